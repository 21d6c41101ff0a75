#!/usr/bin/env bash
# Quick start 1: install what is missing, build (Release) and run nephos on the embedded GFS
# sample: the cloud weather masks (out/masks/) and a GOES-East full-disc render of all four
# cloud types in three bands (out/). Extra arguments are passed to `nephos render`.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$here/scripts/setup.sh"
cd "$here"
build/apps/nephos/nephos masks --out out/masks
exec build/apps/nephos/nephos render --out out "$@"
