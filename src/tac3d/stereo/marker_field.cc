#include "tac3d/stereo/marker_field.h"

#include <cmath>

#include "tac3d/util/error.h"

namespace tac3d {

int MarkerField::CountValid() const {
  int n = 0;
  for (std::uint8_t v : valid) n += v != 0;
  return n;
}

void MarkerTriangulatorOptions::Validate() const {
  if (!(max_ray_gap_mm > 0)) {
    throw Error(fmt::format("marker triangulation: max_ray_gap_mm = {} must be > 0", max_ray_gap_mm));
  }
  if (model != RefractionModel::kNone) compensation.Validate();
}

void StereoTriangulator::Triangulate(const std::vector<Eigen::Vector2d>& left,
                                     const std::vector<Eigen::Vector2d>& right, MarkerField& out) const {
  if (static_cast<int>(left.size()) != markers_ || static_cast<int>(right.size()) != markers_) {
    throw Error(fmt::format("triangulation: {} left and {} right markers given, the grid has {}",
                            left.size(), right.size(), markers_));
  }
  if (static_cast<int>(out.positions.size()) != markers_) {
    out.positions.assign(markers_, Eigen::Vector3d::Zero());
    out.displacements.assign(markers_, Eigen::Vector3d::Zero());
    out.valid.assign(markers_, 0);
  }
  const Eigen::Vector3d nan = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  for (int i = 0; i < markers_; ++i) {
    const std::optional<Eigen::Vector3d> p =
        left[i].allFinite() && right[i].allFinite() ? TriangulateMarker(left[i], right[i]) : std::nullopt;
    out.valid[i] = p ? 1 : 0;
    out.positions[i] = p ? *p : nan;
  }
}

MarkerTriangulator::MarkerTriangulator(const SensorConfig& config,
                                       const MarkerTriangulatorOptions& options)
    : StereoTriangulator(config.markers.rows * config.markers.cols),
      options_((options.Validate(), options)),
      rig_(StereoRig::FromSensorConfig(config, /*with_gel=*/true)) {
  // The exact model starts from the polynomial's answer, so both need it.
  if (options.model != RefractionModel::kNone) {
    compensation_ = RefractionCompensation::Fit(rig_, config, options.compensation);
  }
}

std::optional<Eigen::Vector3d> MarkerTriangulator::TriangulateMarker(const Eigen::Vector2d& left,
                                                                     const Eigen::Vector2d& right) const {
  const Triangulation air = TriangulateMidpoint(rig_, left, right);
  if (!air.valid || air.residual > options_.max_ray_gap_mm) return std::nullopt;
  Eigen::Vector3d p = air.point;
  if (options_.model != RefractionModel::kNone) p = compensation_->Correct(p);
  if (options_.model == RefractionModel::kExact) {
    const Triangulation exact = TriangulateRefracted(rig_, left, right, p);
    if (!exact.valid) return std::nullopt;
    p = exact.point;
  }
  return p;
}

void DisplacementReference::Set(const std::vector<MarkerField>& frames) {
  if (frames.empty()) throw Error("displacement reference: no frames to take it from");
  const size_t n = frames.front().positions.size();
  std::vector<Eigen::Vector3d> sum(n, Eigen::Vector3d::Zero());
  std::vector<int> count(n, 0);
  for (const MarkerField& f : frames) {
    if (f.positions.size() != n) throw Error("displacement reference: frames of different sizes");
    for (size_t i = 0; i < n; ++i) {
      if (!f.valid[i]) continue;
      sum[i] += f.positions[i];
      ++count[i];
    }
  }
  reference_.assign(n, Eigen::Vector3d::Zero());
  known_.assign(n, 0);
  for (size_t i = 0; i < n; ++i) {
    if (count[i] == 0) continue;
    reference_[i] = sum[i] / count[i];
    known_[i] = 1;
  }
}

void DisplacementReference::Shift(std::size_t i, const Eigen::Vector3d& delta_mm) {
  TAC3D_DEMAND(i < reference_.size());
  reference_[i] += delta_mm;
}

void DisplacementReference::Apply(MarkerField& field) const {
  if (field.positions.size() != reference_.size()) {
    throw Error(fmt::format("displacement reference has {} markers, the frame {}",
                            reference_.size(), field.positions.size()));
  }
  for (size_t i = 0; i < reference_.size(); ++i) {
    if (!known_[i]) field.valid[i] = 0;
    field.displacements[i] = field.valid[i] ? Eigen::Vector3d(field.positions[i] - reference_[i])
                                            : Eigen::Vector3d::Zero();
  }
}

}  // namespace tac3d
