#include "nephos/core/atomic_file.hpp"

#include <unistd.h>

#include <system_error>

#include "nephos/core/error.hpp"

namespace nephos {

AtomicFile::AtomicFile(std::filesystem::path destination) : destination_(std::move(destination)) {
  // Same directory as the destination so that rename() is atomic (same file system).
  temp_ = destination_;
  temp_ += ".tmp" + std::to_string(::getpid());
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    std::error_code ec;
    std::filesystem::remove(temp_, ec);
  }
}

void AtomicFile::commit() {
  std::error_code ec;
  std::filesystem::rename(temp_, destination_, ec);
  if (ec) throw IoError("cannot rename temporary file into place: " + ec.message(), {.file = destination_.string()});
  committed_ = true;
}

void ensure_directory(const std::filesystem::path& dir) {
  if (dir.empty()) return;
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw IoError("cannot create output directory: " + (ec ? ec.message() : "not a directory"), {.file = dir.string()});
}

}  // namespace nephos
