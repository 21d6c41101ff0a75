#!/usr/bin/env bash
# Builds the sprite renderer's check for a lent GPU machine (docs/PERFORMANCE.md, sprite section),
# which has no Debian packages and so cannot run the nephos program: a portable build
# (x86-64-v3 instead of this machine's -march=native) of realtime_test and nephos_gpu_check in
# build-gpu/, then .gpu/ with the two programs, the shared libraries they load other than the C
# and C++ runtimes, and ecCodes' definitions (about 15 MiB). Then, on the device, from the
# repository root with .gpu carried: `bash scripts/gpu_check.sh`. Run scripts/setup.sh first.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$here"
cmake -S . -B build-gpu -DCMAKE_BUILD_TYPE=Release -DNEPHOS_NATIVE=OFF -DCMAKE_CXX_FLAGS=-march=x86-64-v3 \
  -DCMAKE_EXE_LINKER_FLAGS=-Wl,--as-needed >/dev/null
cmake --build build-gpu --target realtime_test nephos_gpu_check -j"$(nproc 2>/dev/null || echo 2)"
rm -rf .gpu
mkdir -p .gpu/lib
cp build-gpu/src/nephos/realtime/realtime_test build-gpu/bench/nephos_gpu_check .gpu/
strip .gpu/realtime_test .gpu/nephos_gpu_check
for exe in .gpu/realtime_test .gpu/nephos_gpu_check; do ldd "$exe" | awk '/=> \// {print $3}'; done | sort -u |
  while read -r lib; do
    case "$(basename "$lib")" in
      libc.so* | libm.so* | libstdc++.so* | libgcc_s.so* | ld-linux* | libpthread.so* | libdl.so* | librt.so*) ;;
      *) cp -L "$lib" .gpu/lib/ ;;
    esac
  done
tar -C /usr/share/eccodes -czf .gpu/eccodes_definitions.tar.gz definitions
echo "$here" >.gpu/source_dir  # the tests find data/ through the path compiled in
echo "gpu_kit: $(du -sh .gpu | cut -f1) in .gpu ($(find .gpu/lib -type f | wc -l) libraries)"
