#!/usr/bin/env bash
# Trims a NOAA GFS GRIB2 file to the fields nephos reads (data/README.md), with ecCodes'
# grib_copy (Debian package libeccodes-tools). Usage: scripts/trim_gfs_sample.sh IN OUT
#   IN   a GFS pgrb2 file (e.g. shared/data/gfs.t12z.pgrbf120.2p5deg.grib2)
#   OUT  the trimmed file (written under a temporary name, then renamed)
set -euo pipefail
in=${1:?usage: scripts/trim_gfs_sample.sh IN OUT}
out=${2:?usage: scripts/trim_gfs_sample.sh IN OUT}
command -v grib_copy >/dev/null || { echo "grib_copy not found: apt-get install libeccodes-tools" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Pressure levels: heights, temperature, humidity, vertical velocity, winds, condensate, ozone.
grib_copy -w shortName=gh/t/r/w/u/v/clwmr/o3mr,typeOfLevel=isobaricInhPa "$in" "$tmp/1"
# GFS's cloud cover per layer.
grib_copy -w shortName=tcc "$in" "$tmp/2"
# The surface: orography, pressure, land, sea ice, snow, skin temperature, albedo.
grib_copy -w shortName=orog/sp/lsm/ci/sdwe/t/al,typeOfLevel=surface "$in" "$tmp/3"
# Winds 10 m above the ground (sun glint), the column's water and ozone, the tropopause.
grib_copy -w shortName=10u/10v,typeOfLevel=heightAboveGround "$in" "$tmp/4"
grib_copy -w shortName=pwat/tozne,typeOfLevel=atmosphereSingleLayer "$in" "$tmp/5"
grib_copy -w shortName=trpp/t,typeOfLevel=tropopause "$in" "$tmp/6"
# GFS's diagnosed cloud tops and its top-of-atmosphere fluxes (validation only).
grib_copy -w shortName=pres,typeOfLevel=lowCloudTop/middleCloudTop/highCloudTop/convectiveCloudTop "$in" "$tmp/7"
grib_copy -w shortName=t,typeOfLevel=highCloudTop "$in" "$tmp/8"
grib_copy -w shortName=ulwrf/uswrf,typeOfLevel=nominalTop "$in" "$tmp/9"
cat "$tmp"/1 "$tmp"/2 "$tmp"/3 "$tmp"/4 "$tmp"/5 "$tmp"/6 "$tmp"/7 "$tmp"/8 "$tmp"/9 > "$out.tmp"
mv "$out.tmp" "$out"
echo "$out: $(grib_count "$out") fields"
