#!/usr/bin/env bash
# Quick start 1: install what is missing, build (Release) and run nephos on the embedded GFS
# sample. Outputs land in out/. Extra arguments are passed to `nephos masks`.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$here/scripts/setup.sh"
cd "$here"
exec build/apps/nephos/nephos masks --out out "$@"
