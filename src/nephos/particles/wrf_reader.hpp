#pragma once
// WRF-ARW output (wrfout NetCDF) -> particle weather, read with netCDF-C by WRF's own conventions
// (ARW User's Guide, ch. 5 "WRF output"; variable registry):
//   Times(Time, DateStrLen)                       "YYYY-MM-DD_hh:mm:ss"
//   XLAT, XLONG(Time, south_north, west_east)     degree_north / degree_east
//   PH, PHB(Time, bottom_top_stag, south_north, west_east)    perturbation / base geopotential [m2 s-2]
//   P, PB(Time, bottom_top, south_north, west_east)           perturbation / base pressure [Pa]
//   T(Time, bottom_top, south_north, west_east)   perturbation potential temperature theta - 300 [K]
//   QCLOUD, QICE(Time, bottom_top, south_north, west_east)    mixing ratios [kg kg-1]
//   U(Time, bottom_top, south_north, west_east_stag), V(..., south_north_stag, west_east),
//   W(Time, bottom_top_stag, south_north, west_east)          grid-relative wind [m s-1]
//   global attributes DX, DY                      grid spacing [m]
// Heights are (PH + PHB) / g on the staggered (interface) levels; mass levels lie between them.
// Temperature is theta (p / 1000 hPa)^(R/cp) with WRF's R/cp = 287/1004.5 (module_model_constants).
#include <filesystem>
#include <optional>

#include "nephos/particles/cloud_columns.hpp"

namespace nephos::particles {

/// Reads every time of `path`. `region` (optional) keeps the smallest index rectangle holding the
/// cells whose XLAT/XLONG fall inside it. QICE is optional (warm-rain schemes such as Kessler have
/// none; ice is then 0, with a warning); every other variable above is required. Throws IoError if
/// the file cannot be opened, FormatError naming the variable, dimension or attribute that is
/// missing or not as WRF writes it.
ParticleWeather read_wrf(const std::filesystem::path& path, const std::optional<LatLonRegion>& region = std::nullopt,
                         const ColumnParams& params = {});

}  // namespace nephos::particles
