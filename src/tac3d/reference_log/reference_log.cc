#include "tac3d/reference_log/reference_log.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "tac3d/record/recording.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"
#include "tac3d/util/number_csv.h"

namespace tac3d {
namespace {

// A reference log of a long session at 1 kHz: ~40 bytes a line, an hour in ~150 MB.
constexpr std::size_t kMaxReferenceLogBytes = 256u << 20;
// The offset estimate: a coarse grid, then a fine one around its best point.
constexpr double kCoarseStepS = 0.01, kFineStepS = 0.0005;
constexpr int kMinOverlapFrames = 10;

// The reference force at time t (reference clock), linearly interpolated; nullopt outside the
// log. `hint` is the index of the last interval used, so a forward sweep costs O(1) a call.
std::optional<Eigen::Vector3d> ForceAt(const std::vector<ReferenceSample>& log,
                                       double t,
                                       size_t* hint) {
  if (t < log.front().t_s || t > log.back().t_s) return std::nullopt;
  size_t k = std::min(*hint, log.size() - 2);
  if (log[k].t_s > t) {
    k = static_cast<size_t>(std::upper_bound(log.begin(), log.end(), t,
                                             [](double v, const ReferenceSample& s) {
                                               return v < s.t_s;
                                             }) -
                            log.begin());
    k = k == 0 ? 0 : k - 1;
  }
  while (k + 2 < log.size() && log[k + 1].t_s < t) ++k;
  *hint = k;
  const double a = (t - log[k].t_s) / (log[k + 1].t_s - log[k].t_s);
  return (1.0 - a) * log[k].force_n + a * log[k + 1].force_n;
}

// Pearson correlation of the frames' magnitudes with the reference's at t - offset, over the
// frames inside the log; nullopt when fewer than kMinOverlapFrames overlap or either side is
// constant.
std::optional<double> MagnitudeCorrelation(const std::vector<double>& frame_t_s,
                                           const std::vector<double>& frame_magnitude,
                                           const std::vector<ReferenceSample>& reference,
                                           double offset_s) {
  double n = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  size_t hint = 0;
  for (size_t k = 0; k < frame_t_s.size(); ++k) {
    const std::optional<Eigen::Vector3d> f = ForceAt(reference, frame_t_s[k] - offset_s, &hint);
    if (!f) continue;
    const double x = frame_magnitude[k], y = f->norm();
    n += 1;
    sx += x;
    sy += y;
    sxx += x * x;
    syy += y * y;
    sxy += x * y;
  }
  if (n < kMinOverlapFrames) return std::nullopt;
  const double vx = sxx - sx * sx / n, vy = syy - sy * sy / n;
  if (!(vx > 0.0 && vy > 0.0)) return std::nullopt;
  return (sxy - sx * sy / n) / std::sqrt(vx * vy);
}

bool AllValid(const TactileFrame& frame) {
  return std::all_of(frame.valid.begin(), frame.valid.end(), [](bool v) { return v; });
}

// D (3N, mm) in the calibration presses' order: dx of every marker, then dy, then dz.
Eigen::VectorXd PaperOrderDisplacements(const TactileFrame& frame) {
  const Eigen::Index n = static_cast<Eigen::Index>(frame.displacements_mm.size());
  Eigen::VectorXd d(3 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (int axis = 0; axis < 3; ++axis) d(axis * n + i) = frame.displacements_mm[i](axis);
  }
  return d;
}

}  // namespace

std::vector<ReferenceSample> ParseReferenceLog(const std::string& csv_text,
                                               const std::string& source) {
  std::vector<ReferenceSample> log;
  for (const std::vector<double>& row : ParseNumberCsv(csv_text, source, kReferenceLogCsvHeader, 4)) {
    if (!log.empty() && !(row[0] > log.back().t_s)) {
      throw Error(fmt::format("{}: reading {} at t = {} s does not come after the one before "
                              "(t = {} s): times must increase",
                              source, log.size() + 1, row[0], log.back().t_s));
    }
    log.push_back({row[0], Eigen::Vector3d(row[1], row[2], row[3])});
  }
  if (log.size() < 2) {
    throw Error(fmt::format("{}: {} reading(s); a reference log needs at least 2", source,
                            log.size()));
  }
  return log;
}

std::vector<ReferenceSample> LoadReferenceLog(const std::string& path) {
  return ParseReferenceLog(ReadFileCapped(path, kMaxReferenceLogBytes, "reference log"), path);
}

void ReferenceJoinOptions::Validate() const {
  const OptionCheck require("ReferenceJoinOptions");
  if (time_offset_s) require(std::isfinite(*time_offset_s), "time_offset_s", "finite", *time_offset_s);
  require(max_offset_s >= 0.0 && max_offset_s <= kMaxSearchedOffsetS, "max_offset_s",
          "in [0, 600] s", max_offset_s);
  require(min_correlation > 0.0 && min_correlation <= 1.0, "min_correlation", "in (0, 1]",
          min_correlation);
  require(min_force_n > 0.0 && std::isfinite(min_force_n), "min_force_n", "> 0 N and finite",
          min_force_n);
  require(max_rate_n_per_s > 0.0 && std::isfinite(max_rate_n_per_s), "max_rate_n_per_s",
          "> 0 N/s and finite", max_rate_n_per_s);
  for (int axis = 0; axis < 3; ++axis) {
    require(gains_used(axis) > 0.0 && std::isfinite(gains_used(axis)), "gains_used",
            "> 0 and finite", gains_used(axis));
  }
}

nlohmann::json ToJson(const ReferenceJoin& join) {
  return {{"time_offset_s", join.time_offset_s},
          {"offset_estimated", join.offset_estimated},
          {"correlation", join.correlation},
          {"frames", join.frames},
          {"recording_status", join.recording_status},
          {"recording_message", join.recording_message},
          {"pairs", join.pairs.size()},
          {"frame_indices", join.frame_indices},
          {"skipped",
           {{"outside_reference", join.skipped.outside_reference},
            {"below_force", join.skipped.below_force},
            {"changing", join.skipped.changing},
            {"flagged", join.skipped.flagged},
            {"invalid_markers", join.skipped.invalid_markers}}}};
}

double EstimateTimeOffset(const std::vector<double>& frame_t_s,
                          const std::vector<Eigen::Vector3d>& frame_force_n,
                          const std::vector<ReferenceSample>& reference,
                          const ReferenceJoinOptions& options,
                          double* correlation) {
  TAC3D_DEMAND(frame_t_s.size() == frame_force_n.size() && reference.size() >= 2);
  std::vector<double> magnitude;
  for (const Eigen::Vector3d& f : frame_force_n) magnitude.push_back(f.norm());
  std::optional<double> best_offset;
  double best = -2.0;
  const auto search = [&](double from, double to, double step) {
    const int steps = static_cast<int>(std::floor((to - from) / step + 1e-9));
    for (int k = 0; k <= steps; ++k) {
      const double offset = from + k * step;
      const std::optional<double> r = MagnitudeCorrelation(frame_t_s, magnitude, reference, offset);
      if (r && *r > best) {
        best = *r;
        best_offset = offset;
      }
    }
  };
  search(-options.max_offset_s, options.max_offset_s, kCoarseStepS);
  if (!best_offset) {
    throw Error(fmt::format("the recording and the reference log overlap in fewer than {} frames "
                            "(or one of them is constant) at every offset within +-{} s: check "
                            "the files, or give the offset",
                            kMinOverlapFrames, options.max_offset_s));
  }
  const double coarse = *best_offset;
  search(coarse - kCoarseStepS, coarse + kCoarseStepS, kFineStepS);
  if (best < options.min_correlation) {
    throw Error(fmt::format("the recording's and the reference's force magnitudes correlate at "
                            "most {:.3f} (at an offset of {:.4f} s, within +-{} s), under {}: "
                            "they may not be the same session, or the offset lies outside the "
                            "search; give the offset (recording time = reference time + offset)",
                            best, *best_offset, options.max_offset_s, options.min_correlation));
  }
  *correlation = best;
  return *best_offset;
}

ReferenceJoin JoinRecordingWithReference(const std::string& recording_path,
                                         const std::vector<ReferenceSample>& reference,
                                         const ReferenceJoinOptions& options) {
  options.Validate();
  TAC3D_DEMAND(reference.size() >= 2);
  // First pass: the resultants (unit gains) and times, for the offset and the frame interval.
  std::vector<double> times;
  std::vector<Eigen::Vector3d> resultants;
  int rows = 0, cols = 0;
  {
    RecordingReader reader(recording_path);
    while (std::optional<RecordedFrame> recorded = reader.Next()) {
      const TactileFrame& frame = recorded->frame;
      if (times.empty()) {
        rows = frame.rows;
        cols = frame.cols;
      } else if (frame.rows != rows || frame.cols != cols) {
        throw Error(fmt::format("{}: frame {} has a {} x {} marker grid, the first one {} x {}",
                                recording_path, frame.index, frame.rows, frame.cols, rows, cols));
      }
      times.push_back(frame.timestamp_s);
      resultants.push_back(frame.resultant_force_n.cwiseQuotient(options.gains_used));
    }
  }
  if (times.size() < 2) {
    throw Error(fmt::format("{}: {} frame(s); nothing to join", recording_path, times.size()));
  }
  ReferenceJoin join;
  join.frames = static_cast<std::int64_t>(times.size());
  if (options.time_offset_s) {
    join.time_offset_s = *options.time_offset_s;
    std::vector<double> magnitude;
    for (const Eigen::Vector3d& f : resultants) magnitude.push_back(f.norm());
    join.correlation =
        MagnitudeCorrelation(times, magnitude, reference, join.time_offset_s).value_or(0.0);
  } else {
    join.time_offset_s = EstimateTimeOffset(times, resultants, reference, options, &join.correlation);
    join.offset_estimated = true;
  }
  // The reference's rate of change over one frame interval (central difference).
  std::vector<double> intervals;
  for (size_t k = 1; k < times.size(); ++k) intervals.push_back(times[k] - times[k - 1]);
  std::nth_element(intervals.begin(), intervals.begin() + intervals.size() / 2, intervals.end());
  const double half_interval = std::max(0.5 * intervals[intervals.size() / 2], 1e-4);

  // Second pass: the frames that are steady presses.
  RecordingReader reader(recording_path);
  size_t hint = 0, hint_before = 0, hint_after = 0;
  while (std::optional<RecordedFrame> recorded = reader.Next()) {
    const TactileFrame& frame = recorded->frame;
    const double t = frame.timestamp_s - join.time_offset_s;
    const std::optional<Eigen::Vector3d> force = ForceAt(reference, t, &hint);
    if (!force) {
      ++join.skipped.outside_reference;
      continue;
    }
    if (force->norm() < options.min_force_n) {
      ++join.skipped.below_force;
      continue;
    }
    const double before = std::max(t - half_interval, reference.front().t_s);
    const double after = std::min(t + half_interval, reference.back().t_s);
    const double rate = after > before ? (*ForceAt(reference, after, &hint_after) -
                                          *ForceAt(reference, before, &hint_before))
                                                 .norm() /
                                             (after - before)
                                       : 0.0;
    if (rate > options.max_rate_n_per_s) {
      ++join.skipped.changing;
      continue;
    }
    if ((frame.flags & ~static_cast<std::uint32_t>(FrameFlag::kZeroed)) != 0) {
      ++join.skipped.flagged;
      continue;
    }
    if (!AllValid(frame)) {
      ++join.skipped.invalid_markers;
      continue;
    }
    join.pairs.push_back({frame.resultant_force_n.cwiseQuotient(options.gains_used), *force});
    join.presses.push_back({PaperOrderDisplacements(frame), *force, std::nullopt});
    join.frame_indices.push_back(frame.index);
  }
  join.recording_status = RecordingStatusName(reader.status());
  join.recording_message = reader.message();
  return join;
}

}  // namespace tac3d
