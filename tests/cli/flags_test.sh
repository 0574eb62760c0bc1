#!/usr/bin/env bash
# One flag, one meaning: the shared flags behave alike in every subcommand, and a bad option is
# refused with exit 2 and one line before any output appears.
#   flags_test.sh TESSWAVE_BINARY
source "$(dirname "$0")/lib.sh"

check "samples" "$tesswave" samples -o "$dir/s" --size 96x64
s=$dir/s
# --mesh: a file or a generator, in compress and analyze alike.
check "a mesh file" "$tesswave" mesh grid --cells 6x4 --like "$s/scene.png" -o "$dir/m.json"
for mesh in "$dir/m.json" grid:6x4 voronoi:20; do
    check "compress --mesh $mesh" "$tesswave" compress "$s/scene.png" --mesh "$mesh" -o "$dir/c.twi" -y
    check "analyze --mesh $mesh" "$tesswave" analyze "$s/scene.png" --mesh "$mesh" -o "$dir/an" -y
done
refuse "compress --mesh voronoi:x" "$dir/bad.twi" \
    "$tesswave" compress "$s/scene.png" --mesh voronoi:x -o "$dir/bad.twi"
refuse "morph --mesh with a file" "$dir/bad.mp4" \
    "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" --mesh "$dir/m.json" -o "$dir/bad.mp4"
# -J, --levels and --density in every subcommand that takes them.
check "mesh draw -J 2" "$tesswave" mesh draw "$dir/m.json" -J 2 -o "$dir/m.png"
refuse "--density 20" "$dir/bad.twi" \
    "$tesswave" compress "$s/scene.png" --density 20 -o "$dir/bad.twi"
refuse "encode --density 0" "$dir/bad.twv" \
    "$tesswave" encode "$s/clip.mkv" --density 0 -o "$dir/bad.twv"
# --psnr in compress and encode; --frames a count; --range in decode; --at in morph and inbetween.
check "encode --psnr 28 --frames 4" \
    "$tesswave" encode "$s/clip.mkv" --psnr 28 --frames 4 -o "$dir/c.twv"
check "decode --range 1:2" "$tesswave" decode "$dir/c.twv" --range 1:2 -o "$dir/r"
if (($(ls "$dir/r" | wc -l) == 2)); then pass "two frames decoded"; else fail "not two frames"; fi
refuse "decode --range 3:1" "$dir/r2" "$tesswave" decode "$dir/c.twv" --range 3:1 -o "$dir/r2"
check "morph --at 0.5" \
    "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" --points-a "$s/pair_a.txt" \
    --points-b "$s/pair_b.txt" --at 0.5 -o "$dir/mid.png"
# A morph whose mesh would pass the sample limit is refused before the matching (it failed after
# it, naming no file), naming what sets the size.
status=0
"$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" --size 8000x8000 -o "$dir/big.mp4" \
    >/dev/null 2>"$dir/err.txt" || status=$?
if ((status == 1)) && [[ ! -e $dir/big.mp4 ]] && grep -q "^tesswave: --size 8000x8000: .*mesh samples" "$dir/err.txt"; then
    pass "a morph past the sample limit refused: $(cat "$dir/err.txt")"
else
    fail "a morph past the sample limit: exit $status, $(cat "$dir/err.txt")"
fi
# Past the limit by the mesh's exact count (the estimate, 59 M samples, could still fit): refused
# once the pair's mesh is known, before the morph is built.
status=0
"$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" --size 7000x7000 --density 1.2 \
    -o "$dir/big2.mp4" >/dev/null 2>"$dir/err.txt" || status=$?
if ((status == 1)) && [[ ! -e $dir/big2.mp4 ]] &&
    grep -q "^tesswave: --size 7000x7000: .* on this mesh has .* samples at level" "$dir/err.txt"; then
    pass "a morph past the limit by its mesh refused: $(tail -1 "$dir/err.txt")"
else
    fail "a morph past the limit by its mesh: exit $status, $(cat "$dir/err.txt")"
fi
# analyze on a mesh as dense as the pixels: its mesh picture draws the levels it can show (it
# drew three and failed at the end: "draw: level 1 has 1438721 edges ...").
check "samples 400x300" "$tesswave" samples -o "$dir/s400" --size 400x300
check "analyze on a mesh as dense as the pixels" "$tesswave" analyze "$dir/s400/scene.png" \
    --mesh voronoi:120000 -J 1 --keep 10 -o "$dir/dense"
[[ -s $dir/dense/mesh.png ]] && pass "its mesh picture is written" || fail "no mesh picture"
# An SVG past 10 MB is said to be one (a 4-face mesh at -J 8: 38 MB without a word).
check "mesh grid 2x2" "$tesswave" mesh grid --cells 2x2 --size 64x48 -o "$dir/m22.json"
check "mesh draw -J 8 to SVG" "$tesswave" mesh draw "$dir/m22.json" -J 8 -o "$dir/m22.svg"
grep -q "^warning: .*m22.svg: T0 and 8 refinement levels make an SVG of 3[0-9] MB" "$dir/err.txt" &&
    pass "the SVG's size is said: $(cat "$dir/err.txt")" || fail "no SVG size warning"
check "inbetween --at 0.5" "$tesswave" inbetween "$s/pair_a.png" "$s/pair_b.png" --at 0.5 \
    -o "$dir/ib.png"
refuse "morph --frames 0" "$dir/bad.gif" \
    "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" --frames 0 -o "$dir/bad.gif"
# Frames go to one writer: unknown extensions are refused before any work.
refuse "decode -o x.webm" "$dir/x.webm" "$tesswave" decode "$dir/c.twv" -o "$dir/x.webm"
refuse "morph -o x.avi" "$dir/x.avi" \
    "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" -o "$dir/x.avi"
check "decode to a GIF" "$tesswave" decode "$dir/c.twv" -o "$dir/c.gif"
# Lists: comma-separated or repeated.
refuse "analyze --keep 200" "$dir/an2" "$tesswave" analyze "$s/scene.png" --keep 10,200 -o "$dir/an2"
check "analyze --keep 10 --keep 1" \
    "$tesswave" analyze "$s/scene.png" --keep 10 --keep 1 -o "$dir/an" -y --json
if grep -q '"keep_percent": 1' "$dir/out.txt"; then pass "both percentages kept"; else fail "--keep"; fi
# -q: nothing but errors (and --json); -v: a line per stage; both before or after the subcommand.
check "-q compress" "$tesswave" compress "$s/scene.png" -o "$dir/q.twi" -q
if [[ ! -s $dir/out.txt && ! -s $dir/err.txt ]]; then pass "-q is silent"; else fail "-q printed"; fi
# The kind of an output follows from its extension: a mismatch is refused before any work.
refuse "compress -o x.png" "$dir/x.png" "$tesswave" compress "$s/scene.png" -o "$dir/x.png"
refuse "encode -o x.mp4" "$dir/x.mp4" "$tesswave" encode "$s/clip.mkv" -o "$dir/x.mp4"
refuse "mesh grid -o x.png" "$dir/x.png" "$tesswave" mesh grid --cells 4x3 -o "$dir/x.png"
refuse "inbetween -o a folder" "$dir/ib" "$tesswave" inbetween "$s/pair_a.png" "$s/pair_b.png" \
    -o "$dir/ib"

# The mesh generators' limits are --mesh's: no cell smaller than a pixel, at most 10^6 sites; a
# few border points a side (their work grows with the square of the count).
refuse "mesh grid finer than the pixels" "$dir/g.json" "$tesswave" mesh grid --cells 100x10 \
    --size 64x48 -o "$dir/g.json"
refuse "mesh voronoi -n 5000 on 64x48" "$dir/v.json" "$tesswave" mesh voronoi -n 5000 \
    --size 64x48 -o "$dir/v.json"
printf '10 10\n20 30\n40 20\n' >"$dir/three.txt"
refuse "mesh triangulate --border-points 5000" "$dir/t.json" "$tesswave" mesh triangulate \
    "$dir/three.txt" --size 64x48 --border-points 5000 -o "$dir/t.json"

# Checked before the work, not after it: a folder where a file goes, a GIF's frame rate.
mkdir -p "$dir/afolder.twi"
status=0
"$tesswave" compress "$s/scene.png" -o "$dir/afolder.twi" -y 2>"$dir/err.txt" || status=$?
if ((status == 1)) && grep -q "is a folder, and the output is a file" "$dir/err.txt"; then
    pass "a folder where the .twi goes is refused: $(cat "$dir/err.txt")"
else
    fail "a folder where the .twi goes: exit $status, $(cat "$dir/err.txt")"
fi
refuse "morph --fps 500 to a GIF" "$dir/fast.gif" "$tesswave" morph "$s/pair_a.png" \
    "$s/pair_b.png" --fps 500 -o "$dir/fast.gif"

# A mistyped command is named, with the nearest one; an empty point list is no triangulation.
status=0
"$tesswave" comprss "$s/scene.png" 2>"$dir/err.txt" || status=$?
if ((status == 2)) && grep -q "unknown command 'comprss' (did you mean 'compress'?)" "$dir/err.txt"; then
    pass "a mistyped command: $(cat "$dir/err.txt")"
else
    fail "a mistyped command: exit $status, $(cat "$dir/err.txt")"
fi
: >"$dir/none.txt"
status=0
"$tesswave" mesh triangulate "$dir/none.txt" --size 64x48 -o "$dir/none.json" 2>"$dir/err.txt" ||
    status=$?
if ((status == 1)) && grep -q "none.txt: no points" "$dir/err.txt" && [[ ! -e $dir/none.json ]]; then
    pass "an empty point list: $(cat "$dir/err.txt")"
else
    fail "an empty point list: exit $status, $(cat "$dir/err.txt")"
fi

# A refinement level with more edges than the picture has pixels is refused before the
# hierarchy is built (a 2000-cell mesh at level 6 took 3.7 GB).
"$tesswave" mesh voronoi -n 200 --size 256x192 -o "$dir/v200.json" >/dev/null 2>&1
status=0
"$tesswave" mesh draw "$dir/v200.json" -J 6 -o "$dir/v200.png" 2>"$dir/err.txt" || status=$?
if ((status == 1)) && grep -q "v200.json: draw: level 6 has" "$dir/err.txt" && [[ ! -e $dir/v200.png ]]; then
    pass "mesh draw too fine for the picture: $(cat "$dir/err.txt")"
else
    fail "mesh draw too fine: exit $status, $(cat "$dir/err.txt")"
fi

# mesh validate shows three problems of a kind, then how many more there are.
printf '{"domain":[10,10],"vertices":[[0,0],[10,0],[10,10],[0,10],[5,5],[20,20],[21,20],[22,20],[23,20],[24,20]],"faces":[[0,1,4],[1,2,4],[2,3,4],[3,0,4]]}' \
    >"$dir/outside.json"
"$tesswave" mesh validate "$dir/outside.json" 2>"$dir/err.txt"
if (($(grep -c "outside the domain" "$dir/err.txt") == 4)) && grep -q '2 more like "vertex #' "$dir/err.txt"; then
    pass "mesh validate groups the problems of a kind"
else
    fail "mesh validate: $(cat "$dir/err.txt")"
fi

# Options of another path are refused, not ignored.
refuse "compress --grid 97 --density 2" "$dir/g97.twi" "$tesswave" compress "$s/scene.png" \
    --grid 97 --density 2 -o "$dir/g97.twi"
refuse "encode --intra-weight without --low-delay" "$dir/iw.twv" "$tesswave" encode \
    "$s/clip.mkv" --intra-weight 3 -o "$dir/iw.twv"

# NaN is no number for any option (CLI11's ranges let it through: every comparison is false).
refuse "compress --psnr nan" "$dir/nan.twi" "$tesswave" compress "$s/scene.png" --psnr nan \
    -o "$dir/nan.twi"
refuse "analyze --keep 10,nan" "$dir/nan" "$tesswave" analyze "$s/scene.png" --keep 10,nan \
    -o "$dir/nan"
refuse "morph --fps NaN" "$dir/nan.mp4" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" \
    --fps NaN -o "$dir/nan.mp4"
# A rate that rounds to no byte is no rate (it used to mean the whole stream, or lossless).
status=0
"$tesswave" compress "$s/scene.png" --bpp 1e-9 -o "$dir/tiny.twi" 2>"$dir/err.txt" || status=$?
if ((status == 1)) && grep -q "does not hold the" "$dir/err.txt" && [[ ! -e $dir/tiny.twi ]]; then
    pass "compress --bpp 1e-9 refused: $(cat "$dir/err.txt")"
else
    fail "compress --bpp 1e-9: exit $status, $(cat "$dir/err.txt")"
fi
status=0
"$tesswave" compare "$s/scene.png" --bpp 0.00001 -o "$dir/tiny" 2>"$dir/err.txt" || status=$?
if ((status == 1)) && grep -q "scene.png: --bpp 1e-05" "$dir/err.txt" && [[ ! -e $dir/tiny ]]; then
    pass "compare --bpp 0.00001 refused, nothing left: $(cat "$dir/err.txt")"
else
    fail "compare --bpp 0.00001: exit $status, left: $(ls "$dir/tiny" 2>&1), $(cat "$dir/err.txt")"
fi
check "-q compress --psnr 90" "$tesswave" -q compress "$s/scene.png" --psnr 90 -o "$dir/q.twi" -y
if [[ ! -s $dir/err.txt ]]; then pass "-q hides the warning"; else fail "-q warned"; fi
check "-v compress" "$tesswave" -v compress "$s/scene.png" -o "$dir/v.twi"
if grep -q "coding" "$dir/err.txt"; then pass "-v names the stages"; else fail "-v silent"; fi
# Options that would not be used are refused, not ignored.
refuse "morph --at with --frames" "$dir/at.png" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" \
    --at 0.5 --frames 10 -o "$dir/at.png"
refuse "morph --crf to a GIF" "$dir/crf.gif" "$tesswave" morph "$s/pair_a.png" "$s/pair_b.png" \
    --crf 20 -o "$dir/crf.gif"
refuse "decode --preset to PNG frames" "$dir/pf" "$tesswave" decode "$dir/c.twv" --preset slow \
    -o "$dir/pf"
refuse "encode --size for a video file" "$dir/sz.twv" "$tesswave" encode "$s/clip.mkv" \
    --size 64x48 -o "$dir/sz.twv"
refuse "compare-video --pix-fmt for a video file" "$dir/cv" "$tesswave" compare-video \
    "$s/clip.mkv" --pix-fmt gray -o "$dir/cv"
# A command that reads and writes no image file does not load OpenImageIO (0.3 s and 100 MB of
# libraries at start-up); one that does loads it. Sanitizer builds link it in (CMakeLists.txt).
if [[ ${TESSWAVE_IMAGE_MODULE:-1} == 1 ]]; then
    LD_DEBUG=files "$tesswave" info "$dir/c.twv" >/dev/null 2>"$dir/ld.txt"
    if grep -q libOpenImageIO "$dir/ld.txt"; then
        fail "info loaded OpenImageIO"
    else
        pass "info without OpenImageIO"
    fi
    LD_DEBUG=files "$tesswave" compress "$s/scene.png" -o "$dir/ld.twi" -y >/dev/null 2>"$dir/ld.txt"
    if grep -q libOpenImageIO "$dir/ld.txt"; then
        pass "compress loads OpenImageIO"
    else
        fail "compress: no OpenImageIO"
    fi
    # decompress of a file it refuses: the output's name (.png) is checked without the module.
    head -c 40 "$dir/ld.twi" >"$dir/cut.twi"
    status=0
    LD_DEBUG=files "$tesswave" decompress "$dir/cut.twi" -o "$dir/cut.png" >/dev/null \
        2>"$dir/ld.txt" || status=$?
    if ((status == 1)) && ! grep -q libOpenImageIO "$dir/ld.txt"; then
        pass "decompress of a cut file refused without OpenImageIO"
    else
        fail "decompress of a cut file: exit $status, OpenImageIO $(grep -c libOpenImageIO "$dir/ld.txt")"
    fi
fi
finish
