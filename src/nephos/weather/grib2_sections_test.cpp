// The GRIB2 section check against the structure WMO's FM 92 GRIB edition 2 defines: every
// message NCEP wrote (the embedded sample, the validation file, the multi-field test file) is
// sound, and each kind of damage the check looks for is named.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "nephos/core/test_support.hpp"
#include "nephos/weather/grib2_sections.hpp"
#include "test_grib_writer.hpp"

namespace nephos::weather {
namespace {

const std::filesystem::path data_dir = std::filesystem::path(NEPHOS_SOURCE_DIR) / "data";

std::vector<unsigned char> read_bytes(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

std::uint64_t big_endian(const unsigned char* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = v << 8 | p[i];
  return v;
}

// The messages of a file of GRIB2 messages back to back: (offset, length) from section 0.
std::vector<std::pair<std::size_t, std::size_t>> messages(const std::vector<unsigned char>& b) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (std::size_t o = 0; o + 16 <= b.size();) {
    const auto n = static_cast<std::size_t>(big_endian(&b[o + 8], 8));
    out.emplace_back(o, n);
    o += n;
  }
  return out;
}

std::string check(const std::vector<unsigned char>& m) { return grib2_section_error(m.data(), m.size()); }

// The first message of the embedded sample (t on a 2.5 degree grid, complex packing 5.3) and the
// offset of its section `number` within it.
struct Message {
  std::vector<unsigned char> bytes;
  std::size_t section(int number) const {
    for (std::size_t pos = 16; pos + 5 <= bytes.size();) {
      if (bytes[pos + 4] == number) return pos;
      pos += static_cast<std::size_t>(big_endian(&bytes[pos], 4));
    }
    return 0;
  }
  void put(std::size_t at, std::uint64_t value, int bytes_count) {
    for (int i = bytes_count - 1; i >= 0; --i, value >>= 8) bytes[at + static_cast<std::size_t>(i)] = value & 0xff;
  }
};

Message first_message() {
  const auto b = read_bytes(data_dir / "gfs_20110110_12z_f120_2p5deg.grib2");
  const auto [o, n] = messages(b).front();
  return {std::vector<unsigned char>(b.begin() + static_cast<long>(o), b.begin() + static_cast<long>(o + n))};
}

TEST(Grib2Sections, EveryMessageNcepWroteIsSound) {
  for (const char* f : {"gfs_20110110_12z_f120_2p5deg.grib2", "validation/gfs_20111008_00z_f072_2p5deg.grib2",
                        "test/gfs_20110110_12z_f120_500hPa_gh_uv_multifield.grib2"}) {
    const auto b = read_bytes(data_dir / f);
    const auto list = messages(b);
    ASSERT_GT(list.size(), 1u) << f;
    for (const auto& [o, n] : list) EXPECT_EQ(grib2_section_error(&b[o], n), "") << f << " at byte " << o;
  }
}

TEST(Grib2Sections, MultiFieldMessagesRepeatSectionsFourToSeven) {
  // NCEP's u and v in one message: sections 4-7 twice. Its second field's section 4 must be
  // accepted after a section 7, and one after section 6 must not.
  const auto b = read_bytes(data_dir / "test/gfs_20110110_12z_f120_500hPa_gh_uv_multifield.grib2");
  const auto [o, n] = messages(b).back();
  Message m{std::vector<unsigned char>(b.begin() + static_cast<long>(o), b.begin() + static_cast<long>(o + n))};
  int sevens = 0;
  for (std::size_t pos = 16; pos + 4 < m.bytes.size(); pos += big_endian(&m.bytes[pos], 4))
    sevens += m.bytes[pos + 4] == 7;
  ASSERT_EQ(sevens, 2);
  EXPECT_EQ(check(m.bytes), "");
  m.bytes.at(m.section(7) + 4) = 8;  // the first field's data section renumbered: not a GRIB2 section
  EXPECT_NE(check(m.bytes).find("section numbered 8"), std::string::npos) << check(m.bytes);
}

TEST(Grib2Sections, NamesEachKindOfDamage) {
  const Message sound = first_message();
  ASSERT_EQ(check(sound.bytes), "");
  auto damaged = [&](auto edit) {
    Message m = sound;
    edit(m);
    return check(m.bytes);
  };
  auto has = [](const std::string& e, const char* what) { return e.find(what) != std::string::npos; };
  // Section 6 shorter than its fixed 6 octets: the length ecCodes 2.28 overruns its buffer with.
  std::string e = damaged([](Message& m) { m.put(m.section(6), 2, 4); });
  EXPECT_TRUE(has(e, "section 6 of 2 bytes") && has(e, "at least 6")) << e;
  // A section running past the end, and the total length disagreeing with the bytes.
  e = damaged([](Message& m) { m.put(m.section(7), m.bytes.size(), 4); });
  EXPECT_TRUE(has(e, "past its end")) << e;
  e = damaged([](Message& m) { m.put(8, m.bytes.size() + 1, 8); });
  EXPECT_TRUE(has(e, "states")) << e;
  // No "7777", a section out of order, an edition-1 message (not checked).
  e = damaged([](Message& m) { m.bytes[m.bytes.size() - 1] = '6'; });
  EXPECT_TRUE(has(e, "7777")) << e;
  e = damaged([](Message& m) { m.bytes.at(m.section(4) + 4) = 5; });
  EXPECT_TRUE(has(e, "section 5 after section 3")) << e;
  EXPECT_EQ(damaged([](Message& m) { m.bytes[7] = 1; }), "");
  // Complex packing (template 5.3): more groups than values (octets 32-35), or group
  // descriptors that overflow the data section (the group widths' bits, octet 37).
  e = damaged([](Message& m) { m.put(m.section(5) + 31, 0x80000000u, 4); });
  EXPECT_TRUE(has(e, "groups for 10512 values")) << e;
  e = damaged([](Message& m) { m.bytes.at(m.section(5) + 36) = 255; });
  EXPECT_TRUE(has(e, "groups' descriptors")) << e;
  // A bitmap (section 6 indicator 0) shorter than the grid (section 3 octets 7-10: 10512 points).
  e = damaged([](Message& m) { m.bytes.at(m.section(6) + 5) = 0; });
  EXPECT_TRUE(has(e, "bitmap of 0 bytes for 10512 grid points")) << e;
}

TEST(Grib2Sections, SimplePackingMustFitItsValues) {
  // A message ecCodes writes with simple packing (template 5.0; test_grib_writer): its values'
  // bits (octet 20) made 255 need more bytes than its data section holds.
  const auto p = test_support::temp_path("grib2_sections_simple.grib2");
  std::filesystem::remove(p);
  testing::append_grib(p, testing::GribGridSpec{}, "t", "isobaricInhPa", 500, [](double, double) { return 250.0; });
  const auto b = read_bytes(p);
  std::filesystem::remove(p);
  Message m{b};
  ASSERT_EQ(big_endian(&m.bytes.at(m.section(5) + 9), 2), 0u) << "not simple packing";
  ASSERT_EQ(check(m.bytes), "");
  m.bytes.at(m.section(5) + 19) = 255;
  EXPECT_NE(check(m.bytes).find("packs 40 values of 255 bits"), std::string::npos) << check(m.bytes);
}

}  // namespace
}  // namespace nephos::weather
