#include "nephos/core/progress.hpp"

#include <unistd.h>

#include <cstdio>

#include "nephos/core/log.hpp"

namespace nephos {
namespace {
std::atomic<bool> g_enabled{true};
}

void Progress::set_enabled(bool enabled) { g_enabled = enabled; }

Progress::Progress(std::string label, std::size_t total, double delay_s)
    : label_(std::move(label)),
      total_(total == 0 ? 1 : total),
      delay_s_(delay_s),
      start_(std::chrono::steady_clock::now()),
      active_(g_enabled && verbosity() != Verbosity::quiet && isatty(STDERR_FILENO) == 1) {
  next_draw_ns_ = static_cast<long long>(delay_s_ * 1e9);
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

void Progress::draw(std::size_t done, bool final) {
  std::lock_guard lock(draw_mutex_);
  const double frac = std::min(1.0, static_cast<double>(done) / static_cast<double>(total_));
  constexpr int width = 30;
  const int filled = static_cast<int>(frac * width);
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.resize(width, '.');
  const double t = elapsed_s();
  const double eta = frac > 0 ? t * (1 - frac) / frac : 0;
  std::fprintf(stderr, "\r%-18s [%s] %5.1f%%  %6.1f s  eta %6.1f s%s", label_.c_str(), bar.c_str(), 100 * frac, t,
               final ? 0.0 : eta, final ? "\n" : "");
  std::fflush(stderr);
  drawn_ = true;
}

}  // namespace nephos
