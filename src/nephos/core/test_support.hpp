#pragma once
// For tests only: scratch paths that no other test process shares. CTest runs every test case
// as its own process, several at once (-j), so a fixed name under /tmp races between them (the
// FP32 and FP16 cases of one water-model test once wrote and read the same checkpoint at once).
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace nephos::test_support {

/// temp_directory_path()/nephos_<pid>_<name>: unique to this process, stable within it.
inline std::filesystem::path temp_path(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("nephos_" + std::to_string(::getpid()) + "_" + name);
}

/// A file's whole content, byte for byte (empty if it cannot be read).
inline std::string file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

}  // namespace nephos::test_support
