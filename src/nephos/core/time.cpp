#include "nephos/core/time.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <regex>

#include "nephos/core/error.hpp"

namespace nephos {
namespace {
// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's days_from_civil).
std::int64_t days_from_civil(std::int64_t y, unsigned m, unsigned d) {
  y -= m <= 2;
  const std::int64_t era = (y >= 0 ? y : y - 399) / 400;
  const auto yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<std::int64_t>(doe) - 719468;
}
void civil_from_days(std::int64_t z, int& y, int& m, int& d) {
  z += 719468;
  const std::int64_t era = (z >= 0 ? z : z - 146096) / 146097;
  const auto doe = static_cast<unsigned>(z - era * 146097);
  const unsigned yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  const unsigned doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
  const unsigned mp = (5 * doy + 2) / 153;
  d = static_cast<int>(doy - (153 * mp + 2) / 5 + 1);
  m = static_cast<int>(mp < 10 ? mp + 3 : mp - 9);
  y = static_cast<int>(static_cast<std::int64_t>(yoe) + era * 400 + (m <= 2));
}
}  // namespace

std::optional<UtcTime> UtcTime::try_from_civil(int year, int month, int day, int hour, int minute, int second) {
  const bool leap = (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
  static constexpr int month_days[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  const int days = month < 1 || month > 12 ? 0 : month_days[month - 1] + (month == 2 && leap);
  if (month < 1 || month > 12 || day < 1 || day > days || hour < 0 || hour > 23 || minute < 0 || minute > 59 ||
      second < 0 || second > 60)
    return std::nullopt;
  return UtcTime{days_from_civil(year, static_cast<unsigned>(month), static_cast<unsigned>(day)) * 86400 + hour * 3600 +
                 minute * 60 + second};
}

UtcTime UtcTime::from_civil(int year, int month, int day, int hour, int minute, int second) {
  if (const auto t = try_from_civil(year, month, day, hour, minute, second)) return *t;
  throw ValueError(fmt::format("invalid calendar date/time {:04d}-{:02d}-{:02d} {:02d}:{:02d}:{:02d}", year, month, day,
                               hour, minute, second),
                   {.key = "time"});
}

UtcTime UtcTime::parse(const std::string& text) {
  static const std::regex re(R"((\d{4})-(\d{2})-(\d{2})(?:[T ](\d{2}):(\d{2})(?::(\d{2}))?)?(Z|\+00:?00)?)");
  std::smatch m;
  if (!std::regex_match(text, m, re))
    throw ValueError("expected a UTC time as YYYY-MM-DDThh:mm[:ss]Z, got '" + text + "'", {.key = "time"});
  auto num = [&](int i) { return m[i].matched ? std::stoi(m[i].str()) : 0; };
  return from_civil(num(1), num(2), num(3), num(4), num(5), num(6));
}

std::string UtcTime::iso() const {
  const std::int64_t days = (unix_s >= 0 ? unix_s : unix_s - 86399) / 86400;
  const std::int64_t sod = unix_s - days * 86400;
  int y, m, d;
  civil_from_days(days, y, m, d);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02dZ", y, m, d, static_cast<int>(sod / 3600),
                static_cast<int>(sod / 60 % 60), static_cast<int>(sod % 60));
  return buf;
}

}  // namespace nephos
