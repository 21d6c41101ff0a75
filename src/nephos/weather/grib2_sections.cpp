#include "nephos/weather/grib2_sections.hpp"

#include <fmt/format.h>

#include <array>
#include <cstdint>
#include <cstring>

namespace nephos::weather {
namespace {
// The fixed part of each section [B] (FM 92 GRIB2: the octets every template of it has).
constexpr std::array<std::uint64_t, 8> min_length = {16, 21, 5, 14, 9, 11, 6, 5};

std::uint64_t big_endian(const unsigned char* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = v << 8 | p[i];
  return v;
}

// A field's sections as far as the packing checks read them: section 3's grid points, section 5
// and section 6 (the message's latest of each: a repeated field may reuse them).
struct FieldSections {
  std::uint64_t grid_points = 0;
  const unsigned char* s5 = nullptr;
  const unsigned char* s6 = nullptr;
  std::uint64_t s5_length = 0, s6_length = 0;
};

std::uint64_t bytes_for(std::uint64_t count, std::uint64_t bits) { return (count * bits + 7) / 8; }

// What is wrong with a field's packing against its data section of s7_length bytes: the simple
// and complex packings (data representation templates 5.0, 5.2 and 5.3; octets as numbered in
// FM 92) must fit their groups' descriptors and values in section 7, and a bitmap (section 6
// indicator 0) must cover the grid. Other templates (JPEG 2000, PNG, ...) are left to ecCodes.
std::string packing_error(const FieldSections& f, std::uint64_t s7_length) {
  if (f.s6 && f.s6[5] == 0 && f.s6_length < 6 + bytes_for(f.grid_points, 1))
    return fmt::format("has a bitmap of {} bytes for {} grid points", f.s6_length - 6, f.grid_points);
  if (!f.s5) return {};
  const auto templ = static_cast<int>(big_endian(f.s5 + 9, 2));
  if (templ != 0 && templ != 2 && templ != 3) return {};
  const std::uint64_t fixed = templ == 0 ? 21 : templ == 2 ? 47 : 49;  // the template's octets
  if (f.s5_length < fixed)
    return fmt::format("has a section 5 of {} bytes for template 5.{} ({} expected)", f.s5_length, templ, fixed);
  const std::uint64_t values = big_endian(f.s5 + 5, 4), bits = f.s5[19], data = s7_length - 5;
  if (templ == 0) {
    if (bytes_for(values, bits) > data)
      return fmt::format("packs {} values of {} bits in a data section of {} bytes", values, bits, data);
    return {};
  }
  const std::uint64_t groups = big_endian(f.s5 + 31, 4), width_bits = f.s5[36], length_bits = f.s5[46];
  if (groups > values) return fmt::format("has {} groups for {} values", groups, values);
  const std::uint64_t extra = templ == 3 ? (f.s5[47] + 1ull) * f.s5[48] : 0;
  const std::uint64_t need =
      extra + bytes_for(groups, bits) + bytes_for(groups, width_bits) + bytes_for(groups, length_bits);
  if (need > data)
    return fmt::format("needs {} bytes for its {} groups' descriptors, its data section holds {}", need, groups, data);
  return {};
}

// Whether section `next` may follow section `prev` (0: section 0).
bool may_follow(int prev, int next) {
  switch (prev) {
    case 0:
      return next == 1;
    case 1:
      return next == 2 || next == 3;
    case 7:
      return next == 2 || next == 3 || next == 4;  // the message's next field
    default:
      return next == prev + 1;
  }
}
}  // namespace

std::string grib2_section_error(const unsigned char* m, std::size_t size) {
  if (size < 8 || std::memcmp(m, "GRIB", 4) != 0) return "does not start with \"GRIB\"";
  if (m[7] != 2) return {};
  if (size < min_length[0] + 4) return fmt::format("is {} bytes long, shorter than a GRIB2 message can be", size);
  if (const std::uint64_t total = big_endian(m + 8, 8); total != size)
    return fmt::format("states {} bytes, holds {}", total, size);
  const std::uint64_t end = size - 4;  // where "7777" starts
  std::uint64_t pos = min_length[0];
  int prev = 0;
  FieldSections fields;
  while (pos < end) {
    if (pos + 5 > end) return fmt::format("ends inside a section header at its byte {}", pos);
    const std::uint64_t length = big_endian(m + pos, 4);
    const int number = m[pos + 4];
    if (number < 1 || number > 7) return fmt::format("has a section numbered {} at its byte {}", number, pos);
    if (!may_follow(prev, number))
      return fmt::format("has section {} after section {} at its byte {}", number, prev, pos);
    if (length < min_length[static_cast<std::size_t>(number)])
      return fmt::format("has a section {} of {} bytes at its byte {} (at least {} expected)", number, length, pos,
                         min_length[static_cast<std::size_t>(number)]);
    if (length > end - pos)
      return fmt::format("has a section {} of {} bytes at its byte {}, past its end", number, length, pos);
    const unsigned char* section = m + pos;
    if (number == 3) fields.grid_points = big_endian(section + 6, 4);
    if (number == 5) fields.s5 = section, fields.s5_length = length;
    if (number == 6) fields.s6 = section, fields.s6_length = length;
    if (number == 7)
      if (std::string e = packing_error(fields, length); !e.empty())
        return fmt::format("{} (section 7 at its byte {})", e, pos);
    pos += length, prev = number;
  }
  if (prev != 7) return fmt::format("ends after section {}, not 7", prev);
  if (std::memcmp(m + end, "7777", 4) != 0) return "does not end with \"7777\"";
  return {};
}

}  // namespace nephos::weather
