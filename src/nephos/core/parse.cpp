#include "nephos/core/parse.hpp"

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
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw ValueError("'" + item + "' in '" + text + "' is not a number; expected " + what, {.key = key});
    }
  }
  if (v.size() != count) throw ValueError("expected " + what + ", got '" + text + "'", {.key = key});
  return v;
}

}  // namespace nephos
