#pragma once
// A parameter dictionary read from TOML that remembers which keys were read, so that a
// misspelt or unknown key is reported (with its line) instead of silently ignored
// (after Mitsuba's Properties). Nested tables share the record of used keys with their parent.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace toml {
inline namespace v3 {
class table;
}
}  // namespace toml

namespace nephos {

class ParamDict {
 public:
  /// An empty dictionary (every get() returns its default).
  ParamDict();
  /// Parses a TOML file. Throws IoError if unreadable, ConfigError (with line) if malformed.
  static ParamDict from_file(const std::filesystem::path& path);
  /// Parses TOML text; `source` names it in messages.
  static ParamDict from_string(std::string_view text, const std::string& source = "<string>");

  bool has(std::string_view key) const;
  double get(std::string_view key, double fallback) const;
  std::int64_t get(std::string_view key, std::int64_t fallback) const;
  int get(std::string_view key, int fallback) const;
  bool get(std::string_view key, bool fallback) const;
  std::string get(std::string_view key, const std::string& fallback) const;
  std::string get(std::string_view key, const char* fallback) const { return get(key, std::string(fallback)); }
  /// get() of a number that must lie in [lo, hi]; ConfigError naming the key and its line
  /// otherwise. (No number may be nan, a type error; inf passes get() where it means "no
  /// bound", and fails get_in() with finite bounds.)
  double get_in(std::string_view key, double fallback, double lo, double hi) const;
  int get_in(std::string_view key, int fallback, int lo, int hi) const;
  /// An array of numbers; `fallback` when absent.
  std::vector<double> get(std::string_view key, const std::vector<double>& fallback) const;

  /// The sub-table `key` (empty dictionary if absent). Throws ConfigError if `key` is not a table.
  ParamDict table(std::string_view key) const;
  /// Names of the direct children of this table.
  std::vector<std::string> keys() const;
  /// Throws ConfigError naming the first key (in file order) that no get()/table() has read.
  void check_unused() const;
  const std::string& source() const;
  /// Throws ConfigError with `message`, naming the file, the full key and its line: for checks
  /// of a value beyond its type and range.
  [[noreturn]] void fail(std::string_view key, const std::string& message) const;

 private:
  struct Shared;
  ParamDict(std::shared_ptr<Shared> shared, const toml::table* table, std::string prefix);
  const void* node(std::string_view key) const;
  [[noreturn]] void type_error(std::string_view key, const char* expected) const;
  [[noreturn]] void range_error(std::string_view key, const std::string& range) const;

  std::shared_ptr<Shared> shared_;
  const toml::table* table_ = nullptr;
  std::string prefix_;
};

}  // namespace nephos
