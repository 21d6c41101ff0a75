#pragma once
// Parsing of small textual option values shared by the command line and the readers.
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "nephos/core/time.hpp"

namespace nephos {

/// Exactly `count` comma-separated finite numbers from `text` (e.g. "135,45"; "nan" and "inf"
/// are rejected). Throws ValueError naming `key`, the text and the expected form `what` (e.g.
/// "AZIMUTH,ELEVATION in degrees").
std::vector<double> parse_numbers(const std::string& text, std::size_t count, const std::string& key,
                                  const std::string& what);

/// Throws ValueError naming `key` unless lo <= value <= hi (NaN fails); `what` names the
/// quantity with its unit, e.g. "latitude [deg]".
void require_range(double value, double lo, double hi, const std::string& key, const std::string& what);
/// The same for lo < value <= hi (a bound that may not be reached, e.g. a radius above 0).
void require_range_above(double value, double lo, double hi, const std::string& key, const std::string& what);

/// Throws ResourceError naming `key` when `bytes` exceeds this machine's physical memory: what a
/// command checks before it allocates, so that a size too large for the machine gets a clear
/// message instead of std::bad_alloc or the kernel's out-of-memory killer.
void require_memory(double bytes, const std::string& key, const std::string& what);

/// This machine's physical memory [bytes].
double physical_memory_bytes();

/// The largest image edge any renderer takes [pixels] (a 20 000^2 image of ~50 B per pixel
/// already needs 20 GB).
inline constexpr int max_image_edge_px = 20000;
/// Throws ValueError naming `key` unless 1 <= width, height <= max_image_edge_px.
void require_image_size(int width, int height, const std::string& key);
/// "WIDTHxHEIGHT" as (width, height), checked by require_image_size; ValueError naming `key`.
std::pair<int, int> parse_size(const std::string& text, const std::string& key);

/// A comma-separated list, empty items dropped; ValueError naming `key` if nothing is left.
std::vector<std::string> split_list(const std::string& list, const std::string& key);
/// split_list() of a list whose items must be distinct (bands, cloud types).
std::vector<std::string> split_distinct(const std::string& list, const std::string& key);
/// UtcTime::parse() whose errors name `key`.
UtcTime parse_time(const std::string& text, const std::string& key);

}  // namespace nephos
