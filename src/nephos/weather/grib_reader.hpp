#pragma once
// The GRIB reader (ecCodes; registered as "grib" in reader.hpp's registry) and what `nephos
// info` shows of a GRIB file beyond what a WeatherGrid keeps.
#include <filesystem>
#include <string>
#include <vector>

#include "nephos/weather/reader.hpp"

namespace nephos::weather {

/// The GRIB reader's factory, which the registry holds from its start.
ReaderFactory grib_reader_factory();

/// What a GRIB file holds beyond what WeatherGrid keeps.
struct GribInventory {
  int messages = 0;                          ///< GRIB messages in the file
  int fields = 0;                            ///< fields in them (a GRIB2 message may hold several)
  int unused_fields = 0;                     ///< fields nephos does not read
  int editions_mask = 0;                     ///< bit 1: GRIB1, bit 2: GRIB2
  std::vector<std::string> grid_types;       ///< distinct gridType values
  std::vector<std::string> skipped_summary;  ///< "shortName/typeOfLevel xN" not used by nephos
};
/// Counts a GRIB file's messages and fields. IoError / FormatError as the reader's.
GribInventory inventory_grib(const std::filesystem::path& path);

}  // namespace nephos::weather
