#include "tac3d/calib/virtual_stereo_calibration.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>

#include <Eigen/Cholesky>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "tac3d/imagefile/image_decode.h"
#include "tac3d/util/error.h"
#include "tac3d/util/progress.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d {
namespace {

constexpr int kHalves = 2;

cv::Mat ToCameraMatrix(const CameraIntrinsics& c) {
  return (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
}

cv::Mat ToDistortion(const CameraIntrinsics& c) {
  return (cv::Mat_<double>(1, 5) << c.distortion[0], c.distortion[1], c.distortion[2],
          c.distortion[3], c.distortion[4]);
}

CameraIntrinsics ToIntrinsics(const cv::Mat& k, const cv::Mat& d, cv::Size size) {
  CameraIntrinsics c;
  c.width = size.width;
  c.height = size.height;
  c.fx = k.at<double>(0, 0);
  c.fy = k.at<double>(1, 1);
  c.cx = k.at<double>(0, 2);
  c.cy = k.at<double>(1, 2);
  for (int i = 0; i < 5; ++i) c.distortion[i] = d.at<double>(i);
  return c;
}

// From a rotation vector or matrix and a translation, as OpenCV gives them.
Rigid3 ToRigid(const cv::Mat& rotation, const cv::Mat& tvec) {
  cv::Mat r = rotation;
  if (rotation.total() == 3) cv::Rodrigues(rotation, r);
  Rigid3 pose = Rigid3::Identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) pose.linear()(i, j) = r.at<double>(i, j);
    pose.translation()(i) = tvec.at<double>(i);
  }
  return pose;
}

// A view that passed the image checks: its refined dot centroids in each half.
struct GoodView {
  int image_index;
  std::array<std::vector<Eigen::Vector2d>, kHalves> centroids;
  std::array<std::vector<Eigen::Vector2d>, kHalves> bias;  // perspective bias, px
};

// Why an image cannot be used, or the empty string; fills its centroids.
std::string CheckImage(const CalibrationImage& input, const CalibrationBoard& board,
                       const SensorConfig& nominal, const VirtualStereoCalibrationOptions& options,
                       GoodView& view, CalibrationViewReport& report) {
  if (input.image.empty()) return input.refusal.empty() ? "unreadable or corrupt file" : input.refusal;
  const CameraIntrinsics& camera = nominal.camera.intrinsics;
  if (input.image.cols != camera.width || input.image.rows != camera.height) {
    return fmt::format("image is {}x{}, the camera's is {}x{}", input.image.cols,
                       input.image.rows, camera.width, camera.height);
  }
  cv::Mat gray;
  if (input.image.type() == CV_8UC1) {
    gray = input.image;
  } else if (input.image.type() == CV_8UC3) {
    cv::cvtColor(input.image, gray, cv::COLOR_BGR2GRAY);
  } else {
    return "not an 8-bit grey or colour image";
  }
  std::vector<std::string> missing;
  std::string clutter;  // why the grid was not looked for, if it was not
  for (const VirtualCameraConfig& vcam : nominal.virtual_cameras) {
    const int h = static_cast<int>(vcam.half);
    const cv::Rect roi(vcam.column_begin, 0, vcam.column_end - vcam.column_begin, gray.rows);
    const DotGridDetection d = DetectDotGrid(gray, roi, board);
    if (!d.found) {
      missing.emplace_back(ToString(vcam.half));
      if (d.blobs > kMaxDotGridBlobsPerDot * board.rows * board.cols) {
        clutter = fmt::format(" ({} blobs in the {} half, more than {} per board dot: noise or clutter)",
                              d.blobs, ToString(vcam.half), kMaxDotGridBlobsPerDot);
      }
      continue;
    }
    view.centroids[h] = d.centers;
    view.bias[h].assign(d.centers.size(), Eigen::Vector2d::Zero());
    report.edge_width_px[h] = d.edge_width_px;
  }
  if (missing.size() == 2) return "grid not found in the left and right halves" + clutter;
  if (missing.size() == 1) return fmt::format("grid not found in the {} half{}", missing[0], clutter);
  const double blur = std::max(report.edge_width_px[0], report.edge_width_px[1]);
  if (!(blur <= options.max_edge_width_px)) {
    return fmt::format("blurred: dot edge width {:.2f} px > {:.2f} px", blur,
                       options.max_edge_width_px);
  }
  return "";
}

std::vector<cv::Point2f> ImagePoints(const GoodView& v, int half) {
  std::vector<cv::Point2f> points;
  for (size_t i = 0; i < v.centroids[half].size(); ++i) {
    const Eigen::Vector2d p = v.centroids[half][i] - v.bias[half][i];
    points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  }
  return points;
}

struct MonoResult {
  cv::Mat camera_matrix, distortion, per_view_rms;
  std::vector<cv::Mat> rvecs, tvecs;
  double rms = 0;
};

MonoResult CalibrateHalf(const std::vector<GoodView>& views, int half,
                         const std::vector<cv::Point3f>& board_points,
                         const CameraIntrinsics& start, cv::Size size) {
  MonoResult m;
  std::vector<std::vector<cv::Point3f>> object(views.size(), board_points);
  std::vector<std::vector<cv::Point2f>> image;
  for (const GoodView& v : views) image.push_back(ImagePoints(v, half));
  m.camera_matrix = ToCameraMatrix(start);
  m.distortion = ToDistortion(start);
  cv::Mat std_intrinsics, std_extrinsics;
  m.rms = cv::calibrateCamera(object, image, size, m.camera_matrix, m.distortion, m.rvecs,
                              m.tvecs, std_intrinsics, std_extrinsics, m.per_view_rms,
                              cv::CALIB_USE_INTRINSIC_GUESS,
                              cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100,
                                               1e-12));
  return m;
}

// The board's pose in the left camera fitted to both halves of one view at once, with the
// rig fixed (Gauss-Newton on the reprojection error, numerical Jacobian).
Rigid3 FitBoardToRig(const std::array<CameraIntrinsics, 2>& intrinsics,
                     const Rigid3& right_from_left, const std::vector<Eigen::Vector3d>& dots,
                     const std::array<std::vector<cv::Point2f>, 2>& observed,
                     const Rigid3& initial, double& rms_px) {
  const int n = static_cast<int>(dots.size());
  auto residuals = [&](const Rigid3& left_from_board) {
    Eigen::VectorXd r(4 * n);
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d p_left = left_from_board * dots[i];
      const Eigen::Vector2d l = intrinsics[0].Project(p_left);
      const Eigen::Vector2d q = intrinsics[1].Project(right_from_left * p_left);
      r.segment<4>(4 * i) << l.x() - observed[0][i].x, l.y() - observed[0][i].y,
          q.x() - observed[1][i].x, q.y() - observed[1][i].y;
    }
    return r;
  };
  auto perturbed = [](const Rigid3& pose, const Eigen::Matrix<double, 6, 1>& delta) {
    Rigid3 out = pose;
    const double angle = delta.head<3>().norm();
    if (angle > 0) {
      out.linear() = Eigen::AngleAxisd(angle, delta.head<3>() / angle).toRotationMatrix() *
                     pose.linear();
    }
    out.translation() += delta.tail<3>();
    return out;
  };
  Rigid3 pose = initial;
  Eigen::VectorXd r = residuals(pose);
  for (int iteration = 0; iteration < 20; ++iteration) {
    Eigen::Matrix<double, Eigen::Dynamic, 6> jacobian(4 * n, 6);
    for (int k = 0; k < 6; ++k) {
      Eigen::Matrix<double, 6, 1> delta = Eigen::Matrix<double, 6, 1>::Zero();
      delta(k) = k < 3 ? 1e-7 : 1e-6;
      jacobian.col(k) = (residuals(perturbed(pose, delta)) - r) / delta(k);
    }
    const Eigen::Matrix<double, 6, 1> step =
        (jacobian.transpose() * jacobian).ldlt().solve(-jacobian.transpose() * r);
    pose = perturbed(pose, step);
    r = residuals(pose);
    if (step.norm() < 1e-12) break;
  }
  rms_px = std::sqrt(r.squaredNorm() / (2 * n));
  return pose;
}

// The views that passed the image checks, and which of them is the reference view.
struct GoodViews {
  std::vector<GoodView> views;
  int reference = -1;  // index into `views`
};

// Checks every image (one report each, with its refusal if any) and keeps the good views.
// @throws Error if the reference view is refused or missing.
GoodViews DetectGoodViews(const std::vector<CalibrationImage>& images,
                          const CalibrationBoardFile& board_file,
                          const SensorConfig& nominal,
                          const VirtualStereoCalibrationOptions& options,
                          std::vector<CalibrationViewReport>& reports) {
  reports.resize(images.size());
  GoodViews good;
  {
    ProgressBar progress("detecting grids", static_cast<long>(images.size()), options.progress);
    for (size_t i = 0; i < images.size(); ++i) {
      CalibrationViewReport& report = reports[i];
      report.name = images[i].name;
      GoodView view{static_cast<int>(i), {}, {}};
      report.refusal = CheckImage(images[i], board_file.board, nominal, options, view, report);
      if (report.refusal.empty()) {
        if (images[i].name == board_file.reference_image) {
          good.reference = static_cast<int>(good.views.size());
        }
        good.views.push_back(std::move(view));
      } else if (images[i].name == board_file.reference_image) {
        throw Error(fmt::format("the reference view '{}' is refused: {}", images[i].name,
                                report.refusal));
      }
      progress.Update(static_cast<long>(i + 1));
    }
  }
  if (good.reference < 0) {
    throw Error(fmt::format("the reference view '{}' is not among the {} images",
                            board_file.reference_image, images.size()));
  }
  return good;
}

// @throws Error listing every refusal if fewer than options.min_views views are left.
void RequireEnoughViews(const std::vector<GoodView>& good,
                        size_t num_images,
                        const VirtualStereoCalibrationOptions& options,
                        const std::vector<CalibrationViewReport>& reports) {
  if (static_cast<int>(good.size()) >= options.min_views) return;
  std::string refusals;
  for (const CalibrationViewReport& r : reports) {
    if (!r.refusal.empty()) refusals += fmt::format("\n  {}: {}", r.name, r.refusal);
  }
  throw Error(fmt::format("too few good views: {} of {} images, at least {} needed{}",
                          good.size(), num_images, options.min_views, refusals));
}

std::array<MonoResult, 2> CalibrateHalves(const std::vector<GoodView>& good,
                                          const std::vector<cv::Point3f>& board_points,
                                          const std::array<CameraIntrinsics, 2>& intrinsics,
                                          cv::Size size) {
  std::array<MonoResult, 2> mono;
  for (int h = 0; h < kHalves; ++h) mono[h] = CalibrateHalf(good, h, board_points, intrinsics[h], size);
  return mono;
}

// A grid found in the wrong order or with a wrong dot does not fit any camera: refuses the
// views whose mono reprojection RMS exceeds the bound. True if any was refused.
// @throws Error if the reference view is.
bool RefuseMisfitViews(const std::array<MonoResult, 2>& mono,
                       const VirtualStereoCalibrationOptions& options,
                       GoodViews& good,
                       std::vector<CalibrationViewReport>& reports) {
  std::vector<GoodView> kept;
  int new_reference = -1;
  for (size_t v = 0; v < good.views.size(); ++v) {
    const double worst = std::max(mono[0].per_view_rms.at<double>(static_cast<int>(v)),
                                  mono[1].per_view_rms.at<double>(static_cast<int>(v)));
    if (worst <= options.max_view_rms_px) {
      if (static_cast<int>(v) == good.reference) new_reference = static_cast<int>(kept.size());
      kept.push_back(good.views[v]);
      continue;
    }
    CalibrationViewReport& report = reports[good.views[v].image_index];
    report.refusal = fmt::format("reprojection RMS {:.3f} px > {:.3f} px (misdetected grid?)",
                                 worst, options.max_view_rms_px);
    if (static_cast<int>(v) == good.reference) {
      throw Error(fmt::format("the reference view '{}' is refused: {}", report.name,
                              report.refusal));
    }
  }
  if (kept.size() == good.views.size()) return false;
  good.views = std::move(kept);
  good.reference = new_reference;
  return true;
}

// Stereo calibration from the mono results (refined in place): sets the intrinsics, the rig
// and the per-view RMS (px, a column a half); returns the overall RMS, px.
double CalibrateRig(const std::vector<GoodView>& good,
                    const std::vector<cv::Point3f>& board_points,
                    cv::Size size,
                    std::array<MonoResult, 2>& mono,
                    std::array<CameraIntrinsics, 2>& intrinsics,
                    Rigid3& right_from_left,
                    cv::Mat& per_view_rms) {
  std::vector<std::vector<cv::Point3f>> object(good.size(), board_points);
  std::array<std::vector<std::vector<cv::Point2f>>, 2> image;
  for (const GoodView& v : good) {
    for (int h = 0; h < kHalves; ++h) image[h].push_back(ImagePoints(v, h));
  }
  cv::Mat r, t, e, f;
  const double rms = cv::stereoCalibrate(
      object, image[0], image[1], mono[0].camera_matrix, mono[0].distortion,
      mono[1].camera_matrix, mono[1].distortion, size, r, t, e, f, per_view_rms,
      cv::CALIB_USE_INTRINSIC_GUESS,
      cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12));
  for (int h = 0; h < kHalves; ++h) {
    intrinsics[h] = ToIntrinsics(mono[h].camera_matrix, mono[h].distortion, size);
  }
  right_from_left = ToRigid(r, t);
  return rms;
}

// The next round sees the centroids moved by the bias the current rig predicts.
void UpdateCentroidBias(const std::array<MonoResult, 2>& mono,
                        const std::array<CameraIntrinsics, 2>& intrinsics,
                        const std::vector<Eigen::Vector3d>& dots,
                        const CalibrationBoard& board,
                        std::vector<GoodView>& good) {
  for (size_t v = 0; v < good.size(); ++v) {
    for (int h = 0; h < kHalves; ++h) {
      const Rigid3 cam_from_board = ToRigid(mono[h].rvecs[v], mono[h].tvecs[v]);
      for (size_t i = 0; i < dots.size(); ++i) {
        good[v].bias[h][i] =
            DotCentroidBias(intrinsics[h], cam_from_board, dots[i], 0.5 * board.dot_diameter_mm);
      }
    }
  }
}

// Places the rig in the sensor frame by the reference view: sets out.sensor_from_vcam and
// out.summary.reference_rms_px.
void PlaceRigInSensor(const GoodView& ref,
                      const std::vector<cv::Point3f>& board_points,
                      const std::vector<Eigen::Vector3d>& dots,
                      const std::array<CameraIntrinsics, 2>& intrinsics,
                      const CalibrationBoardFile& board_file,
                      VirtualStereoCalibration& out) {
  const std::array<std::vector<cv::Point2f>, 2> observed = {ImagePoints(ref, 0), ImagePoints(ref, 1)};
  cv::Mat rvec, tvec;
  cv::solvePnP(board_points, observed[0], ToCameraMatrix(intrinsics[0]), ToDistortion(intrinsics[0]),
               rvec, tvec);
  const Rigid3 left_from_board =
      FitBoardToRig(intrinsics, out.right_from_left, dots, observed, ToRigid(rvec, tvec),
                    out.summary.reference_rms_px);
  const Rigid3 sensor_from_left = board_file.sensor_from_board * left_from_board.inverse();
  out.sensor_from_vcam[0] = sensor_from_left;
  out.sensor_from_vcam[1] = sensor_from_left * out.right_from_left.inverse();
}

}  // namespace

void VirtualStereoCalibrationOptions::Validate() const {
  const OptionCheck require("calibration options");
  require(min_views >= 3, "min_views", ">= 3", min_views);
  require(max_edge_width_px > 0, "max_edge_width_px", "> 0", max_edge_width_px);
  require(max_view_rms_px > 0, "max_view_rms_px", "> 0", max_view_rms_px);
  require(bias_correction_rounds >= 0 && bias_correction_rounds <= 10, "bias_correction_rounds",
          "in [0, 10]", bias_correction_rounds);
}

SensorConfig VirtualStereoCalibration::ApplyTo(const SensorConfig& nominal) const {
  if (nominal.virtual_cameras.size() != 2) {
    throw Error("sensor config has no virtual cameras to calibrate: run `tac3d design` first");
  }
  SensorConfig out = nominal;
  for (VirtualCameraConfig& v : out.virtual_cameras) {
    const int h = static_cast<int>(v.half);
    v.sensor_from_vcam = sensor_from_vcam[h];
    v.intrinsics = intrinsics[h];
  }
  return out;
}

VirtualStereoCalibration CalibrateVirtualStereo(const std::vector<CalibrationImage>& images,
                                                const CalibrationBoardFile& board_file,
                                                const SensorConfig& nominal,
                                                const VirtualStereoCalibrationOptions& options) {
  const auto start_time = std::chrono::steady_clock::now();
  options.Validate();
  const CalibrationBoard& board = board_file.board;
  board.Validate();
  if (nominal.virtual_cameras.size() != 2) {
    throw Error("sensor config has no virtual cameras (column ranges, starting intrinsics): "
                "run `tac3d design` first");
  }
  const cv::Size size(nominal.camera.intrinsics.width, nominal.camera.intrinsics.height);

  VirtualStereoCalibration out;
  GoodViews good = DetectGoodViews(images, board_file, nominal, options, out.views);
  RequireEnoughViews(good.views, images.size(), options, out.views);

  const std::vector<Eigen::Vector3d> dots = board.DotCenters();
  std::vector<cv::Point3f> board_points;
  for (const Eigen::Vector3d& p : dots) {
    board_points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0f);
  }
  std::array<CameraIntrinsics, 2> intrinsics;
  for (const VirtualCameraConfig& v : nominal.virtual_cameras) {
    intrinsics[static_cast<int>(v.half)] = v.intrinsics;
  }

  cv::Mat per_view_rms;
  for (int round = 0; round <= options.bias_correction_rounds; ++round) {
    std::array<MonoResult, 2> mono = CalibrateHalves(good.views, board_points, intrinsics, size);
    if (round == 0 && RefuseMisfitViews(mono, options, good, out.views)) {
      RequireEnoughViews(good.views, images.size(), options, out.views);
      mono = CalibrateHalves(good.views, board_points, intrinsics, size);
    }
    for (int h = 0; h < kHalves; ++h) out.summary.mono_rms_px[h] = mono[h].rms;
    out.summary.rms_px = CalibrateRig(
        good.views, board_points, size, mono, intrinsics, out.right_from_left, per_view_rms);
    if (round == options.bias_correction_rounds) break;
    UpdateCentroidBias(mono, intrinsics, dots, board, good.views);
  }

  for (size_t v = 0; v < good.views.size(); ++v) {
    CalibrationViewReport& report = out.views[good.views[v].image_index];
    report.used = true;
    for (int h = 0; h < kHalves; ++h) report.rms_px[h] = per_view_rms.at<double>(static_cast<int>(v), h);
  }
  PlaceRigInSensor(good.views[good.reference], board_points, dots, intrinsics, board_file, out);
  out.intrinsics = intrinsics;

  out.summary.images = static_cast<int>(images.size());
  out.summary.views_used = static_cast<int>(good.views.size());
  out.summary.views_refused = out.summary.images - out.summary.views_used;
  out.summary.seconds = SecondsSince(start_time);
  return out;
}

std::vector<CalibrationImage> LoadCalibrationImages(const std::string& dir, int max_width, int max_height) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw Error(fmt::format("'{}' is not a directory", dir));
  std::vector<fs::path> paths;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir, ec)) {
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (entry.is_regular_file() && (ext == ".png" || ext == ".jpg" || ext == ".jpeg" ||
                                    ext == ".bmp" || ext == ".tif" || ext == ".tiff")) {
      paths.push_back(entry.path());
    }
  }
  if (ec) throw Error(fmt::format("cannot list '{}': {}", dir, ec.message()));
  std::sort(paths.begin(), paths.end());
  std::vector<CalibrationImage> images;
  for (const fs::path& p : paths) {
    DecodedImage decoded;
    try {
      decoded = DecodeGrayImage(ReadImageFileBytes(p.string()), max_width, max_height);
    } catch (const Error& e) {
      decoded.refusal = e.what();
    }
    images.push_back({p.filename().string(), std::move(decoded.image), std::move(decoded.refusal)});
  }
  return images;
}

nlohmann::json ToJson(const VirtualStereoCalibration::Summary& s) {
  return {{"images", s.images},
          {"views_used", s.views_used},
          {"views_refused", s.views_refused},
          {"reprojection_rms_px", s.rms_px},
          {"mono_rms_px", {s.mono_rms_px[0], s.mono_rms_px[1]}},
          {"reference_rms_px", s.reference_rms_px}};
}

}  // namespace tac3d
