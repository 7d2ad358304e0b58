#include "tac3d/vendor_formats/vendor_frames.h"

#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

NpyArray Float64Array(std::vector<std::int64_t> shape, const std::vector<double>& values) {
  NpyArray a;
  a.shape = std::move(shape);
  a.data.assign(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(double));
  return a;
}

void Append(std::vector<double>* values, const Eigen::Vector3d& v) {
  values->insert(values->end(), {v.x(), v.y(), v.z()});
}

}  // namespace

VendorFrames::VendorFrames(VendorRecording recording) : recording_(std::move(recording)) {
  const std::int64_t markers = recording_.markers();
  side_ = static_cast<int>(std::lround(std::sqrt(static_cast<double>(markers))));
  if (side_ < 1 || side_ > TactileFrame::kMaxGridSide || static_cast<std::int64_t>(side_) * side_ != markers) {
    throw Error(fmt::format("recording of '{}': {} markers are not a square grid of at most {} x {}",
                            recording_.serial_number, markers, TactileFrame::kMaxGridSide,
                            TactileFrame::kMaxGridSide));
  }
  index_ = recording_.index.Int64Values();
  time_s_ = recording_.send_timestamp.Float64Values();
  if (frames() == 0) return;
  if (const std::int64_t lost = recording_.FirstNonFiniteMarker(0); lost >= 0) {
    throw Error(fmt::format("recording of '{}': frame 0, the reference, has a marker ({}) whose position, "
                            "displacement or force is not a finite number",
                            recording_.serial_number, lost));
  }
  reference_ = recording_.ReferencePositions(0);
  std::vector<Eigen::Vector3d> rest(static_cast<std::size_t>(markers));
  for (std::int64_t i = 0; i < markers; ++i) rest[i] = reference_.row(i).transpose();
  try {
    surface_.emplace(side_, side_, std::move(rest));
  } catch (const Error&) {
    // No grid surface to take normals of (a test's points on a line, say): they stay zero.
  }
}

TactileFrame VendorFrames::Frame(std::int64_t f) const {
  TAC3D_DEMAND(f >= 0 && f < frames());
  const std::int64_t markers = recording_.markers();
  TactileFrame frame = TactileFrame::Sized(side_, side_);
  frame.sn = recording_.serial_number;
  frame.index = index_[f];
  frame.timestamp_s = time_s_[f];
  Eigen::MatrixX3d positions = VendorRecording::Frame(recording_.positions, f);
  Eigen::MatrixX3d displacements = VendorRecording::Frame(recording_.displacements, f);
  Eigen::MatrixX3d forces = VendorRecording::Frame(recording_.forces, f);
  for (std::int64_t i = 0; i < markers; ++i) {
    // A marker with a NaN or an infinity is lost this frame: at its reference, unloaded, so
    // the frame's other markers and normals are computed as without it.
    if (!VendorRecording::MarkerIsFinite(positions, displacements, forces, i)) {
      frame.valid[i] = false;
      frame.set(FrameFlag::kMarkersLost);
      positions.row(i) = reference_.row(i);
      displacements.row(i).setZero();
      forces.row(i).setZero();
    }
    frame.positions_mm[i] = positions.row(i).transpose();
    frame.displacements_mm[i] = displacements.row(i).transpose();
    frame.forces_n[i] = forces.row(i).transpose();
  }
  frame.resultant_force_n = VendorRecording::Frame(recording_.resultant_force, f).row(0).transpose();
  frame.resultant_moment_nmm = VendorRecording::Frame(recording_.resultant_moment, f).row(0).transpose();
  if (surface_) {
    // The surface's displacements from frame 0's reference: the positions themselves, whatever
    // the vendor's zero point did since (MarkerSurface takes x, then y, then z).
    const Eigen::MatrixX3d from_reference = positions - reference_;
    Eigen::VectorXd d(3 * markers), f_n(3 * markers);
    for (int k = 0; k < 3; ++k) {
      d.segment(k * markers, markers) = from_reference.col(k);
      f_n.segment(k * markers, markers) = forces.col(k);
    }
    const ForceDecomposition parts = surface_->Decompose(d, {}, f_n);
    for (std::int64_t i = 0; i < markers; ++i) {
      frame.normals[i] = parts.normals.col(i);
      frame.contact[i] = parts.contact[i];
    }
  }
  return frame;
}

std::vector<TactileFrame> FramesOfVendorRecording(const VendorRecording& recording) {
  const VendorFrames vendor(recording);
  std::vector<TactileFrame> frames;
  frames.reserve(static_cast<std::size_t>(vendor.frames()));
  for (std::int64_t f = 0; f < vendor.frames(); ++f) frames.push_back(vendor.Frame(f));
  return frames;
}

VendorRecording VendorRecordingOfFrames(const std::vector<TactileFrame>& frames) {
  if (frames.empty()) throw Error("no frame to write as a vendor recording");
  const TactileFrame& first = frames.front();
  const auto t = static_cast<std::int64_t>(frames.size());
  const std::int64_t n = first.num_markers();
  std::vector<double> positions, displacements, forces, resultant, moment, time;
  std::vector<std::int64_t> index;
  for (const TactileFrame& frame : frames) {
    if (frame.sn != first.sn || frame.rows != first.rows || frame.cols != first.cols) {
      throw Error(fmt::format("frame {}: serial number '{}' and grid {} x {} differ from the first frame's ('{}', "
                              "{} x {}): a vendor recording holds one sensor",
                              frame.index, frame.sn, frame.rows, frame.cols, first.sn, first.rows, first.cols));
    }
    frame.Validate();
    for (std::int64_t i = 0; i < n; ++i) {
      Append(&positions, frame.positions_mm[i]);
      Append(&displacements, frame.displacements_mm[i]);
      Append(&forces, frame.forces_n[i]);
    }
    Append(&resultant, frame.resultant_force_n);
    Append(&moment, frame.resultant_moment_nmm);
    index.push_back(frame.index);
    time.push_back(frame.timestamp_s);
  }
  VendorRecording r;
  r.serial_number = first.sn;
  r.positions = Float64Array({t, n, 3}, positions);
  r.displacements = Float64Array({t, n, 3}, displacements);
  r.forces = Float64Array({t, n, 3}, forces);
  r.resultant_force = Float64Array({t, 1, 3}, resultant);
  r.resultant_moment = Float64Array({t, 1, 3}, moment);
  r.send_timestamp = Float64Array({t}, time);
  r.index.type = NpyType::kInt64;
  r.index.shape = {t};
  r.index.data.assign(reinterpret_cast<const char*>(index.data()), index.size() * sizeof(std::int64_t));
  return r;
}

}  // namespace tac3d
