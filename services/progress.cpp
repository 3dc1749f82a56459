#include "services/progress.hpp"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cstdio>

namespace planecell::services {

ProgressBar::ProgressBar(std::string label, std::size_t total)
    : label_(std::move(label)),
      total_(total == 0 ? 1 : total),
      tty_(::isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_ - std::chrono::seconds(1)) {}

ProgressBar::~ProgressBar() {
  if (!finished_) finish();
}

void ProgressBar::update(std::size_t done, const std::string& status) {
  const auto now = std::chrono::steady_clock::now();
  const double elapsed_s = std::chrono::duration<double>(now - start_).count();
  const double fraction = static_cast<double>(done) / static_cast<double>(total_);
  const double rate = elapsed_s > 0.0 ? static_cast<double>(done) / elapsed_s : 0.0;
  const double eta_s = rate > 0.0 ? static_cast<double>(total_ - std::min(done, total_)) / rate : 0.0;
  if (tty_) {
    if (now - last_draw_ < std::chrono::milliseconds(100) && done < total_) return;
    last_draw_ = now;
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth);
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(kWidth, '.');
    std::fprintf(stderr, "\r%s [%s] %zu/%zu %5.1f%% %.1f/s eta %.0fs %s\033[K", label_.c_str(),
                 bar.c_str(), done, total_, 100.0 * fraction, rate, eta_s, status.c_str());
    std::fflush(stderr);
  } else {
    const int percent = static_cast<int>(100.0 * fraction);
    if (percent / 10 == last_logged_percent_ / 10 && done < total_) return;
    last_logged_percent_ = percent;
    spdlog::info("{}: {}/{} ({}%), {:.1f}/s, eta {:.0f}s {}", label_, done, total_, percent, rate,
                 eta_s, status);
  }
}

void ProgressBar::finish() {
  if (finished_) return;
  finished_ = true;
  if (tty_) std::fprintf(stderr, "\n");
}

}  // namespace planecell::services
