#!/usr/bin/env bash
# Quick start 2: install what is missing, build (Release) and run the whole test suite.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$here/scripts/setup.sh"
cd "$here/build"
ctest --output-on-failure -j"$(nproc 2>/dev/null || echo 2)" "$@"
