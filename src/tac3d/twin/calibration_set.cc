#include "tac3d/twin/calibration_set.h"

#include <cmath>
#include <filesystem>
#include <random>

#include <opencv2/imgcodecs.hpp>

#include "tac3d/imagefile/image_write.h"
#include "tac3d/util/error.h"
#include "tac3d/util/progress.h"

namespace tac3d {
namespace {

// A unit vector uniformly distributed on the sphere.
Eigen::Vector3d RandomDirection(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Eigen::Vector3d v;
  do {
    v = {normal(rng), normal(rng), normal(rng)};
  } while (v.norm() < 1e-9);
  return v.normalized();
}

// True if every dot's image lies inside both halves' columns, `margin` px from their
// edges, on a pixel whose ray really reaches that half's mirrors.
bool SeenWhole(const OpticalLayout& layout, const SensorConfig& truth,
               const std::vector<Eigen::Vector3d>& dots_in_sensor, double margin) {
  for (const VirtualCameraConfig& v : truth.virtual_cameras) {
    for (const Eigen::Vector3d& p : dots_in_sensor) {
      const auto uv = ProjectPoint(layout, v.half, p);
      if (!uv || uv->x() < v.column_begin + margin || uv->x() > v.column_end - 1 - margin ||
          uv->y() < margin || uv->y() > v.intrinsics.height - 1 - margin) {
        return false;
      }
      const TracedRay ray = TracePixel(layout, *uv);
      if (!ray.ok() || ray.half != v.half) return false;
    }
  }
  return true;
}

}  // namespace

void SensorPerturbationOptions::Validate() const {
  const OptionCheck require("sensor perturbation");
  require(focal_error_max >= 0 && focal_error_max < 0.5, "focal_error_max",
          "in [0, 0.5)", focal_error_max);
  require(principal_point_error_max_px >= 0, "principal_point_error_max_px", ">= 0",
          principal_point_error_max_px);
  require(k1_min <= k1_max, "k1_min", "<= k1_max", k1_min);
  require(k2_max >= 0, "k2_max", ">= 0", k2_max);
  require(tangential_max >= 0, "tangential_max", ">= 0", tangential_max);
  require(mirror_tilt_max_deg >= 0 && mirror_tilt_max_deg <= 10, "mirror_tilt_max_deg",
          "in [0, 10]", mirror_tilt_max_deg);
  require(mirror_shift_max_mm >= 0 && mirror_shift_max_mm <= 5, "mirror_shift_max_mm",
          "in [0, 5]", mirror_shift_max_mm);
  require(camera_tilt_max_deg >= 0 && camera_tilt_max_deg <= 10, "camera_tilt_max_deg",
          "in [0, 10]", camera_tilt_max_deg);
  require(camera_shift_max_mm >= 0 && camera_shift_max_mm <= 5, "camera_shift_max_mm",
          "in [0, 5]", camera_shift_max_mm);
}

SensorPerturbationOptions SensorPerturbationOptions::ManufacturingSpread(std::uint64_t seed) {
  SensorPerturbationOptions o;
  o.seed = seed;
  o.camera_tilt_max_deg = 0.5;
  o.camera_shift_max_mm = 0.3;
  return o;
}

SensorConfig PerturbSensor(const SensorConfig& nominal, const SensorPerturbationOptions& o) {
  o.Validate();
  if (nominal.mirrors.size() != 4 || nominal.virtual_cameras.size() != 2) {
    throw Error("sensor config has no mirrors or virtual cameras: run `tac3d design` first");
  }
  std::mt19937_64 rng(o.seed);
  auto uniform = [&rng](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  SensorConfig truth = nominal;
  CameraIntrinsics& c = truth.camera.intrinsics;
  const double focal_scale = 1.0 + uniform(-o.focal_error_max, o.focal_error_max);
  c.fx *= focal_scale;
  c.fy *= focal_scale;
  c.cx += uniform(-o.principal_point_error_max_px, o.principal_point_error_max_px);
  c.cy += uniform(-o.principal_point_error_max_px, o.principal_point_error_max_px);
  c.distortion = {uniform(o.k1_min, o.k1_max), uniform(0.0, o.k2_max),
                  uniform(-o.tangential_max, o.tangential_max),
                  uniform(-o.tangential_max, o.tangential_max), 0.0};
  for (MirrorConfig& m : truth.mirrors) {
    Rectangle3& s = m.surface;
    const double phi = uniform(0.0, 2.0 * kPi);
    const Eigen::Vector3d axis = std::cos(phi) * s.u_axis + std::sin(phi) * s.v_axis;
    const Eigen::Matrix3d tilt =
        Eigen::AngleAxisd(DegToRad(uniform(-o.mirror_tilt_max_deg, o.mirror_tilt_max_deg)), axis)
            .toRotationMatrix();
    s.u_axis = tilt * s.u_axis;
    s.v_axis = tilt * s.v_axis;
    s.center += uniform(0.0, o.mirror_shift_max_mm) * RandomDirection(rng);
  }
  // Drawn last, so the draws above (and the calibration figures made with them) stay.
  Rigid3& camera = truth.camera.sensor_from_cam;
  const Eigen::Vector3d camera_axis = RandomDirection(rng);
  camera.linear() = Eigen::AngleAxisd(DegToRad(uniform(-o.camera_tilt_max_deg, o.camera_tilt_max_deg)),
                                      camera_axis).toRotationMatrix() * camera.linear();
  camera.translation() += uniform(0.0, o.camera_shift_max_mm) * RandomDirection(rng);
  const OpticalLayout layout = truth.MakeOpticalLayout(false);
  for (VirtualCameraConfig& v : truth.virtual_cameras) {
    v.sensor_from_vcam = layout.SensorFromVirtualCamera(v.half);
    v.intrinsics = c;
  }
  truth.Validate();
  return truth;
}

void CalibrationSetOptions::Validate() const {
  const OptionCheck require("calibration set");
  require(views >= 1 && views <= kMaxCalibrationViews, "views",
          fmt::format("in [1, {}]", kMaxCalibrationViews).c_str(), views);
  board.Validate();
  require(position_range_mm >= 0, "position_range_mm", ">= 0", position_range_mm);
  require(max_tilt_deg >= 0 && max_tilt_deg < 60, "max_tilt_deg", "in [0, 60)", max_tilt_deg);
  require(max_spin_deg >= 0 && max_spin_deg <= 180, "max_spin_deg", "in [0, 180]", max_spin_deg);
  require(edge_margin_px >= 0, "edge_margin_px", ">= 0", edge_margin_px);
  render.Validate();
}

CalibrationSet RenderCalibrationSet(const SensorConfig& truth, const CalibrationSetOptions& options) {
  std::vector<CalibrationImage> images;
  CalibrationSet set = RenderCalibrationSet(
      truth, options, [&images](const CalibrationImage& image) { images.push_back(image); });
  set.images = std::move(images);
  return set;
}

CalibrationSet RenderCalibrationSet(const SensorConfig& truth,
                                    const CalibrationSetOptions& options,
                                    const std::function<void(const CalibrationImage&)>& sink) {
  options.Validate();
  const OpticalLayout layout = truth.MakeOpticalLayout(false);
  const BoardImageRenderer renderer(truth, options.render);
  const DotBoard dot_board = DotBoard{options.board};
  const std::vector<Eigen::Vector3d> dots = options.board.DotCenters();
  auto seen_whole = [&](const Rigid3& pose) {
    std::vector<Eigen::Vector3d> in_sensor;
    for (const Eigen::Vector3d& p : dots) in_sensor.push_back(pose * p);
    return SeenWhole(layout, truth, in_sensor, options.edge_margin_px);
  };

  CalibrationSet set;
  set.board_file.board = options.board;
  set.board_file.reference_image = "reference.png";
  set.board_file.sensor_from_board = options.board.ReferenceSensorFromBoard();
  if (!seen_whole(set.board_file.sensor_from_board)) {
    throw Error("calibration set: the board in its reference placement is not seen whole in "
                "both halves (a smaller board?)");
  }
  set.sensor_from_board.push_back(set.board_file.sensor_from_board);

  std::mt19937_64 rng(options.seed);
  auto uniform = [&rng](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  const double range = options.position_range_mm;
  for (int view = 0; view < options.views; ++view) {
    bool placed = false;
    for (int draw = 0; draw < 1000 && !placed; ++draw) {
      const Eigen::Vector3d centre(uniform(-range, range), uniform(-range, range), uniform(-range, range));
      // Tilt uniform over the disc of directions within max_tilt_deg of the axis.
      const double phi = uniform(0.0, 2.0 * kPi);
      const double tilt = options.max_tilt_deg * std::sqrt(uniform(0.0, 1.0));
      const Eigen::Matrix3d rotation =
          (Eigen::AngleAxisd(DegToRad(tilt), Eigen::Vector3d(std::cos(phi), std::sin(phi), 0)) *
           Eigen::AngleAxisd(DegToRad(uniform(-options.max_spin_deg, options.max_spin_deg)),
                             Eigen::Vector3d::UnitZ()))
              .toRotationMatrix();
      const Eigen::AngleAxisd angle_axis(rotation);
      const Rigid3 pose =
          dot_board.SensorFromBoard(centre, RadToDeg(angle_axis.angle()) * angle_axis.axis());
      if (seen_whole(pose)) {
        set.sensor_from_board.push_back(pose);
        placed = true;
      }
    }
    if (!placed) {
      throw Error("calibration set: no board pose within the ranges is seen whole in both "
                  "halves in 1000 draws (a smaller board or range?)");
    }
  }

  ProgressBar progress("rendering calibration set", static_cast<long>(set.sensor_from_board.size()),
                       options.progress);
  for (size_t i = 0; i < set.sensor_from_board.size(); ++i) {
    const std::string name = i == 0 ? set.board_file.reference_image : fmt::format("view_{:02d}.png", i);
    sink({name, renderer.Render(dot_board, set.sensor_from_board[i], i)});
    progress.Update(static_cast<long>(i + 1));
  }
  return set;
}

CalibrationSet WriteCalibrationSet(const SensorConfig& truth,
                                   const CalibrationSetOptions& options,
                                   const std::string& dir) {
  options.Validate();  // before the folder is made
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw Error(fmt::format("cannot create directory '{}': {}", dir, ec.message()));
  const std::filesystem::path root(dir);
  const CalibrationSet set = RenderCalibrationSet(truth, options, [&](const CalibrationImage& image) {
    const std::string path = (root / image.name).string();
    WriteImageFile(path, image.image);
  });
  SaveCalibrationBoardFile(set.board_file, (root / "board.yaml").string());
  SaveSensorConfig(truth, (root / "truth.yaml").string());
  return set;
}

}  // namespace tac3d
