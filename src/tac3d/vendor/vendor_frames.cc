#include "tac3d/vendor/vendor_frames.h"

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

std::vector<TactileFrame> FramesOfVendorRecording(const VendorRecording& recording) {
  const std::int64_t markers = recording.markers();
  const int side = static_cast<int>(std::lround(std::sqrt(static_cast<double>(markers))));
  if (side < 1 || side > TactileFrame::kMaxGridSide || static_cast<std::int64_t>(side) * side != markers) {
    throw Error(fmt::format("recording of '{}': {} markers are not a square grid of at most {} x {}",
                            recording.serial_number, markers, TactileFrame::kMaxGridSide,
                            TactileFrame::kMaxGridSide));
  }
  const std::vector<std::int64_t> index = recording.index.Int64Values();
  const std::vector<double> time = recording.send_timestamp.Float64Values();
  std::vector<TactileFrame> frames;
  frames.reserve(index.size());
  for (std::int64_t f = 0; f < recording.frames(); ++f) {
    TactileFrame frame = TactileFrame::Sized(side, side);
    frame.sn = recording.serial_number;
    frame.index = index[f];
    frame.timestamp_s = time[f];
    const Eigen::MatrixX3d positions = VendorRecording::Frame(recording.positions, f);
    const Eigen::MatrixX3d displacements = VendorRecording::Frame(recording.displacements, f);
    const Eigen::MatrixX3d forces = VendorRecording::Frame(recording.forces, f);
    for (std::int64_t i = 0; i < markers; ++i) {
      frame.positions_mm[i] = positions.row(i).transpose();
      frame.displacements_mm[i] = displacements.row(i).transpose();
      frame.forces_n[i] = forces.row(i).transpose();
    }
    frame.resultant_force_n = VendorRecording::Frame(recording.resultant_force, f).row(0).transpose();
    frame.resultant_moment_nmm = VendorRecording::Frame(recording.resultant_moment, f).row(0).transpose();
    frames.push_back(std::move(frame));
  }
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
