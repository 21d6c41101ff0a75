#!/usr/bin/env bash
# The sprite renderer's check on a lent GPU machine, run there from the repository root with .gpu
# carried (scripts/gpu_kit.sh makes it): the realtime tests three times in a row, then (unless the
# first argument is `tests`) frames to compare with llvmpipe's and `bench fly`'s matrix. Writes
# to $OUT (the device tool's folder), else out/gpu. Back here, the frames against llvmpipe's:
#   mkdir -p /tmp/gpu && tar -C /tmp/gpu -xf frames.tar
#   LD_LIBRARY_PATH=.gpu/lib .gpu/nephos_gpu_check frames /tmp/cpu
#   LD_LIBRARY_PATH=.gpu/lib .gpu/nephos_gpu_check compare /tmp/gpu /tmp/cpu
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.." || exit 1
out=${OUT:-out/gpu}
mkdir -p "$out"
export LD_LIBRARY_PATH=$PWD/.gpu/lib
vendor=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
[ -f "$vendor" ] && export __EGL_VENDOR_LIBRARY_FILENAMES=$vendor
src=$(cat .gpu/source_dir)
[ -e "$src" ] || { mkdir -p "$(dirname "$src")" && ln -s "$PWD" "$src"; }
mkdir -p /tmp/nephos_eccodes && tar -C /tmp/nephos_eccodes -xzf .gpu/eccodes_definitions.tar.gz
export ECCODES_DEFINITION_PATH=/tmp/nephos_eccodes/definitions
nvidia-smi -L 2>/dev/null
echo "== realtime_test, three times"
timeout 300 .gpu/realtime_test --gtest_brief=1 --gtest_repeat=3 >"$out/realtime_test.txt" 2>&1
echo "exit status $?"
grep -E "PASSED|FAILED|Failure" "$out/realtime_test.txt" | tail -30
[ "${1:-}" = tests ] && exit 0
echo "== frames"
rm -rf /tmp/nephos_frames
timeout 150 .gpu/nephos_gpu_check frames /tmp/nephos_frames && tar -C /tmp/nephos_frames -cf "$out/frames.tar" .
echo "== bench fly"
timeout 300 .gpu/nephos_gpu_check bench "$out" 600 2>&1 | tee "$out/bench_fly.txt"
