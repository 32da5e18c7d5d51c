#!/usr/bin/env bash
# Coverage-guided fuzzing of one reader with libFuzzer (clang-14, ASan + UBSan).
#   scripts/fuzz.sh TARGET SECONDS [extra libFuzzer flags]
# TARGET: nrrd nhdr metaimage nifti vti raw_sidecar labels dicom control_points keyframes style curve
#         scene script
# The seed corpus is fuzz/corpus/TARGET (read only); new inputs go to build-fuzz/corpus/TARGET;
# crashes, hangs (> 5 s) and out-of-memory (> 2 GB) land in build-fuzz/findings/TARGET: keep
# each fixed one under tests/fuzz-regressions/TARGET (ctest replays them).
set -euo pipefail
cd "$(dirname "$0")/.."
target=${1:?usage: scripts/fuzz.sh TARGET SECONDS}
seconds=${2:?usage: scripts/fuzz.sh TARGET SECONDS}
shift 2

need=()
for p in clang-14 libclang-rt-14-dev; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || need+=("$p")
done
if ((${#need[@]})); then
  apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${need[@]}"
fi

BUILD_DIR=${BUILD_DIR:-build-fuzz}
CC=clang-14 CXX=clang++-14 cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DVELLUM_FUZZ=ON -DVELLUM_BUILD_TESTS=OFF -DVELLUM_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build "$BUILD_DIR" -j "${JOBS:-$(nproc)}" --target "vellum_fuzz_$target"

corpus="$BUILD_DIR/corpus/$target" findings="$BUILD_DIR/findings/$target"
mkdir -p "$corpus" "$findings"
dict=()
[ -f "fuzz/dict/$target.dict" ] && dict=(-dict="fuzz/dict/$target.dict")
seeds=()
[ -d "fuzz/corpus/$target" ] && seeds=("fuzz/corpus/$target")
ASAN_OPTIONS=detect_leaks=0 "$BUILD_DIR/fuzz/vellum_fuzz_$target" "$corpus" "${seeds[@]}" \
  "${dict[@]}" -max_total_time="$seconds" -timeout=5 -rss_limit_mb=2048 \
  -artifact_prefix="$findings/" -print_final_stats=1 "$@"
