#!/usr/bin/env bash
# The commands a new user tries first, with no options, on the procedural samples: each succeeds and
# writes a file that decodes; --lossless gives the image back bit for bit or is refused (exit 2, no
# file); a quality target out of reach is a warning, not a failure.
#   first_run_test.sh TESSWAVE_BINARY
source "$(dirname "$0")/lib.sh"
same_pixels() {  # same_pixels A B: the two images have identical pixel values
    "$tesswave" compress "$1" --lossless --grid 53 -o "$dir/a.twi" -y >/dev/null 2>&1 &&
        "$tesswave" compress "$2" --lossless --grid 53 -o "$dir/b.twi" -y >/dev/null 2>&1 &&
        cmp -s "$dir/a.twi" "$dir/b.twi"
}

check "samples" "$tesswave" samples -o "$dir/s" --size 96x64
for image in scene.png scene_grey.png scene_16bit.tif scene_rgba.png; do
    check "compress $image with no options" \
        "$tesswave" compress "$dir/s/$image" -o "$dir/$image.twi"
    check "decompress it" "$tesswave" decompress "$dir/$image.twi" -o "$dir/$image.back.png"
    for transform in "" "--grid 53"; do
        # $transform unquoted: empty or two words.
        check "compress $image --lossless $transform" \
            "$tesswave" compress "$dir/s/$image" --lossless $transform -o "$dir/ll.twi" -y
        check "decompress the lossless file" \
            "$tesswave" decompress "$dir/ll.twi" -o "$dir/ll.tif" -y
        # The decoded pixels equal the input's: the two lossless 5/3 files of them are the same.
        check "$image --lossless $transform gives the image back bit for bit" \
            same_pixels "$dir/s/$image" "$dir/ll.tif"
    done
done
check "a mesh file" "$tesswave" mesh grid --cells 6x4 --like "$dir/s/scene.png" -o "$dir/m.json"
refuse "--lossless with a --mesh file" "$dir/refused.twi" \
    "$tesswave" compress "$dir/s/scene.png" --lossless --mesh "$dir/m.json" -o "$dir/refused.twi"
refuse "--lossless with the 9/7" "$dir/refused.twi" \
    "$tesswave" compress "$dir/s/scene.png" --lossless --grid 97 -o "$dir/refused.twi"
check "a PSNR target out of the mesh's reach" \
    "$tesswave" compress "$dir/s/scene.png" --psnr 90 -o "$dir/high.twi"
if grep -q "out of reach" "$dir/err.txt" && [[ -s $dir/high.twi ]]; then
    pass "it warns and writes the whole stream"
else
    fail "no warning or no file for an unreachable --psnr"
fi
check "encode the sample clip with no rate option" \
    "$tesswave" encode "$dir/s/clip.mkv" --frames 8 -o "$dir/clip.twv"
check "decode it" "$tesswave" decode "$dir/clip.twv" -o "$dir/clip.mkv"
finish
