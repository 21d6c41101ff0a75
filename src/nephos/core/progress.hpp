#pragma once
// A progress bar on stderr for long work. Drawn only when stderr is a terminal, logging is not
// quiet, and the work has run for more than `delay_s` (so sub-second work prints nothing).
// advance() is thread-safe and cheap (one relaxed atomic add; drawing is throttled to 10 Hz).
#include <atomic>
#include <chrono>
#include <cstddef>
#include <mutex>
#include <string>

namespace nephos {

class Progress {
 public:
  Progress(std::string label, std::size_t total, double delay_s = 1.0);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void advance(std::size_t n = 1);
  /// Seconds since construction.
  double elapsed_s() const;
  /// Globally allows (terminal) or forbids drawing; the CLI sets this from --quiet.
  static void set_enabled(bool enabled);

 private:
  void draw(std::size_t done, bool final);

  std::string label_;
  std::size_t total_;
  double delay_s_;
  std::atomic<std::size_t> done_{0};
  std::atomic<long long> next_draw_ns_{0};
  std::chrono::steady_clock::time_point start_;
  std::mutex draw_mutex_;
  bool drawn_ = false;
  bool active_;
};

}  // namespace nephos
