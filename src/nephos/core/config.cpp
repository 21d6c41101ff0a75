#include "nephos/core/config.hpp"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"

namespace nephos {

struct ParamDict::Shared {
  toml::table root;
  std::string source;
  std::set<std::string> used;
};

ParamDict::ParamDict() : shared_(std::make_shared<Shared>()), table_(&shared_->root) {}

ParamDict::ParamDict(std::shared_ptr<Shared> shared, const toml::table* table, std::string prefix)
    : shared_(std::move(shared)), table_(table), prefix_(std::move(prefix)) {}

ParamDict ParamDict::from_string(std::string_view text, const std::string& source) {
  auto shared = std::make_shared<Shared>();
  shared->source = source;
  try {
    shared->root = toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    throw ConfigError(std::string(e.description()), {.file = source, .line = static_cast<int>(e.source().begin.line)});
  }
  const toml::table* root = &shared->root;
  return ParamDict(std::move(shared), root, "");
}

ParamDict ParamDict::from_file(const std::filesystem::path& path) {
  require_input_file(path, "a TOML configuration file");
  std::ifstream in(path);
  if (!in) throw IoError("cannot open configuration file", {.file = path.string()});
  std::stringstream ss;
  ss << in.rdbuf();
  return from_string(ss.str(), path.string());
}

const std::string& ParamDict::source() const { return shared_->source; }

const void* ParamDict::node(std::string_view key) const {
  const toml::node* n = table_->get(key);
  if (n) shared_->used.insert(prefix_ + std::string(key));
  return n;
}

void ParamDict::fail(std::string_view key, const std::string& message) const {
  const toml::node* n = table_->get(key);
  throw ConfigError(message, {.file = shared_->source,
                              .key = prefix_ + std::string(key),
                              .line = n ? static_cast<int>(n->source().begin.line) : 0});
}

namespace {

// What a TOML value is, for an error that says what it expected instead.
std::string describe(const toml::node& n) {
  if (const auto s = n.value_exact<std::string>()) {
    const std::string& text = *s;
    return fmt::format("the string \"{}\"", text.size() > 40 ? text.substr(0, 40) + "..." : text);
  }
  if (const auto b = n.value_exact<bool>()) return *b ? "true" : "false";
  if (const auto i = n.value_exact<std::int64_t>()) return fmt::format("{}", *i);
  if (const auto d = n.value_exact<double>()) return fmt::format("{:g}", *d);
  if (n.is_array()) return "an array";
  if (n.is_table()) return "a table";
  return "a date or time";
}

}  // namespace

void ParamDict::type_error(std::string_view key, const char* expected) const {
  const toml::node* n = table_->get(key);
  fail(key, std::string("expected ") + expected + (n ? ", got " + describe(*n) : std::string()));
}

bool ParamDict::has(std::string_view key) const { return table_->contains(key); }

double ParamDict::get(std::string_view key, double fallback) const {
  auto n = static_cast<const toml::node*>(node(key));
  if (!n) return fallback;
  // Integers convert too. TOML's inf may stand for "no bound" (masks.toml); nan never means
  // anything.
  if (auto v = n->value<double>(); v && !std::isnan(*v)) return *v;
  type_error(key, "a number (not nan)");
}

double ParamDict::get_in(std::string_view key, double fallback, double lo, double hi) const {
  const double v = get(key, fallback);
  if (!(v >= lo && v <= hi)) range_error(key, fmt::format("[{:g}, {:g}], got {:g}", lo, hi, v));
  return v;
}

int ParamDict::get_in(std::string_view key, int fallback, int lo, int hi) const {
  const std::int64_t v = get(key, static_cast<std::int64_t>(fallback));
  if (v < lo || v > hi) range_error(key, fmt::format("[{}, {}], got {}", lo, hi, v));
  return static_cast<int>(v);
}

void ParamDict::range_error(std::string_view key, const std::string& range) const { fail(key, "must be in " + range); }

std::int64_t ParamDict::get(std::string_view key, std::int64_t fallback) const {
  auto n = static_cast<const toml::node*>(node(key));
  if (!n) return fallback;
  if (n->is_integer()) return *n->value<std::int64_t>();
  type_error(key, "an integer");
}

int ParamDict::get(std::string_view key, int fallback) const {
  const std::int64_t v = get(key, static_cast<std::int64_t>(fallback));
  if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
    range_error(key, fmt::format("the range of a 32-bit integer, got {}", v));
  return static_cast<int>(v);
}

bool ParamDict::get(std::string_view key, bool fallback) const {
  auto n = static_cast<const toml::node*>(node(key));
  if (!n) return fallback;
  if (n->is_boolean()) return *n->value<bool>();
  type_error(key, "true or false");
}

std::string ParamDict::get(std::string_view key, const std::string& fallback) const {
  auto n = static_cast<const toml::node*>(node(key));
  if (!n) return fallback;
  if (n->is_string()) return *n->value<std::string>();
  type_error(key, "a string");
}

std::vector<double> ParamDict::get(std::string_view key, const std::vector<double>& fallback) const {
  auto n = static_cast<const toml::node*>(node(key));
  if (!n) return fallback;
  const toml::array* a = n->as_array();
  if (!a) type_error(key, "an array of numbers");
  std::vector<double> out;
  for (const auto& e : *a) {
    auto v = e.value<double>();
    if (!v || std::isnan(*v)) fail(key, "expected an array of numbers (not nan), got " + describe(e) + " in it");
    out.push_back(*v);
  }
  return out;
}

ParamDict ParamDict::table(std::string_view key) const {
  static const toml::table empty;
  auto n = static_cast<const toml::node*>(node(key));
  if (!n) return ParamDict(shared_, &empty, prefix_ + std::string(key) + ".");
  const toml::table* t = n->as_table();
  if (!t) type_error(key, "a table");
  return ParamDict(shared_, t, prefix_ + std::string(key) + ".");
}

std::vector<std::string> ParamDict::keys() const {
  std::vector<std::string> out;
  for (const auto& [k, v] : *table_) out.emplace_back(k.str());
  return out;
}

namespace {
// Finds the unused key with the smallest line number below `t`.
void find_unused(const toml::table& t, const std::string& prefix, const std::set<std::string>& used,
                 std::string& best_key, int& best_line) {
  for (const auto& [k, v] : t) {
    const std::string full = prefix + std::string(k.str());
    const int line = static_cast<int>(v.source().begin.line);
    if (!used.count(full)) {
      if (best_key.empty() || line < best_line) {
        best_key = full;
        best_line = line;
      }
    } else if (const toml::table* sub = v.as_table()) {
      find_unused(*sub, full + ".", used, best_key, best_line);
    }
  }
}
}  // namespace

void ParamDict::check_unused() const {
  std::string key;
  int line = 0;
  find_unused(*table_, prefix_, shared_->used, key, line);
  if (!key.empty())
    throw ConfigError("unknown key (not a parameter here; check its spelling and table)",
                      {.file = shared_->source, .key = key, .line = line});
}

}  // namespace nephos
