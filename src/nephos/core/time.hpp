#pragma once
// UTC instants with one-second resolution (all that GRIB metadata and solar geometry need).
#include <cstdint>
#include <optional>
#include <string>

namespace nephos {

struct UtcTime {
  std::int64_t unix_s = 0;  ///< seconds since 1970-01-01T00:00:00Z

  /// The instant of a proleptic Gregorian date and time. Throws ValueError (key "time") if it is
  /// no calendar date and time of day.
  static UtcTime from_civil(int year, int month, int day, int hour = 0, int minute = 0, int second = 0);
  /// from_civil(), or nothing if it is no calendar date and time of day.
  static std::optional<UtcTime> try_from_civil(int year, int month, int day, int hour = 0, int minute = 0,
                                               int second = 0);
  /// Parses ISO 8601 "YYYY-MM-DD[Thh:mm[:ss]][Z]" (UTC only). Throws ValueError otherwise.
  static UtcTime parse(const std::string& text);
  /// "YYYY-MM-DDThh:mm:ssZ"
  std::string iso() const;
  /// Days since 2000-01-01T12:00:00Z (J2000.0), as used by solar-position algorithms.
  double days_since_j2000() const { return (static_cast<double>(unix_s) - 946728000.0) / 86400.0; }
  UtcTime plus_seconds(double s) const { return {unix_s + static_cast<std::int64_t>(s)}; }
  auto operator<=>(const UtcTime&) const = default;
};

}  // namespace nephos
