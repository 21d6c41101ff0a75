#!/usr/bin/env bash
# Compares what this checkout's nephos writes with what an earlier commit's writes, file by
# file: renders, lattice-Boltzmann fields, flight frames, particles and masks of small runs on
# the embedded GFS sample. Usage: scripts/compare_outputs.sh COMMIT [WORK_DIR]
#   COMMIT    the commit to compare with (built in WORK_DIR/ref, tests and Python off)
#   WORK_DIR  where the reference checkout, its build and both runs' outputs go
#             (default: a new directory under /tmp)
# Prints one line per file (same / text / DIFFERS) and exits 1 if any file's data differ; "text"
# marks a file whose data are identical and whose descriptive text (a NetCDF file's title,
# comment, history or source attribute, a PLY file's comment lines) is not. Left out of the
# byte comparison, and why: the frames.csv columns that are wall-clock times (the others are
# compared) and clouds.vdb (OpenVDB stamps every file with a new UUID; its grids are the
# fields of lbm.nc, which is compared).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
ref_commit=${1:?usage: scripts/compare_outputs.sh COMMIT [WORK_DIR]}
work=${2:-$(mktemp -d /tmp/nephos-compare.XXXXXX)}
mkdir -p "$work"
jobs=$(nproc 2>/dev/null || echo 2)

"$here/scripts/setup.sh" >/dev/null
if [ ! -x "$work/ref/build/apps/nephos/nephos" ]; then
  echo "building $ref_commit in $work/ref (a few minutes)" >&2
  rm -rf "$work/ref"
  git -C "$here" worktree add --detach "$work/ref" "$ref_commit" >/dev/null
  cmake -S "$work/ref" -B "$work/ref/build" -DCMAKE_BUILD_TYPE=Release -DNEPHOS_BUILD_TESTS=OFF \
    -DNEPHOS_BUILD_PYTHON=OFF >/dev/null
  cmake --build "$work/ref/build" -j"$jobs" --target nephos >/dev/null
fi

# The runs: every output family, small enough for a minute each on two cores.
run_all() {
  local nephos=$1 out=$2
  # Both programs read the same sample (its path is recorded in the outputs).
  export NEPHOS_DATA_DIR="$here/data"
  rm -rf "$out"
  mkdir -p "$out"
  "$nephos" -q masks --out "$out/masks" >/dev/null
  "$nephos" -q render --size 120x120 --texture 64 --bands vis,nir,lwir,mwir --out "$out/render_geo" >/dev/null
  "$nephos" -q --seed 5 render --sensor leo:-5,-30,700,12 --size 96x64 --texture 64 --samples 4 \
    --time 2011-01-15T13:30:00Z --out "$out/render_leo" >/dev/null
  "$nephos" -q --seed 3 lbm --grid 32x32x24 --iterations 30 --percolation 3 --size 96x72 --out "$out/lbm" >/dev/null
  "$nephos" -q --seed 3 lbm --grid 32x32x24 --iterations 30 --percolation 0 --storage fp16 --size 64x48 \
    --out "$out/lbm_fp16" >/dev/null
  if command -v mpirun >/dev/null; then
    mpirun --allow-run-as-root --oversubscribe -np 2 "$nephos" -q --seed 3 lbm --grid 32x32x24 --iterations 30 \
      --percolation 3 --size 96x72 --out "$out/lbm_mpi" >/dev/null
  fi
  "$nephos" -q fly --code d400 --frames 12 --size 320x180 --out "$out/fly" >/dev/null
  "$nephos" -q fly --code d200 --frames 6 --size 320x180 --no-impostors --background transparent \
    --out "$out/fly_all" >/dev/null
  "$nephos" -q particles --count 50000 --frames 2 --size 240x135 --out "$out/particles" >/dev/null
}

echo "running $ref_commit" >&2
run_all "$work/ref/build/apps/nephos/nephos" "$work/out_ref"
echo "running this checkout" >&2
run_all "$here/build/apps/nephos/nephos" "$work/out_new"

# What is compared of a file: its bytes, or of a frames.csv the columns that are not times.
digest() {
  case "$1" in
    */particles/frames.csv) cut -d, -f1-5 "$1" | sha256sum | cut -d' ' -f1 ;;
    */frames.csv) cut -d, -f1,3- "$1" | sha256sum | cut -d' ' -f1 ;;
    *) sha256sum "$1" | cut -d' ' -f1 ;;
  esac
}
# A file without its descriptive text: the data and structure that a reader parses.
data_digest() {
  case "$1" in
    *.nc) ncdump "$1" | grep -vE '^[[:space:]]*:(title|comment|history|source) = ' | tail -n +2 | sha256sum | cut -d' ' -f1 ;;
    *.ply) grep -av '^comment ' "$1" | sha256sum | cut -d' ' -f1 ;;
    *) digest "$1" ;;
  esac
}
status=0
count=0
text_only=0
while IFS= read -r f; do
  case "$f" in *.vdb) continue ;; esac
  count=$((count + 1))
  if [ ! -f "$work/out_new/$f" ]; then
    echo "MISSING  $f"
    status=1
  elif [ "$(digest "$work/out_ref/$f")" = "$(digest "$work/out_new/$f")" ]; then
    echo "same     $f"
  elif [ "$(data_digest "$work/out_ref/$f")" = "$(data_digest "$work/out_new/$f")" ]; then
    echo "text     $f (the data identical, descriptive text not)"
    text_only=$((text_only + 1))
  else
    echo "DIFFERS  $f"
    status=1
  fi
done < <(cd "$work/out_ref" && find . -type f | sed 's|^\./||' | sort)
new_only=$(comm -13 <(cd "$work/out_ref" && find . -type f | sort) <(cd "$work/out_new" && find . -type f | sort))
if [ -n "$new_only" ]; then
  echo "new files: $new_only"
fi
if [ $status -ne 0 ]; then
  verdict=DIFFERENCES
elif [ $text_only -gt 0 ]; then
  verdict="the data all identical; descriptive text differs in $text_only"
else
  verdict="all identical"
fi
echo "$count files compared with $ref_commit: $verdict"
exit $status
