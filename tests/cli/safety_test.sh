# Interrupted runs and protected inputs (the reliability issue): SIGINT and SIGTERM remove what the
# run wrote and exit 130 and 143; a folder output never replaces a file the command reads.
source "$(dirname "$0")/lib.sh"

"$tesswave" samples -o "$dir/s" >/dev/null

# Waits until `pattern` matches at least `count` files under `where` (the job is under way), at
# most about 60 s; returns 1 if it never does (the job finished or failed first).
wait_for_files() {
    local where=$1 pattern=$2 count=$3
    for _ in $(seq 1 600); do
        (($(find "$where" -name "$pattern" 2>/dev/null | wc -l) >= count)) && return 0
        sleep 0.1
    done
    return 1
}

# interrupt SIGNAL CODE DESCRIPTION OUTPUT_FOLDER PATTERN COMMAND...: starts the command, sends the
# signal once PATTERN files exist below OUTPUT_FOLDER, and expects exit CODE, one message line
# and nothing left in OUTPUT_FOLDER (which the test made empty).
interrupt() {
    local signal=$1 code=$2 what=$3 folder=$4 pattern=$5 status=0
    shift 5
    mkdir -p "$folder"
    "$@" >"$dir/out.txt" 2>"$dir/err.txt" &
    local pid=$!
    if ! wait_for_files "$folder" "$pattern" 1; then
        wait "$pid"
        fail "$what: the job ended before it wrote anything ($(tail -1 "$dir/err.txt"))"
        return
    fi
    kill "-$signal" "$pid"
    wait "$pid" || status=$?
    local left
    left=$(find "$folder" -mindepth 1 | head -3)
    if ((status == code)) && [[ -z $left ]] && grep -q "interrupted" "$dir/err.txt"; then
        pass "$what: exit $status, nothing left"
    else
        fail "$what: exit $status (want $code), left: ${left:-nothing}, $(tail -1 "$dir/err.txt")"
    fi
}

interrupt INT 130 "morph to a folder, Ctrl-C" "$dir/m" "*.png" \
    "$tesswave" morph "$dir/s/pair_a.png" "$dir/s/pair_b.png" -o "$dir/m/frames" \
    --frames 2000 --size 320x240
interrupt TERM 143 "encode, SIGTERM" "$dir/e" "*.twv" \
    "$tesswave" encode "$dir/s/clip.mkv" -o "$dir/e/clip.twv" --frames 100000 --sampling fit

# A folder output that holds an input is refused before any work, and the input is untouched.
mkdir -p "$dir/d"
cp "$dir/s/scene.png" "$dir/d/resampled.png"
sum=$(md5sum <"$dir/d/resampled.png")
status=0
"$tesswave" analyze "$dir/d/resampled.png" -o "$dir/d" -y --keep 10 >/dev/null 2>"$dir/err.txt" ||
    status=$?
if ((status != 0)) && [[ $(md5sum <"$dir/d/resampled.png") == "$sum" ]] &&
    [[ $(find "$dir/d" -mindepth 1 | wc -l) == 1 ]]; then
    pass "analyze into the folder of its input refused: $(cat "$dir/err.txt")"
else
    fail "analyze into the folder of its input: exit $status, $(ls "$dir/d" | tr '\n' ' ')"
fi
# The same through a symlink to the folder.
ln -s "$dir/d" "$dir/link"
status=0
"$tesswave" analyze "$dir/d/resampled.png" -o "$dir/link" -y --keep 10 >/dev/null 2>&1 || status=$?
if ((status != 0)) && [[ $(md5sum <"$dir/d/resampled.png") == "$sum" ]]; then
    pass "analyze into a symlink to the folder of its input refused"
else
    fail "analyze through a symlink: exit $status"
fi
# An input named through a symlink inside the output folder (to a file outside it): the output
# would replace the name the user gave, so the run is refused and the link stays.
mkdir -p "$dir/sl"
ln -s "$dir/s/scene.png" "$dir/sl/resampled.png"
status=0
"$tesswave" analyze "$dir/sl/resampled.png" -o "$dir/sl" -y --keep 10 >/dev/null 2>"$dir/err.txt" ||
    status=$?
if ((status != 0)) && [[ -L "$dir/sl/resampled.png" ]] &&
    [[ $(find "$dir/sl" -mindepth 1 | wc -l) == 1 ]]; then
    pass "analyze of a symlink inside its output folder refused: $(cat "$dir/err.txt")"
else
    fail "analyze of a symlink inside its output folder: exit $status, $(ls "$dir/sl" | tr '\n' ' ')"
fi
# A hard link to the input inside the output folder: outputs replace names, never the file.
mkdir -p "$dir/h"
ln "$dir/d/resampled.png" "$dir/h/resampled.png"
check "analyze next to a hard link of its input" \
    "$tesswave" analyze "$dir/s/scene.png" -o "$dir/h" -y --keep 10
if [[ $(md5sum <"$dir/d/resampled.png") == "$sum" ]]; then
    pass "the hard-linked input is unchanged"
else
    fail "the hard-linked input changed"
fi
# An output folder that holds the input under another name (a hard link) is refused.
mkdir -p "$dir/h2/sub"
ln "$dir/d/resampled.png" "$dir/h2/sub/copy.png"
status=0
"$tesswave" analyze "$dir/d/resampled.png" -o "$dir/h2" -y --keep 10 >/dev/null 2>"$dir/err.txt" ||
    status=$?
if ((status == 1)) &&
    grep -q "h2: output folder holds sub/copy.png, a hard link to the input .*d/resampled.png" \
        "$dir/err.txt" && [[ $(find "$dir/h2" -type f | wc -l) == 1 ]]; then
    pass "analyze into a folder holding a hard link of its input refused: $(cat "$dir/err.txt")"
else
    fail "analyze into a folder holding a hard link of its input: exit $status, $(cat "$dir/err.txt")"
fi
# The same input (now three names, none in the output folder) into a folder of other files.
mkdir -p "$dir/h3/sub"
cp "$dir/s/scene.png" "$dir/h3/sub/other.png"
check "analyze a hard-linked input into a folder without its names" \
    "$tesswave" analyze "$dir/d/resampled.png" -o "$dir/h3" -y --keep 10

# -y into an existing folder replaces its frames only: the user's other files stay, and frames of
# an earlier, longer run go (they would pass as part of the sequence).
mkdir -p "$dir/keep/sub"
echo precious >"$dir/keep/notes.txt"
echo x >"$dir/keep/sub/y.txt"
touch "$dir/keep/frame_00007.png"
check "morph -y into a folder with other files" "$tesswave" morph "$dir/s/pair_a.png" \
    "$dir/s/pair_b.png" -o "$dir/keep" --frames 2 --size 64x48 -y
if [[ $(cat "$dir/keep/notes.txt") == precious && -f $dir/keep/sub/y.txt &&
    -f $dir/keep/frame_00001.png && ! -e $dir/keep/frame_00007.png ]]; then
    pass "-y kept the folder's other files and replaced its frames"
else
    fail "-y into a folder: $(find "$dir/keep" | tr '\n' ' ')"
fi

# Nothing dropped silently, every message names its file: a half-cut .mkv (libav reads it to its
# end without an error), a 1x1 image for compare, and running out of memory.
size=$(stat -c %s "$dir/s/clip.mkv")
head -c $((size / 2)) "$dir/s/clip.mkv" >"$dir/half.mkv"
check "encode a half-cut .mkv" "$tesswave" encode "$dir/half.mkv" -o "$dir/half.twv"
if grep -q "half.mkv: the stream ends after [0-9]* frames of the 48 its container declares" \
    "$dir/err.txt"; then
    pass "the cut is said: $(grep half.mkv "$dir/err.txt")"
else
    fail "no warning on the cut .mkv: $(cat "$dir/err.txt")"
fi
status=0
printf 'P6\n1 1\n255\n\x80\x80\x80' >"$dir/one.ppm"
"$tesswave" compare "$dir/one.ppm" -o "$dir/c1" 2>"$dir/err.txt" || status=$?
if ((status == 1)) && grep -q "one.ppm: 1x1 pixels" "$dir/err.txt" && [[ ! -e $dir/c1 ]]; then
    pass "compare of a 1x1 image names it: $(cat "$dir/err.txt")"
else
    fail "compare of a 1x1 image: exit $status: $(cat "$dir/err.txt")"
fi
# Under AddressSanitizer the address-space cap cannot apply (its shadow memory alone is larger).
# gcc links its runtime as libasan.so, clang into the binary.
if ldd "$tesswave" | grep -q libasan || grep -q -a __asan_init "$tesswave"; then
    echo "note: out of memory not checked: the binary is built with AddressSanitizer"
else
    "$tesswave" samples -o "$dir/big" --size 3000x2000 -q
    status=0
    (ulimit -v 1500000 && "$tesswave" compress "$dir/big/scene.png" --density 6 -o "$dir/big.twi") \
        2>"$dir/err.txt" || status=$?
    if ((status == 1)) && grep -q "big/scene.png: out of memory" "$dir/err.txt" && [[ ! -e $dir/big.twi ]]; then
        pass "out of memory names the input: $(cat "$dir/err.txt")"
    else
        fail "out of memory: exit $status: $(cat "$dir/err.txt")"
    fi
fi

finish
