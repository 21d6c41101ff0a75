#pragma once
// The section structure of a GRIB edition 2 message (WMO Manual on Codes, FM 92 GRIB edition 2),
// checked before ecCodes parses it: ecCodes 2.28 writes past its buffer when a section's stated
// length is shorter than the section's fixed part (a 2-byte section 6 aborts the process with a
// double free), so such a message must be refused before it reaches ecCodes.
#include <cstddef>
#include <string>

namespace nephos::weather {

/// What is wrong with the section structure of the GRIB2 message `message` of `size` bytes; empty
/// when it is sound. Checked: section 0 (16 bytes, "GRIB", edition 2, the total length equal to
/// `size`); then sections 1 to 7, each a 4-byte big-endian length and its number, in the order
/// 1, (2), 3, 4, 5, 6, 7 with 2-7, 3-7 or 4-7 repeated for each further field, each at least
/// its fixed part long and within the message; the end "7777" right after the last section 7;
/// and per field, the simple and complex packings' values and group descriptors (templates 5.0,
/// 5.2, 5.3) within section 7, no more groups than values, and a bitmap covering section 3's
/// grid. A message of another edition (GRIB1) is not checked: empty.
/// @param message the message's bytes, from its "GRIB"
/// @param size    its length in bytes [B]
std::string grib2_section_error(const unsigned char* message, std::size_t size);

}  // namespace nephos::weather
