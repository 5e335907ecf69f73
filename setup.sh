#!/usr/bin/env bash
# One entry point for a fresh Debian machine (12 bookworm, 13 trixie, unstable).
#   bash setup.sh               install the packages, build, install the Blender add-on, run the demo
#   bash setup.sh test          install the packages, build, run every test (C++ and Blender)
#   bash setup.sh test-blender  the same for the Blender suites (and the module in plain python3) only (the
#                               version matrix in CI)
#   bash setup.sh bench         install the benchmark's extra packages and run the benchmarks
#   bash setup.sh sanitize      clang build with ASan + UBSan + libFuzzer (build-sanitize/): the C++ tests and
#                               the CLI's hostile catalogue, then each fuzz target for FUZZ_SECONDS (default 60)
#   bash setup.sh tsan          clang build with ThreadSanitizer (build-tsan/): the C++ tests
#   bash setup.sh deps          only install the packages
set -euo pipefail
cd "$(dirname "$0")"
mode=${1:-demo}
BUILD=${ARAP_BUILD_DIR:-build}

packages=(build-essential cmake libeigen3-dev libopenmesh-dev nlohmann-json3-dev pybind11-dev python3-dev
          python3-numpy googletest libgtest-dev blender xvfb xauth xdotool imagemagick
          # Blender's own extensions add-on imports these; some Debian releases' blender lacks them.
          python3-requests python3-cattr)
[ "$mode" = bench ] && packages+=(libcgal-dev python3-matplotlib)
# libclang-rt-dev: the sanitizer and libFuzzer runtimes of Debian's default clang.
[ "$mode" = sanitize ] || [ "$mode" = tsan ] && packages+=(clang libclang-rt-dev)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo=sudo
  echo "Installing: ${missing[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

[ "$mode" = deps ] && exit 0

if [ "$mode" = sanitize ]; then
  # Only the native library, CLI, C++ tests and fuzz targets (ARAP_SANITIZE leaves out the
  # Python module, which could not load into Blender, and the benchmarks).
  SBUILD=${ARAP_SANITIZE_BUILD_DIR:-build-sanitize}
  CC=clang CXX=clang++ cmake -S . -B "$SBUILD" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DARAP_FUZZ=ON
  cmake --build "$SBUILD" -j"$(nproc)"
  ctest --test-dir "$SBUILD" --output-on-failure -j"$(nproc)"
  FUZZ_SEED=${FUZZ_SEED:-1} bash native/fuzz/run_fuzzers.sh "$SBUILD" "${FUZZ_SECONDS:-60}"
  exit 0
fi

if [ "$mode" = tsan ]; then
  # Every C++ test under ThreadSanitizer; a report fails the test. die_after_fork=0: the
  # fork test runs the child's helper threads too (TSan would otherwise refuse them).
  TBUILD=${ARAP_TSAN_BUILD_DIR:-build-tsan}
  CC=clang CXX=clang++ cmake -S . -B "$TBUILD" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DARAP_TSAN=ON
  cmake --build "$TBUILD" -j"$(nproc)" --target arap_tests
  TSAN_OPTIONS="halt_on_error=1 die_after_fork=0 ${TSAN_OPTIONS:-}" \
    ctest --test-dir "$TBUILD" --output-on-failure -j"$(nproc)" -L native
  exit 0
fi

configure=(-DCMAKE_BUILD_TYPE=Release)
[ "$mode" = test-blender ] && configure+=(-DARAP_BUILD_BENCH=OFF)
# The benchmark compares with CGAL: with libcgal-dev installed above, a build without it fails the configure.
if [ "$mode" = bench ]; then configure+=(-DARAP_BENCH_REQUIRE_CGAL=ON); else configure+=(-DARAP_BENCH_REQUIRE_CGAL=OFF); fi
cmake -S . -B "$BUILD" "${configure[@]}"
if [ "$mode" = demo ]; then
  # The demo needs the two command-line tools and the add-on: the tests and benchmarks build in
  # `bash setup.sh test` / `bash setup.sh bench`.
  cmake --build "$BUILD" -j"$(nproc)" --target arap-make-mesh arap-deform arap_addon_zip
else
  cmake --build "$BUILD" -j"$(nproc)"
fi

case "$mode" in
  test)
    ctest --test-dir "$BUILD" --output-on-failure -j1
    ;;
  test-blender)
    # The Blender suites and the module in that system's plain python3 (labels blender, python).
    ctest --test-dir "$BUILD" --output-on-failure -j1 -L "blender|python"
    ;;
  demo)
    "$BUILD/arap-make-mesh" bar --vertices 2000 --output "$BUILD/demo_bar.obj" \
      --fixed-out "$BUILD/demo_fixed.txt" --handle-out "$BUILD/demo_handle.txt"
    "$BUILD/arap-deform" "$BUILD/demo_bar.obj" --fixed "$BUILD/demo_fixed.txt" \
      --handle "$BUILD/demo_handle.txt" --translate 2,0,-1 --max-iterations 20 --output "$BUILD/demo_bar_bent.obj"
    cmake --build "$BUILD" --target arap_addon_install
    blender --background -noaudio --python-exit-code 1 --python tools/demo_pose.py -- "$BUILD/demo"
    ;;
  bench)
    cmake --build "$BUILD" --target run_benchmarks
    blender --background --factory-startup -noaudio --python-exit-code 1 --python bench/blender/bench_live.py -- \
      --addon-dir "$BUILD/addon" --sizes 10000,50000,200000 --frames 20 --output "$BUILD/results"
    ;;
  *)
    echo "usage: bash setup.sh [test|test-blender|bench|sanitize|tsan|deps]" >&2
    exit 2
    ;;
esac
