#!/usr/bin/env bash
# Morphs as a new user starts them: point files that cross, CRLF and a BOM, --auto on images
# without a face (flow and features), --faces where there is none (refused, naming the image).
#   morph_test.sh TESSWAVE_BINARY
source "$(dirname "$0")/lib.sh"

check "samples" "$tesswave" samples -o "$dir/s" --size 96x64
s=$dir/s
# Two swapped points cross in B: the morph still runs, and says in one line what it left out.
awk 'NR == 2 { keep = $0; getline; print; print keep; next } { print }' "$s/pair_b.txt" \
    >"$dir/swapped.txt"
check "crossing points" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" \
    --points-a "$s/pair_a.txt" --points-b "$dir/swapped.txt" --at 0.5 -o "$dir/mid.png"
if grep -q "^note: left out [12] of" "$dir/err.txt"; then
    pass "the left-out points are named: $(cat "$dir/err.txt")"
else
    fail "no note on the left-out points: $(cat "$dir/err.txt")"
fi
# Windows line ends and a UTF-8 BOM, as landmark tools on Windows write them.
printf '\xef\xbb\xbf' >"$dir/crlf_a.txt"
sed 's/$/\r/' "$s/pair_a.txt" >>"$dir/crlf_a.txt"
sed 's/$/\r/' "$s/pair_b.txt" >"$dir/crlf_b.txt"
check "points with CRLF and a BOM" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" \
    --points-a "$dir/crlf_a.txt" --points-b "$dir/crlf_b.txt" --at 0.5 -o "$dir/crlf.png"
"$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" --points-a "$s/pair_a.txt" \
    --points-b "$s/pair_b.txt" --at 0.5 -o "$dir/plain.png" -q
if cmp -s "$dir/crlf.png" "$dir/plain.png"; then
    pass "CRLF and BOM read as plain lines"
else
    fail "CRLF and BOM change the morph"
fi
# No face in the procedural pair: --auto falls back to flow and features, --faces refuses.
if "$tesswave" morph --help | grep -q "not in this build"; then
    check "--auto without dlib" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" --at 0.5 \
        -o "$dir/auto.png"
else
    check "--auto, no face" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" --at 0.5 \
        -o "$dir/auto.png"
    if grep -q "pair_a.png: no face found; using flow and features" "$dir/err.txt"; then
        pass "the fallback is said"
    else
        fail "no note on the fallback: $(cat "$dir/err.txt")"
    fi
fi
status=0
"$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" --faces --at 0.5 -o "$dir/faces.png" \
    2>"$dir/err.txt" || status=$?
if ((status == 1)) && [[ ! -e $dir/faces.png ]] && (($(wc -l <"$dir/err.txt") == 1)) &&
    grep -q -e "pair_a.png: no face found" -e "dlib" "$dir/err.txt"; then
    pass "--faces without a face refused: $(cat "$dir/err.txt")"
else
    fail "--faces without a face: exit $status: $(cat "$dir/err.txt")"
fi
# Images with nothing in common (a flat one): no mesh can follow them, so the morph keeps the
# shapes at rest, dissolves band by band, and says so; it is not refused.
{
    printf 'P6\n96 64\n255\n'
    head -c $((96 * 64 * 3)) /dev/zero | tr '\0' '\200'
} >"$dir/flat.ppm"
check "--auto, nothing in common" "$tesswave" morph "$s/pair_a.png" "$dir/flat.ppm" --at 0.5 \
    -o "$dir/rest.png"
if [[ -s $dir/rest.png ]] && grep -q "no motion: the morph dissolves them band by band" "$dir/err.txt"; then
    pass "a morph at rest, and the note says why: $(tail -n 1 "$dir/err.txt")"
else
    fail "no morph at rest: $(cat "$dir/err.txt")"
fi
# --loop: A to B and back in 2N - 2 frames, PNG names with a zero-padded counter; --crf for MP4.
check "morph --loop to PNG frames" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" \
    --points-a "$s/pair_a.txt" --points-b "$s/pair_b.txt" --frames 4 --loop -o "$dir/loop"
if [[ "$(ls "$dir/loop" | tr '\n' ' ')" == "frame_00000.png frame_00001.png frame_00002.png frame_00003.png frame_00004.png frame_00005.png " ]] &&
    cmp -s "$dir/loop/frame_00001.png" "$dir/loop/frame_00005.png" &&
    cmp -s "$dir/loop/frame_00002.png" "$dir/loop/frame_00004.png"; then
    pass "six frames, the way back mirrors the way there"
else
    fail "loop frames: $(ls "$dir/loop" | tr '\n' ' ')"
fi
check "morph --crf 40" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" --points-a "$s/pair_a.txt" \
    --points-b "$s/pair_b.txt" --frames 6 --crf 40 -o "$dir/low.mp4"
check "morph --crf 10" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" --points-a "$s/pair_a.txt" \
    --points-b "$s/pair_b.txt" --frames 6 --crf 10 -o "$dir/high.mp4"
if (($(stat -c %s "$dir/low.mp4") < $(stat -c %s "$dir/high.mp4"))); then
    pass "--crf 40 is smaller than --crf 10"
else
    fail "--crf does not change the size"
fi
refuse "morph --crf 60" "$dir/bad.mp4" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" \
    --crf 60 -o "$dir/bad.mp4"
# --preset: x264's speed preset; at one CRF, slower presets make smaller files.
check "morph --preset ultrafast" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" \
    --points-a "$s/pair_a.txt" --points-b "$s/pair_b.txt" --frames 6 --preset ultrafast \
    -o "$dir/ultrafast.mp4"
check "morph --preset slow" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" \
    --points-a "$s/pair_a.txt" --points-b "$s/pair_b.txt" --frames 6 --preset slow -o "$dir/slow.mp4"
if (($(stat -c %s "$dir/slow.mp4") < $(stat -c %s "$dir/ultrafast.mp4"))); then
    pass "--preset slow is smaller than --preset ultrafast"
else
    fail "--preset does not change the size"
fi
refuse "morph --preset turbo" "$dir/bad.mp4" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" \
    --preset turbo -o "$dir/bad.mp4"
# --threads: the same frames on one core and on three.
for t in 1 3; do
    check "morph --threads $t" "$tesswave" --threads $t morph "$s/pair_a.png" "$s/pair_b.png" \
        --points-a "$s/pair_a.txt" --points-b "$s/pair_b.txt" --frames 3 -o "$dir/threads$t"
done
if cmp -s "$dir/threads1/frame_00001.png" "$dir/threads3/frame_00001.png"; then
    pass "--threads 1 and 3 give the same frames"
else
    fail "--threads changes the frames"
fi
refuse "--threads -1" "$dir/bad.png" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" \
    --threads -1 --at 0.5 -o "$dir/bad.png"
# compare-morph: a sheet and, for scripts, the measures of the five methods.
check "compare-morph" "$tesswave" compare-morph "$s/pair_a.png" "$s/pair_b.png" \
    --points-a "$s/pair_a.txt" --points-b "$s/pair_b.txt" -o "$dir/sheet.png" --json
if [[ -s $dir/sheet.png ]] && grep -q '"aware (default)"' "$dir/out.txt" &&
    grep -q '"classic"' "$dir/out.txt" && grep -q '"ghost"' "$dir/out.txt"; then
    pass "compare-morph wrote the sheet and the measures"
else
    fail "compare-morph: $(head -c 300 "$dir/out.txt")"
fi
refuse "compare-morph -o x.mp4" "$dir/x.mp4" "$tesswave" compare-morph "$s/pair_a.png" \
    "$s/pair_b.png" -o "$dir/x.mp4"
finish
