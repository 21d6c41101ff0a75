#include "nephos/core/atomic_file.hpp"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <system_error>

#include "nephos/core/error.hpp"

namespace nephos {
namespace {
// The temporaries being written, for the interrupt handler. Fixed storage and lock-free atomics:
// a signal handler may call only async-signal-safe functions (unlink, raise), never allocate
// or take a lock that the interrupted thread may hold.
constexpr int max_pending = 64;         // files written at once by one process (a few in practice)
constexpr std::size_t max_path = 4096;  // PATH_MAX on Linux
struct PendingTemporary {
  std::atomic<int> state{0};  // 0 free, 1 being filled in, 2 registered
  char path[max_path];
};
PendingTemporary pending[max_pending];
static_assert(std::atomic<int>::is_always_lock_free, "the interrupt handler reads these atomics");

int register_temporary(const std::string& path) {
  if (path.size() >= max_path) return -1;
  for (int i = 0; i < max_pending; ++i) {
    int expected = 0;
    if (pending[i].state.compare_exchange_strong(expected, 1, std::memory_order_acquire)) {
      std::memcpy(pending[i].path, path.c_str(), path.size() + 1);
      pending[i].state.store(2, std::memory_order_release);
      return i;
    }
  }
  return -1;  // more at once than the table holds: this one is not removed on an interrupt
}

void unregister_temporary(int slot) {
  if (slot >= 0) pending[slot].state.store(0, std::memory_order_release);
}

extern "C" void remove_temporaries_and_reraise(int sig) {
  for (auto& p : pending)
    if (p.state.load(std::memory_order_acquire) == 2) ::unlink(p.path);
  // Die of the same signal, so that the shell or mpirun sees what stopped the run.
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}
}  // namespace

AtomicFile::AtomicFile(std::filesystem::path destination) : destination_(std::move(destination)) {
  // Same directory as the destination so that rename() is atomic (same file system).
  temp_ = destination_;
  temp_ += ".tmp" + std::to_string(::getpid());
  slot_ = register_temporary(temp_.string());
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    std::error_code ec;
    std::filesystem::remove(temp_, ec);
  }
  unregister_temporary(slot_);
}

void AtomicFile::commit() {
  std::error_code ec;
  std::filesystem::rename(temp_, destination_, ec);
  if (ec) throw IoError("cannot rename temporary file into place: " + ec.message(), {.file = destination_.string()});
  committed_ = true;
  unregister_temporary(slot_);  // an interrupt now finds nothing to remove (the name has gone)
  slot_ = -1;
}

void AtomicFile::commit(std::ofstream& stream) {
  stream.close();
  if (stream.fail()) throw IoError("write failed (disk full?)", {.file = destination_.string()});
  commit();
}

void remove_temporaries_on_interrupt() {
  struct sigaction action {};
  action.sa_handler = remove_temporaries_and_reraise;
  sigemptyset(&action.sa_mask);
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
    // A signal ignored at start stays ignored: nohup's SIGHUP, a background job's SIGINT.
    struct sigaction current {};
    if (::sigaction(sig, nullptr, &current) == 0 && current.sa_handler == SIG_IGN) continue;
    ::sigaction(sig, &action, nullptr);
  }
}

void ensure_directory(const std::filesystem::path& dir) {
  if (dir.empty()) return;
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw IoError("cannot create output directory: " + (ec ? ec.message() : "not a directory"), {.file = dir.string()});
}

void require_input_file(const std::filesystem::path& path, const std::string& what) {
  std::error_code ec;
  const auto st = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(st)) throw IoError("no such file", {.file = path.string()});
  if (std::filesystem::is_directory(st)) throw IoError("is a directory, expected " + what, {.file = path.string()});
}

}  // namespace nephos
