#include "nephos/core/error.hpp"

namespace nephos {
namespace {
std::string compose(const std::string& message, const ErrorContext& c) {
  std::string out;
  if (!c.file.empty()) {
    out.append(c.file);
    if (c.line > 0) out.append(":").append(std::to_string(c.line));
    out.append(": ");
  }
  if (!c.field.empty()) out.append("field '").append(c.field).append("': ");
  if (!c.key.empty()) out.append("key '").append(c.key).append("': ");
  out.append(message);
  return out;
}
}  // namespace

Error::Error(const std::string& message, ErrorContext context)
    : std::runtime_error(compose(message, context)), context_(std::move(context)), message_(message) {}

}  // namespace nephos
