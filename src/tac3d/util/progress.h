#pragma once

#include <chrono>
#include <cstdio>
#include <string>

namespace tac3d {

/// A one-line progress bar on a terminal (stderr), or a line every 10% when stderr is
/// not a terminal, so long work in CI logs shows it is alive. Silent when disabled.
class ProgressBar {
 public:
  ProgressBar(std::string label, long total, bool enabled = true);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  /// Sets the amount of work done so far (0..total).
  void Update(long done);
  /// Marks the work complete and ends the line.
  void Finish();

 private:
  void Draw(long done);

  std::string label_;
  long total_;
  bool enabled_;
  bool is_terminal_;
  bool finished_ = false;
  int last_decile_ = -1;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace tac3d
