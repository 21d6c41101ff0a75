#pragma once
// Write-then-rename: outputs appear whole or not at all. Write to temp_path(), then commit();
// if commit() is never reached (an exception), the destructor removes the temporary, and after
// remove_temporaries_on_interrupt() so does an interrupt (Ctrl-C, kill, a closed terminal).
#include <filesystem>
#include <fstream>
#include <string>

namespace nephos {

class AtomicFile {
 public:
  explicit AtomicFile(std::filesystem::path destination);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::filesystem::path& temp_path() const { return temp_; }
  const std::filesystem::path& destination() const { return destination_; }
  /// Renames the temporary onto the destination. Throws IoError on failure.
  void commit();
  /// Closes `stream` (writing what it still buffers), throws IoError naming the destination if
  /// any write to it failed (a full disk), else commits: a stream's last bytes and its errors
  /// otherwise surface only in its destructor, which reports nothing.
  void commit(std::ofstream& stream);

 private:
  std::filesystem::path destination_;
  std::filesystem::path temp_;
  bool committed_ = false;
  int slot_ = -1;  // in the table of temporaries an interrupt removes (-1: not in it)
};

/// Installs handlers for SIGINT, SIGTERM and SIGHUP that remove every AtomicFile temporary still
/// being written, then end the process by the same signal; a signal ignored when it is called
/// (nohup's SIGHUP) stays ignored. For programs (nephos's main()), not for libraries loaded
/// into another process (the Python module leaves the host's handlers).
void remove_temporaries_on_interrupt();

/// Creates `dir` (and parents) if needed; throws IoError naming it on failure.
void ensure_directory(const std::filesystem::path& dir);

/// Throws IoError naming `path` if it does not exist ("no such file") or is a directory ("is a
/// directory, expected WHAT"); `what` names what should be there ("a GRIB file"). Pipes and
/// devices pass (`--config <(...)`); what reads them reports their content.
void require_input_file(const std::filesystem::path& path, const std::string& what);

}  // namespace nephos
