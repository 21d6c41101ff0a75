#include "nephos/core/error.hpp"

#include <cstdint>

namespace nephos {
namespace {
// Messages quote what was read (a JSON parser's "last read", a file name): bytes that are not
// printable text, or not valid UTF-8, become \xNN so that a terminal or log shows them as such.
// Valid UTF-8 (deg, um signs) and newlines and tabs pass unchanged.
std::string printable(const std::string& text) {
  static const char* hex = "0123456789abcdef";
  std::string out;
  out.reserve(text.size());
  auto escape = [&](unsigned char b) {
    out.append("\\x");
    out.push_back(hex[b >> 4]);
    out.push_back(hex[b & 15]);
  };
  for (std::size_t i = 0; i < text.size();) {
    const auto b = static_cast<unsigned char>(text[i]);
    if (b < 0x80) {
      if ((b < 0x20 && b != '\n' && b != '\t') || b == 0x7f)
        escape(b);
      else
        out.push_back(static_cast<char>(b));
      ++i;
      continue;
    }
    // Lead byte -> sequence length and the smallest code point it may encode (no overlongs).
    const std::size_t n = b >= 0xc2 && b <= 0xdf ? 2 : b >= 0xe0 && b <= 0xef ? 3 : b >= 0xf0 && b <= 0xf4 ? 4 : 0;
    bool valid = n > 0 && i + n <= text.size();
    std::uint32_t cp = n == 2 ? b & 0x1f : n == 3 ? b & 0x0f : b & 0x07;
    for (std::size_t k = 1; valid && k < n; ++k) {
      const auto c = static_cast<unsigned char>(text[i + k]);
      valid = (c & 0xc0) == 0x80;
      cp = (cp << 6) | (c & 0x3f);
    }
    valid = valid && !(n == 3 && (cp < 0x800 || (cp >= 0xd800 && cp <= 0xdfff))) &&
            !(n == 4 && (cp < 0x10000 || cp > 0x10ffff));
    if (valid) {
      out.append(text, i, n);
      i += n;
    } else {
      escape(b);
      ++i;
    }
  }
  return out;
}

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
  return printable(out);
}
}  // namespace

Error::Error(const std::string& message, ErrorContext context)
    : std::runtime_error(compose(message, context)), context_(std::move(context)), message_(printable(message)) {}

}  // namespace nephos
