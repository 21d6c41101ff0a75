#!/usr/bin/env bash
# Installs the Debian 12 packages nephos needs (only those missing) and configures + builds
# the project in Release mode into build/. Safe and fast to re-run: apt is skipped when every
# package is already installed, and CMake/make rebuild only what changed.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$here"

packages=(
  build-essential cmake pkg-config
  libeccodes-dev libeccodes-tools     # GRIB1/GRIB2 reader + grib_ls/grib_copy
  libnetcdf-dev netcdf-bin            # CF-NetCDF output + ncdump
  libhdf5-dev                         # NetCDF-4's storage layer (nephos turns off its exit-time clean-up)
  libpng-dev                          # PNG previews
  libopenexr-dev                      # multi-channel EXR output
  libopenvdb-dev libboost-iostreams-dev libtbb-dev   # volume output (clouds.vdb); OpenVDB's find module needs both
  libopenmpi-dev openmpi-bin          # nephos lbm across processes (mpirun)
  libglm-dev                          # vector maths
  libtomlplusplus-dev                 # configuration files
  libcli11-dev                        # command line
  nlohmann-json3-dev                  # weather-code JSON (Foreca)
  libegl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri   # headless OpenGL ES / OpenGL 3.3 (EGL; Mesa llvmpipe without a GPU)
  libglfw3-dev libgl1 libglx-mesa0    # nephos view: the window (GLFW on X11/GLX)
  xvfb xauth                          # tests run nephos view on a virtual X server
  libspdlog-dev libfmt-dev            # logging, formatting
  libgtest-dev libgmock-dev           # tests
  libbenchmark-dev                    # benchmarks
  python3 python3-numpy python3-xarray python3-netcdf4   # interoperability tests (xarray reads our NetCDF)
  python3-satpy                       # interoperability tests (satpy reads our ABI L1b files)
  python3-cartopy python3-matplotlib  # the documented satpy map example (scripts/plot_abi_map.py, tested)
  python3-dev pybind11-dev            # the Python module (numpy arrays)
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "nephos setup: installing ${missing[*]}" >&2
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$jobs"
