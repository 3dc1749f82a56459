#pragma once
/// Progress reporting for long runs: a redrawn bar on a terminal, periodic log lines otherwise.
#include <chrono>
#include <cstddef>
#include <string>

namespace planecell::services {

class ProgressBar {
 public:
  /// `label` prefixes the bar; `total` is the number of steps expected.
  ProgressBar(std::string label, std::size_t total);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  /// Marks `done` steps finished; `status` is shown after the bar (e.g. "cells 812").
  void update(std::size_t done, const std::string& status = "");
  /// Ends the bar (newline on a terminal).
  void finish();

 private:
  std::string label_;
  std::size_t total_;
  bool tty_;
  bool finished_ = false;
  int last_logged_percent_ = -1;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace planecell::services
