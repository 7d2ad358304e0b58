#include "tac3d/util/progress.h"

#include <unistd.h>

#include <algorithm>

#include "tac3d/util/seconds_since.h"

namespace tac3d {

ProgressBar::ProgressBar(std::string label, long total, bool enabled)
    : label_(std::move(label)),
      total_(std::max(total, 1L)),
      enabled_(enabled),
      is_terminal_(isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

ProgressBar::~ProgressBar() {
  if (!finished_) Finish();
}

void ProgressBar::Update(long done) {
  if (!enabled_ || finished_) return;
  done = std::clamp(done, 0L, total_);
  const auto now = std::chrono::steady_clock::now();
  if (is_terminal_) {
    // Redrawing more than ~10 times a second only costs time.
    if (now - last_draw_ < std::chrono::milliseconds(100) && done < total_) return;
    last_draw_ = now;
    Draw(done);
  } else {
    const int decile = static_cast<int>(10 * done / total_);
    if (decile == last_decile_) return;
    last_decile_ = decile;
    Draw(done);
  }
}

void ProgressBar::Finish() {
  if (finished_) return;
  // In a log the last Update may already have printed the 100% line.
  if (enabled_ && (is_terminal_ || last_decile_ != 10)) Draw(total_);
  if (enabled_ && is_terminal_) std::fputc('\n', stderr);
  finished_ = true;
}

void ProgressBar::Draw(long done) {
  constexpr int kWidth = 30;
  const double fraction = static_cast<double>(done) / static_cast<double>(total_);
  const double elapsed_s = SecondsSince(start_);
  const int filled = static_cast<int>(fraction * kWidth);
  std::string bar(filled, '#');
  bar.resize(kWidth, '.');
  std::fprintf(stderr, "%s%s [%s] %3d%% %ld/%ld %.1fs%s", is_terminal_ ? "\r" : "",
               label_.c_str(), bar.c_str(), static_cast<int>(100 * fraction), done, total_,
               elapsed_s, is_terminal_ ? "" : "\n");
  std::fflush(stderr);
}

}  // namespace tac3d
