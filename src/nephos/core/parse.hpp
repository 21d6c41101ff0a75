#pragma once
// Parsing of small textual option values shared by the command line and the readers.
#include <cstddef>
#include <string>
#include <vector>

namespace nephos {

/// Exactly `count` comma-separated numbers from `text` (e.g. "135,45"). Throws ValueError
/// naming `key`, the text and the expected form `what` (e.g. "AZIMUTH,ELEVATION in degrees").
std::vector<double> parse_numbers(const std::string& text, std::size_t count, const std::string& key,
                                  const std::string& what);

}  // namespace nephos
