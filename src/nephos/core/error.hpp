#pragma once
// Typed exceptions for all nephos library code (after OpenVDB's ValueError/IoError family).
// Each carries where the problem is (file, field, key, line) so that a message read by a user
// names what to fix. Only main() and the Python layer catch them.
#include <optional>
#include <stdexcept>
#include <string>

namespace nephos {

/// Where an error happened. Every member is optional; what() prints those that are set.
struct ErrorContext {
  std::string file;   ///< file being read or written
  std::string field;  ///< data field (e.g. GRIB shortName "gh") or variable
  std::string key;    ///< configuration key or command-line option
  int line = 0;       ///< 1-based line in `file`, 0 if unknown
};

class Error : public std::runtime_error {
 public:
  Error(const std::string& message, ErrorContext context = {});
  const ErrorContext& context() const noexcept { return context_; }
  /// The message without the context prefix.
  const std::string& message() const noexcept { return message_; }

 private:
  ErrorContext context_;
  std::string message_;
};

/// A file cannot be opened, read, written or renamed.
class IoError : public Error {
  using Error::Error;
};
/// A file was read but does not hold what was expected (not GRIB, a required field missing...).
class FormatError : public Error {
  using Error::Error;
};
/// An argument or parameter value is out of its valid range.
class ValueError : public Error {
  using Error::Error;
};
/// A configuration file is malformed, has an unknown key or a value of the wrong type.
class ConfigError : public Error {
  using Error::Error;
};
/// A numerical computation left its valid range (NaN, non-convergence).
class NumericError : public Error {
  using Error::Error;
};
/// A request needs more of the machine (memory) than it has.
class ResourceError : public Error {
  using Error::Error;
};

}  // namespace nephos
