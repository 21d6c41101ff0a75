#include "nephos/core/progress.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>

#include <fmt/format.h>

#include "nephos/core/error.hpp"
#include "nephos/core/log.hpp"

namespace nephos {
namespace {
std::atomic<bool> g_enabled{true};
}

void Progress::set_enabled(bool enabled) { g_enabled = enabled; }

namespace {
// NEPHOS_PROGRESS_DELAY_S, when set: the delay of every progress line [s] (tests draw at once).
double delay_from_environment(double delay_s) {
  const char* text = std::getenv("NEPHOS_PROGRESS_DELAY_S");
  if (!text) return delay_s;
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !(v >= 0 && v < 1e6))
    throw ValueError(fmt::format("NEPHOS_PROGRESS_DELAY_S must be a delay in seconds >= 0, got '{}'", text));
  return v;
}
}  // namespace

Progress::Progress(std::string label, std::size_t total, double delay_s)
    : label_(std::move(label)),
      total_(total == 0 ? 1 : total),
      delay_s_(delay_from_environment(delay_s)),
      start_(std::chrono::steady_clock::now()),
      active_(g_enabled && verbosity() != Verbosity::quiet && isatty(STDERR_FILENO) == 1) {
  next_draw_ns_ = static_cast<long long>(delay_s_ * 1e9);
}

Progress::Progress(std::string label, OpenEnded, double delay_s) : Progress(std::move(label), 1, delay_s) {
  total_ = 0;
}

Progress::~Progress() {
  if (active_ && drawn_) draw(done_.load(), true);
}

double Progress::elapsed_s() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Progress::advance(std::size_t n) {
  const std::size_t done = done_.fetch_add(n, std::memory_order_relaxed) + n;
  if (!active_) return;
  const auto now_ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - start_).count();
  long long next = next_draw_ns_.load(std::memory_order_relaxed);
  if (now_ns < next) return;
  if (!next_draw_ns_.compare_exchange_strong(next, now_ns + 100'000'000)) return;  // 10 Hz
  draw(done, false);
}

void Progress::set_detail(std::string detail) {
  std::lock_guard lock(draw_mutex_);
  detail_ = std::move(detail);
}

std::string Progress::line(const std::string& label, std::size_t done, std::size_t total, const std::string& detail,
                           double elapsed_s, bool final) {
  if (total == 0)
    return fmt::format("{:<18} {:>6} steps  {:<30}  {:6.1f} s{}", label, done, detail, elapsed_s, final ? "\n" : "");
  const double frac = std::min(1.0, static_cast<double>(done) / static_cast<double>(total));
  constexpr int width = 30;
  const int filled = static_cast<int>(frac * width);
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.resize(width, '.');
  const double eta = frac > 0 ? elapsed_s * (1 - frac) / frac : 0;
  return fmt::format("{:<18} [{}] {:5.1f}%  {:6.1f} s  eta {:6.1f} s{}", label, bar, 100 * frac, elapsed_s,
                     final ? 0.0 : eta, final ? "\n" : "");
}

void Progress::draw(std::size_t done, bool final) {
  std::lock_guard lock(draw_mutex_);
  std::fprintf(stderr, "\r%s", line(label_, done, total_, detail_, elapsed_s(), final).c_str());
  std::fflush(stderr);
  drawn_ = true;
}

}  // namespace nephos
