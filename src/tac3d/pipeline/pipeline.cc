#include "tac3d/pipeline/pipeline.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "tac3d/force/regularization.h"
#include "tac3d/util/error.h"
#include "tac3d/vendor_formats/vendor_stereo.h"

namespace tac3d {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The sensor's camera model: a vendor's when it was imported with one, else the mirror rig.
std::unique_ptr<StereoTriangulator> MakeTriangulator(const SensorConfig& config,
                                                     const MarkerTriangulatorOptions& options) {
  if (config.vendor_camera) return std::make_unique<VendorMarkerTriangulator>(config, options.max_ray_gap_mm);
  return std::make_unique<MarkerTriangulator>(config, options);
}


}  // namespace

ForceReconstructorOptions DefaultForceOptions(const SensorConfig& config) {
  ForceReconstructorOptions force = PipelineOptions{}.force;
  if (config.vendor_camera) force.support_refinement = false;
  return force;
}

PipelineOptions DefaultPipelineOptions(const SensorConfig& config) {
  PipelineOptions options;
  options.sn = DefaultSerialNumber(config);
  options.force = DefaultForceOptions(config);
  return options;
}

std::string DefaultSerialNumber(const SensorConfig& config) {
  if (config.vendor_camera && !config.vendor_camera->serial_number.empty()) return config.vendor_camera->serial_number;
  return PipelineOptions{}.sn;
}

std::vector<Eigen::Vector3d> RestMarkerPositions(const SensorConfig& config) {
  if (!config.vendor_camera) return config.MarkerPositions();
  std::vector<Eigen::Vector3d> points;
  for (const Triangulation& t : VendorStereo(config).TriangulateReference()) points.push_back(t.point);
  return points;
}

void PipelineOptions::Validate() const {
  const OptionCheck require("pipeline");
  if (sn.empty()) throw Error("pipeline: sn must not be empty");
  require(reference_frames >= 2 && reference_frames <= 10000, "reference_frames", "in [2, 10000]",
          reference_frames);
  require(displacement_range_mm > 0, "displacement_range_mm", "> 0", displacement_range_mm);
  require(force_range_n > 0, "force_range_n", "> 0", force_range_n);
  force.Validate();
  lighting.Validate();
  drift.Validate();
  contact.Validate();
  slip.Validate();
  stereo.Validate();
}

Pipeline::Pipeline(const SensorConfig& config, const Eigen::MatrixXd& h,
                   const std::vector<Eigen::Vector3d>& fem_markers_mm, const PipelineOptions& options)
    : Pipeline(config, std::make_shared<const Eigen::MatrixXd>(h), fem_markers_mm, options) {}

Pipeline::Pipeline(const SensorConfig& config, const std::shared_ptr<const Eigen::MatrixXd>& h,
                   const std::vector<Eigen::Vector3d>& fem_markers_mm, const PipelineOptions& options)
    : options_((options.Validate(), options)),
      rows_(config.markers.rows),
      cols_(config.markers.cols),
      tracker_(config, options.tracking),
      triangulator_(MakeTriangulator(config, options.stereo)),
      reconstructor_(h, fem_markers_mm, options.force),
      surface_(config.markers.rows, config.markers.cols, fem_markers_mm, options.contact),
      slip_(config.markers.rows * config.markers.cols, options.slip),
      lighting_(options.lighting),
      drift_(options.drift) {
  const size_t n = static_cast<size_t>(rows_) * cols_;
  if (fem_markers_mm.size() != n) {
    throw Error(fmt::format("pipeline: the sensor has {} x {} markers, the compliance model {}", rows_, cols_,
                            fem_markers_mm.size()));
  }
  // The FEM's markers must be the sensor's: H was built for them.
  const std::vector<Eigen::Vector3d> sensor_markers = RestMarkerPositions(config);
  for (size_t i = 0; i < n; ++i) {
    if ((sensor_markers[i] - fem_markers_mm[i]).norm() > 1e-6) {
      throw Error(fmt::format("pipeline: marker {} is at ({:.3f}, {:.3f}, {:.3f}) in the sensor config but at "
                              "({:.3f}, {:.3f}, {:.3f}) in the compliance model: built for another sensor?",
                              i, sensor_markers[i].x(), sensor_markers[i].y(), sensor_markers[i].z(),
                              fem_markers_mm[i].x(), fem_markers_mm[i].y(), fem_markers_mm[i].z()));
    }
  }
  d_.resize(3 * n);
  valid_.resize(n);
}

Pipeline::~Pipeline() = default;

bool Pipeline::initializing() const { return reference_.empty() || zero_requested_; }

void Pipeline::RequestZero() {
  zero_requested_ = true;
  reference_stack_.clear();
  lighting_.ClearReference();
}

void Pipeline::FillInitializing(int progress, TactileFrame& out) const {
  out.initialize_progress = progress;
  out.set(FrameFlag::kInitializing);
  int lost = 0;
  for (int i = 0; i < out.num_markers(); ++i) {
    out.valid[i] = field_.valid[i] != 0;
    lost += out.valid[i] ? 0 : 1;
    out.positions_mm[i] = out.valid[i] ? field_.positions[i] : Eigen::Vector3d::Constant(kNaN);
    out.displacements_mm[i] = out.valid[i] ? Eigen::Vector3d::Zero() : Eigen::Vector3d::Constant(kNaN);
    out.forces_n[i].setZero();
    out.normals[i] = surface_.rest_normals().col(i);
    out.contact[i] = false;
  }
  out.resultant_force_n.setZero();
  out.resultant_moment_nmm.setZero();
  out.set(FrameFlag::kMarkersLost, lost > 0);
  out.slip = FrameSlip{.state = SlipState::kNone};
}

bool Pipeline::CollectReference(TactileFrame& out) {
  const int n = rows_ * cols_;
  // The reference is taken from consecutive frames that see the grid: a covered or dark
  // frame starts the collection again.
  auto restart = [&] {
    reference_stack_.clear();
    lighting_.ClearReference();
    FillInitializing(0, out);
    return false;
  };
  if (2 * field_.CountValid() < n) return restart();
  reference_stack_.push_back(field_);
  lighting_.AddReference(observation_);
  if (static_cast<int>(reference_stack_.size()) < options_.reference_frames) {
    FillInitializing(static_cast<int>(100 * reference_stack_.size() / options_.reference_frames), out);
    return false;
  }
  // A reference needs most markers seen in every frame (a black or covered start is not
  // the undeformed state): otherwise start collecting again.
  int steady = 0;
  for (int i = 0; i < n; ++i) {
    steady += std::all_of(reference_stack_.begin(), reference_stack_.end(),
                          [i](const MarkerField& f) { return f.valid[i] != 0; });
  }
  if (2 * steady < n) return restart();
  reference_.Set(reference_stack_);
  lighting_.FinishReference();
  drift_.Reset();
  std::vector<Eigen::VectorXd> static_d;
  for (MarkerField& f : reference_stack_) {
    reference_.Apply(f);
    Eigen::VectorXd d(3 * n);
    for (int i = 0; i < n; ++i) {
      for (int a = 0; a < 3; ++a) d[a * n + i] = f.valid[i] ? f.displacements[i][a] : kNaN;
    }
    static_d.push_back(std::move(d));
  }
  noise_variance_ = EstimateDisplacementNoise(static_d).variance_mm2;
  slip_.SetDisplacementVariance(*noise_variance_);
  slip_.SetMarkerForceSigma(reconstructor_.CalcUncertainty(*noise_variance_).marker_sigma_n);
  reference_stack_.clear();
  return true;
}

void Pipeline::Process(const Frame& frame, TactileFrame& out) {
  if (!std::isfinite(frame.timestamp_s)) {
    throw Error(fmt::format("pipeline: frame {}: timestamp {} s is not finite", frame.index,
                            frame.timestamp_s));
  }
  const int n = rows_ * cols_;
  if (out.num_markers() != n || out.positions_mm.size() != static_cast<size_t>(n)) {
    out = TactileFrame::Sized(rows_, cols_);
  }
  tracker_.Track(frame.image, observation_, frame.decoded_region);
  triangulator_->Triangulate(observation_.half(ImageHalf::kLeft).uv, observation_.half(ImageHalf::kRight).uv,
                            field_);
  out.sn = options_.sn;
  out.index = frames_;
  out.timestamp_s = frame.timestamp_s;
  out.flags = 0;
  out.set(FrameFlag::kGridReacquired, observation_.summary.acquired && frames_ > 0);
  ++frames_;

  bool zeroed_now = false;
  if (initializing()) {
    if (!CollectReference(out)) return;
    zeroed_now = zero_requested_;
    zero_requested_ = false;
  }
  out.initialize_progress = 100;
  out.set(FrameFlag::kZeroed, zeroed_now);
  out.set(FrameFlag::kLightingChanged, lighting_.Compare(observation_).changed);

  reference_.Apply(field_);
  out.set(FrameFlag::kDriftAtRest, drift_.Update(frame.timestamp_s, field_, reference_).flagged);
  int lost = 0;
  for (int i = 0; i < n; ++i) {
    const bool valid = field_.valid[i] != 0;
    lost += valid ? 0 : 1;
    out.valid[i] = valid;
    out.positions_mm[i] = valid ? field_.positions[i] : Eigen::Vector3d::Constant(kNaN);
    out.displacements_mm[i] = valid ? field_.displacements[i] : Eigen::Vector3d::Constant(kNaN);
  }
  out.set(FrameFlag::kMarkersLost, lost > 0);
  ComputeForces(out);
}

void Pipeline::RecomputeForces(TactileFrame& frame) {
  const int n = rows_ * cols_;
  if (frame.num_markers() != n) {
    throw Error(fmt::format("recomputing forces: the frame has {} markers, the sensor {} x {}", frame.num_markers(),
                            rows_, cols_));
  }
  for (int i = 0; i < n; ++i) {
    if (frame.valid[i] && !(frame.positions_mm[i].allFinite() && frame.displacements_mm[i].allFinite())) {
      throw Error(fmt::format("recomputing forces: frame {}: valid marker {} has a position or displacement that "
                              "is not finite",
                              frame.index, i));
    }
  }
  ComputeForces(frame);
}

void Pipeline::ComputeForces(TactileFrame& out) {
  const int n = rows_ * cols_;
  double max_displacement = 0.0;
  for (int i = 0; i < n; ++i) {
    const bool valid = out.valid[i];
    valid_[i] = valid;
    for (int a = 0; a < 3; ++a) d_[a * n + i] = valid ? out.displacements_mm[i][a] : kNaN;
    if (valid) max_displacement = std::max(max_displacement, out.displacements_mm[i].norm());
  }
  reconstructor_.Reconstruct(d_, valid_, &force_);
  const ForceDecomposition parts = surface_.Decompose(d_, valid_, force_.forces_n);
  for (int i = 0; i < n; ++i) {
    out.forces_n[i] = force_.MarkerForce(i);
    out.normals[i] = parts.normals.col(i);
    out.contact[i] = parts.contact[i];
  }
  out.resultant_force_n = force_.resultant_force_n;
  out.resultant_moment_nmm = force_.resultant_moment_nmm;
  out.set(FrameFlag::kDisplacementOutOfRange, max_displacement > options_.displacement_range_mm);
  out.set(FrameFlag::kForceOutOfRange, force_.resultant_force_n.norm() > options_.force_range_n);
  out.slip = slip_.Estimate(out);
}

}  // namespace tac3d
