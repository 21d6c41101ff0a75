#pragma once
// A progress bar on stderr for long work. Drawn only when stderr is a terminal, logging is not
// quiet, and the work has run for more than `delay_s` (so sub-second work prints nothing).
// advance() is thread-safe and cheap (one relaxed atomic add; drawing is throttled to 10 Hz).
// Work whose length is not known in advance (iterations to convergence) is open-ended: the
// line counts steps and shows a detail (e.g. the residual) instead of a bar. The environment
// variable NEPHOS_PROGRESS_DELAY_S replaces every line's delay (ValueError if it is not a
// number of seconds >= 0).
#include <atomic>
#include <chrono>
#include <cstddef>
#include <mutex>
#include <string>

namespace nephos {

class Progress {
 public:
  struct OpenEnded {};
  Progress(std::string label, std::size_t total, double delay_s = 1.0);
  Progress(std::string label, OpenEnded, double delay_s = 1.0);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void advance(std::size_t n = 1);
  /// Text shown after the count of open-ended work (thread-safe).
  void set_detail(std::string detail);
  /// The line drawn for `done` of `total` units (0: open-ended, counted in steps) after
  /// `elapsed_s`, without the leading carriage return.
  static std::string line(const std::string& label, std::size_t done, std::size_t total, const std::string& detail,
                          double elapsed_s, bool final);
  /// Seconds since construction.
  double elapsed_s() const;
  /// Globally allows (terminal) or forbids drawing; the CLI sets this from --quiet.
  static void set_enabled(bool enabled);

 private:
  void draw(std::size_t done, bool final);

  std::string label_;
  std::size_t total_;  // 0: open-ended
  std::string detail_;
  double delay_s_;
  std::atomic<std::size_t> done_{0};
  std::atomic<long long> next_draw_ns_{0};
  std::chrono::steady_clock::time_point start_;
  std::mutex draw_mutex_;
  bool drawn_ = false;
  bool active_;
};

}  // namespace nephos
