#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "tac3d/geometry/geometry.h"
#include "tac3d/source/frame_source.h"

namespace tac3d {

/// The contact state of a surface node.
enum class ContactState : std::uint8_t { kSeparated = 0, kStick = 1, kSlip = 2 };

/// The twin's truth on the fingertip's outer surface at one step: node positions (sensor
/// frame, undeformed, mm), their tractions (N/mm^2, sensor frame: the object's push on the
/// fingertip) and contact states.
struct SurfaceTractions {
  std::vector<Eigen::Vector3d> positions_mm;
  std::vector<Eigen::Vector3d> tractions_mpa;
  std::vector<ContactState> states;
  /// The object's mu (its FrictionAt) where a node touches it, NaN where separated. Kept in
  /// memory only (tac3d.simulate_arrays); the dataset folder's surface files do not hold it.
  std::vector<double> friction;
};

/// One step of a twin simulation with its ground truth.
struct TwinStep {
  int index = 0;
  double t_s = 0.0;
  Rigid3 world_from_sensor = Rigid3::Identity();
  cv::Mat image;  ///< the rendered camera frame, CV_8UC1 (empty: not rendered)
  /// Per marker, row-major: true position (sensor frame, mm), true force on its surface
  /// patch (N, sensor frame), in contact, slipping.
  std::vector<Eigen::Vector3d> marker_positions_mm;
  std::vector<Eigen::Vector3d> marker_forces_n;
  std::vector<std::uint8_t> marker_contact;
  std::vector<std::uint8_t> marker_slip;
  Eigen::Vector3d total_force_n = Eigen::Vector3d::Zero();
  /// About the sensor origin, N mm (as the pipeline reports it).
  Eigen::Vector3d total_moment_nmm = Eigen::Vector3d::Zero();
  SurfaceTractions surface;
  /// The contact solver's report for this step (iterations, residuals, status).
  nlohmann::json solver;
  /// The session's nuisances at this step, their truth (a scene's `conditions`,
  /// docs/render.md); null in a nominal session. The marker positions include their creep.
  nlohmann::json conditions;
};

/// Writes a dataset folder (layout: docs/datasets.md). Each step is written to temporary
/// names and renamed into place, image first and the step's JSON last, so a simulation
/// stopped at any moment leaves only complete steps behind.
class TwinDatasetWriter {
 public:
  /// Creates the folder and writes `dataset.json` (the header: name, the scene and sensor
  /// as given, anything else in `header`).
  /// @throws Error if the folder it goes in does not exist (CheckOutputFolder: a typo in a
  ///   parent is refused, not created), or the folder cannot be created or is not empty.
  TwinDatasetWriter(const std::string& folder, const nlohmann::json& header);

  /// @throws Error if a file cannot be written or the step's arrays disagree in length.
  void Write(const TwinStep& step);

  /// Adds (or replaces) top-level keys of `dataset.json`, rewritten atomically, e.g. the
  /// run's timings once it is over. @throws Error if it cannot be written.
  void UpdateHeader(const nlohmann::json& keys);

  const std::string& folder() const { return folder_; }

 private:
  std::string folder_;
  nlohmann::json header_;
  int markers_ = -1;
};

/// Reads a dataset folder written by TwinDatasetWriter.
class TwinDatasetReader {
 public:
  /// @throws Error if the folder has no readable dataset.json.
  explicit TwinDatasetReader(const std::string& folder);

  const nlohmann::json& header() const { return header_; }
  /// The complete steps present, in order.
  const std::vector<int>& steps() const { return steps_; }
  /// @param with_surface also read the surface tractions (the largest part).
  /// @throws Error naming the file if a step is missing or malformed.
  TwinStep Read(int step, bool with_surface = false) const;
  std::string ImagePath(int step) const;

 private:
  std::string folder_;
  nlohmann::json header_;
  std::vector<int> steps_;
};

/// The dataset's camera images as a FrameSource (timestamps are the steps' t_s); a step
/// without an image is a kBadFrame.
/// @throws Error as TwinDatasetReader does, or if the dataset has no step.
std::unique_ptr<FrameSource> OpenTwinDataset(const std::string& folder);

}  // namespace tac3d
