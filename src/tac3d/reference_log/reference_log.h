#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

#include "tac3d/force/force_gains.h"
#include "tac3d/frame/tactile_frame.h"

namespace tac3d {

/// One reading of a reference force sensor, in the tactile sensor's frame (N), at a time on
/// the reference's own clock (s).
struct ReferenceSample {
  double t_s = 0.0;
  Eigen::Vector3d force_n = Eigen::Vector3d::Zero();
};

/// The header line of a reference-log CSV file.
inline constexpr const char* kReferenceLogCsvHeader = "t_s,fx_n,fy_n,fz_n";

/// Parses a reference log: the header kReferenceLogCsvHeader, then one reading a line (time,
/// force), times strictly increasing. Blank and '#' lines skipped, spaces allowed.
/// @throws tac3d::Error as ParseNumberCsv, and naming the line of a time that does not
///   increase; fewer than 2 readings.
std::vector<ReferenceSample> ParseReferenceLog(const std::string& csv_text,
                                               const std::string& source = "<text>");
/// Reads a reference-log CSV file (ParseReferenceLog).
std::vector<ReferenceSample> LoadReferenceLog(const std::string& path);

/// The widest offset search, +- (s): ten minutes between starting the two logs by hand. The
/// search tries an offset every 10 ms, each a pass over the frames, so the bound also keeps it
/// to seconds (+-1e9 s would be 2e11 offsets).
inline constexpr double kMaxSearchedOffsetS = 600.0;

/// How a recording is joined with a reference log into calibration pairs and presses.
struct ReferenceJoinOptions {
  /// Recording time = reference time + offset (s). Unset: estimated as the offset that best
  /// correlates the two force magnitudes (EstimateTimeOffset).
  std::optional<double> time_offset_s;
  /// The estimate's search range, +- (s), at most kMaxSearchedOffsetS, and the least
  /// correlation it accepts.
  double max_offset_s = 10.0;
  double min_correlation = 0.9;
  /// A frame is a press when the reference reads at least this much (N).
  double min_force_n = 0.2;
  /// ... and changes no faster than this (N/s): a residual clock error of dt costs rate x dt,
  /// 10 N/s x 1 ms = 0.01 N.
  double max_rate_n_per_s = 10.0;
  /// The gains the recording was made with (`tac3d run --gains`); its resultants are divided
  /// by them, since a pair's measured force is the one with unit gains.
  Eigen::Vector3d gains_used = Eigen::Vector3d::Ones();

  /// @throws tac3d::Error naming the field and its bound: max_offset_s in
  ///   [0, kMaxSearchedOffsetS]; min_correlation in (0, 1]; min_force_n, max_rate_n_per_s and
  ///   the gains > 0 and finite; the offset finite.
  void Validate() const;
};

/// Frames a join left out, by reason (a frame counts under the first reason that applies, in
/// this order).
struct ReferenceJoinSkips {
  std::int64_t outside_reference = 0;  ///< its time falls outside the log
  std::int64_t below_force = 0;        ///< the reference reads less than min_force_n
  std::int64_t changing = 0;           ///< the reference changes faster than max_rate_n_per_s
  std::int64_t flagged = 0;            ///< a frame flag other than zeroed (lost markers, ...)
  std::int64_t invalid_markers = 0;    ///< a marker not measured (presses need every one)
};

/// The pairs and presses a recording and a reference log give.
struct ReferenceJoin {
  double time_offset_s = 0.0;
  bool offset_estimated = false;
  /// The force magnitudes' correlation at the offset (Pearson, over the overlapping frames).
  double correlation = 0.0;
  std::int64_t frames = 0;
  /// How the recording ended (RecordingStatusName) and where: the frames before a truncated or
  /// corrupt record are used.
  std::string recording_status;
  std::string recording_message;
  std::vector<ForcePair> pairs;
  std::vector<CalibrationPress> presses;
  /// The recording's frame index of each pair and press.
  std::vector<std::int64_t> frame_indices;
  ReferenceJoinSkips skipped;
};

nlohmann::json ToJson(const ReferenceJoin& join);

/// The offset (recording time = reference time + offset) in [-max_offset_s, max_offset_s] that
/// maximises the correlation of the frames' resultant magnitudes with the reference's
/// magnitudes at the frames' times: a 10 ms grid, then 0.5 ms around the best. Magnitudes, so a
/// sign or axis convention of the reference does not spoil the estimate.
/// @param correlation set to the correlation at the offset.
/// @throws tac3d::Error if fewer than 10 frames overlap the log at every offset, or the best
///   correlation is below min_correlation (the message says to give the offset).
double EstimateTimeOffset(const std::vector<double>& frame_t_s,
                          const std::vector<Eigen::Vector3d>& frame_force_n,
                          const std::vector<ReferenceSample>& reference,
                          const ReferenceJoinOptions& options,
                          double* correlation);

/// Joins a recording (read twice: its resultants for the offset, then its frames) with a
/// reference log: every frame that is a steady press with every marker measured and no flag
/// but zeroed gives a pair (its resultant with unit gains, the reference interpolated at its
/// time) and a press (its displacements, the same reference).
/// @throws tac3d::Error if the options are invalid, the recording cannot be read, its frames
///   do not share one marker grid, or the offset cannot be estimated.
ReferenceJoin JoinRecordingWithReference(const std::string& recording_path,
                                         const std::vector<ReferenceSample>& reference,
                                         const ReferenceJoinOptions& options);

}  // namespace tac3d
