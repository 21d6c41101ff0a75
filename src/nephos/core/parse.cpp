#include "nephos/core/parse.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <cmath>
#include <sstream>

#include "nephos/core/error.hpp"

namespace nephos {

std::vector<double> parse_numbers(const std::string& text, std::size_t count, const std::string& key,
                                  const std::string& what) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      std::size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (used != item.size() || !std::isfinite(v.back())) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw ValueError("'" + item + "' in '" + text + "' is not a finite number; expected " + what, {.key = key});
    }
  }
  if (v.size() != count) throw ValueError("expected " + what + ", got '" + text + "'", {.key = key});
  return v;
}

void require_range(double value, double lo, double hi, const std::string& key, const std::string& what) {
  if (!(value >= lo && value <= hi))
    throw ValueError(fmt::format("{} must be in [{:g}, {:g}], got {:g}", what, lo, hi, value), {.key = key});
}

void require_range_above(double value, double lo, double hi, const std::string& key, const std::string& what) {
  if (!(value > lo && value <= hi))
    throw ValueError(fmt::format("{} must be in ({:g}, {:g}], got {:g}", what, lo, hi, value), {.key = key});
}

double physical_memory_bytes() {
  return static_cast<double>(sysconf(_SC_PHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGE_SIZE));
}

void require_memory(double bytes, const std::string& key, const std::string& what) {
  const double have = physical_memory_bytes();
  if (bytes > have)
    throw ResourceError(fmt::format("{} needs about {:.1f} GiB, more than this machine's {:.1f} GiB of memory", what,
                                    bytes / (1 << 30), have / (1 << 30)),
                        {.key = key});
}

}  // namespace nephos
