#!/usr/bin/env bash
# The README's commands: installs missing Debian packages, configures, builds, then runs
#   ./run.sh demo       tesswave demo on the built-in samples (outputs in out/demo)
#   ./run.sh test       the whole test suite (warnings as errors)
#   ./run.sh sanitize   the test suite under -fsanitize=address,undefined (clang)
#   ./run.sh fuzz [s]   the libFuzzer targets, s seconds each (clang, address,undefined)
#   ./run.sh bench      the Google Benchmark kernels (Release)
#   ./run.sh fresh      the demo and test commands in a clean Debian 12 root (.ci/fresh-machine)
set -euo pipefail
cd "$(dirname "$0")"
job=${1:-demo}
if [[ $job == fresh ]]; then  # needs nothing from this machine but mmdebstrap
    exec .ci/fresh-machine
fi

packages=(cmake ninja-build g++ pkg-config clang-format ffmpeg
          libopencv-dev libopenimageio-dev libgtest-dev libgmock-dev libbenchmark-dev
          libcli11-dev nlohmann-json3-dev libopenjp2-7-dev libopenjp2-tools
          libceres-dev libdlib-dev libdlib-data
          # OpenImageIO's CMake config names its tools (/usr/bin/iconvert and others).
          openimageio-tools
          libavformat-dev libavcodec-dev libavutil-dev libswscale-dev libavfilter-dev)
missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
    echo "installing: ${missing[*]}"
    sudo=""
    [[ $(id -u) -eq 0 ]] || sudo=sudo
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
        "${missing[@]}" >/dev/null
fi

build() {  # build DIR [cmake options...] [-- build options...]
    local dir=$1 configure=() options=()
    shift
    while (($#)) && [[ $1 != -- ]]; do configure+=("$1"); shift; done
    (($#)) && shift && options=("$@")
    cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release "${configure[@]}" >/dev/null
    cmake --build "$dir" -j "$(nproc)" "${options[@]}"
}
# demo and test configure build/ alike, so that the one reuses what the other compiled.
main_build=(-DTESSWAVE_STRICT=ON -DTESSWAVE_BUILD_TESTS=ON)

case $job in
demo)
    build build "${main_build[@]}" -- --target tesswave
    ./build/apps/tesswave demo -y -o out/demo
    ;;
test)
    build build "${main_build[@]}"
    ctest --test-dir build --output-on-failure --no-tests=error -j "$(nproc)"
    ;;
sanitize|fuzz)
    DEBIAN_FRONTEND=noninteractive $([[ $(id -u) -eq 0 ]] || echo sudo) apt-get install -y -qq clang >/dev/null
    # One clang tree with AddressSanitizer and UBSan (build-fuzz): the whole test suite and the
    # libFuzzer targets. sanitize builds it all and runs every test (about 4 minutes to build and
    # 12 to run on 2 cores); fuzz builds only the four targets (nothing after sanitize).
    fuzzers=(mesh_fuzz points_fuzz twi_fuzz twv_fuzz)
    targets=()
    [[ $job == fuzz ]] && targets=(-- --target "${fuzzers[@]}")
    CXX=clang++ build build-fuzz -DTESSWAVE_BUILD_FUZZERS=ON -DTESSWAVE_BUILD_TESTS=ON "${targets[@]}"
    if [[ $job == sanitize ]]; then
        # Third-party leak suppressions: see the file.
        LSAN_OPTIONS="suppressions=$PWD/tests/lsan.supp" \
            ctest --test-dir build-fuzz --output-on-failure --no-tests=error -j "$(nproc)"
        exit
    fi
    # ./run.sh fuzz [seconds per target]: libFuzzer runs from seeds that the release binary
    # (built by test and demo; a no-op after ./run.sh test) writes.
    build build "${main_build[@]}" -- --target tesswave
    tesswave=./build/apps/tesswave
    mkdir -p build-fuzz/corpus
    $tesswave samples -y -o build-fuzz/corpus >/dev/null
    # .twi seeds: a 40x30 image in every mode, 300 to 2000 bytes, so that each run decodes quickly.
    small=build-fuzz/twi-samples
    $tesswave samples -y --size 40x30 -o $small >/dev/null
    i=0
    for mode in "--bpp 4" "--bpp 4 --aligned" "--bpp 4 --mesh $small/paper_t0.json" \
        "--bpp 4 --grid 53" "--bpp 2 --grid 97" "--lossless" "--lossless --grid 53"; do
        # $mode unquoted: it is several options.
        $tesswave compress $small/scene.png $mode -y \
            -o build-fuzz/corpus/seed$((i++)).twi >/dev/null
    done
    # .twv seeds: 6 frames of the 176x144 sample clip in each mode (lifted groups by default, and
    # low-delay ones), about 2 kB each.
    for mode in "" "--motion none" "--grid 53" "--low-delay" "--low-delay --grid 97 --intra-weight 2"; do
        # $mode unquoted: it is several options.
        $tesswave encode $small/clip.mkv --frames 6 -g 3 --kbps 60 $mode -y \
            -o build-fuzz/corpus/seed$((i++)).twv >/dev/null
    done
    for t in "${fuzzers[@]}"; do
        ./build-fuzz/tests/$t -max_total_time="${2:-60}" -print_final_stats=1 build-fuzz/corpus
    done
    ;;
bench)
    build build -DTESSWAVE_BUILD_BENCHMARKS=ON
    ./build/tests/tesswave_bench "${@:2}"
    ;;
*)
    echo "usage: ./run.sh demo|test|sanitize|fuzz [seconds]|bench|fresh" >&2
    exit 2
    ;;
esac
