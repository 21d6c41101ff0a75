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

void require_image_size(int width, int height, const std::string& key) {
  if (width < 1 || height < 1 || width > max_image_edge_px || height > max_image_edge_px)
    throw ValueError(fmt::format("expected a width and height in 1..{}, got {}x{}", max_image_edge_px, width, height),
                     {.key = key});
}

std::pair<int, int> parse_size(const std::string& text, const std::string& key) {
  int w = 0, h = 0;
  char x = 0;
  std::stringstream ss(text);
  if (!(ss >> w >> x >> h) || x != 'x' || w < 1 || h < 1 || w > max_image_edge_px || h > max_image_edge_px || !ss.eof())
    throw ValueError(fmt::format("expected WIDTHxHEIGHT (1..{}), got '{}'", max_image_edge_px, text), {.key = key});
  return {w, h};
}

std::vector<std::string> split_list(const std::string& list, const std::string& key) {
  std::vector<std::string> out;
  std::string item;
  std::stringstream ss(list);
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  if (out.empty()) throw ValueError("empty list", {.key = key});
  return out;
}

std::vector<std::string> split_distinct(const std::string& list, const std::string& key) {
  std::vector<std::string> items = split_list(list, key);
  for (std::size_t i = 0; i < items.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (items[i] == items[j]) throw ValueError("'" + items[i] + "' is listed twice", {.key = key});
  return items;
}

UtcTime parse_time(const std::string& text, const std::string& key) {
  try {
    return UtcTime::parse(text);
  } catch (const ValueError& e) {
    throw ValueError(e.message(), {.key = key});
  }
}

}  // namespace nephos
