#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "tac3d/calib/calibration_board.h"
#include "tac3d/sensor/sensor_config.h"
#include "tac3d/twin/ray_field.h"
#include "tac3d/twin/session_conditions.h"

namespace tac3d {

/// The colour of the LEDs' light across the image, one channel at a time (B, G, R): channel
/// c's light is the grey render's times gain[c] * exp(x_slope[c] * (x - cx) / (width - 1) +
/// y_slope[c] * (y - cy) / (height - 1) - falloff[c] * r^2), r^2 the squared distance from the
/// principal point over the corner's. Log-linear, so every channel stays positive whatever
/// the slopes. The default, white (gain 1, no slope, no falloff), is a grey camera.
struct LedColour {
  Eigen::Vector3d gain = Eigen::Vector3d::Ones();       ///< at the principal point, in (0, 4]
  Eigen::Vector3d x_slope = Eigen::Vector3d::Zero();    ///< log light change, left to right, [-5, 5]
  Eigen::Vector3d y_slope = Eigen::Vector3d::Zero();    ///< log light change, top to bottom, [-5, 5]
  Eigen::Vector3d falloff = Eigen::Vector3d::Zero();    ///< log light loss at the corners, [0, 5]

  bool IsWhite() const;
  /// A GelSight Mini's LEDs, fitted to the film of its video (docs/render.md, "Real-image
  /// nuisances"): blue above, red below, magenta at the centre, the corners dark in red.
  static LedColour GelSightMini();
};

/// How the twin's camera forms an image: scene levels (as fractions of the 8-bit full
/// scale), lens blur, vignetting, the LEDs' colour, sensor noise and compression. Every
/// random draw comes from `seed` and the frame index, so a render is reproducible.
struct RenderOptions {
  double film_level = 0.80;           ///< the bright reflective film behind the markers
  double dot_reflectance = 0.2;       ///< a marker relative to the film
  double board_level = 0.85;          ///< white of the calibration board
  double board_dot_reflectance = 0.1; ///< its dots relative to its white
  double outside_level = 0.04;        ///< where no fingertip or board is seen
  double blur_sigma_px = 0.6;         ///< Gaussian lens blur (0: none)
  double vignetting = 0.25;           ///< fractional light loss at the image corners
  double illumination_tilt = 0.0;     ///< fractional light change from left to right edge
  bool noise = true;
  double shot_noise_gain = 0.04;      ///< shot-noise variance per DN of signal (DN), in [0, 255]
  double read_noise_dn = 0.8;         ///< read noise, DN (1 sigma), in [0, 255]
  /// Coloured light (not white): the camera delivers BGR frames, each channel with its own
  /// noise, converted to grey as a frame source converts colour (ConvertToGrey). This and
  /// jpeg_quality are the marker renderer's; the board renderer (room light) ignores them.
  LedColour led_colour;
  /// 0: none; 1-100: every frame JPEG-compressed at this quality (libjpeg, colour at 4:2:0)
  /// before the grey conversion, as a camera streaming MJPEG or MPEG-4 delivers it.
  int jpeg_quality = 0;
  std::uint64_t seed = 1;

  /// These options with the nuisances a real camera's images show and the nominal twin's
  /// lack, at the levels measured on the GelSight Mini video (docs/render.md, "Real-image
  /// nuisances"): LedColour::GelSightMini(), blur_sigma_px 1.0, jpeg_quality 85.
  RenderOptions WithRealImageNuisances() const;
  /// @throws Error naming the field and the bound.
  void Validate() const;
};

/// A dot calibration board (OpenCV circle grid). Symmetric: dot (r, c) at
/// (c * spacing, r * spacing); asymmetric (OpenCV's layout): at
/// ((2c + r % 2) * spacing, r * spacing). The board frame has its origin at dot (0, 0),
/// the dots in its z = 0 plane and z pointing away from the camera.
struct DotBoard {
  CalibrationBoard grid;   ///< the dots (calibration_board.h)
  double margin_mm = 3.0;  ///< white border around the outer dots

  /// @throws Error naming the field and the bound.
  void Validate() const;
  /// The board's white area, in its frame: [min.x, max.x] x [min.y, max.y].
  Eigen::Vector2d Min() const;
  Eigen::Vector2d Max() const;
  /// The pose that puts the board's centre at `centre_in_sensor` (mm), turned about that
  /// centre by a rotation vector in degrees.
  Rigid3 SensorFromBoard(const Eigen::Vector3d& centre_in_sensor,
                         const Eigen::Vector3d& rotation_vector_deg = Eigen::Vector3d::Zero()) const;
};

/// The twin's camera looking at the marker layer through the mirrors, the glass and the
/// silicone (DESIGN.md: the twin, not the inverse model). Construction traces every
/// pixel corner once; Render is then cheap enough for video rates.
class MarkerImageRenderer {
 public:
  /// Renders through the sensor's camera model (MakeMarkerOptics): the mirrors, glass and
  /// silicone, or an imported vendor model's views (1920 x 1080 for HDL1-0001).
  /// @throws Error if the config has neither mirrors nor a vendor camera model, or the options
  ///   are invalid.
  MarkerImageRenderer(const SensorConfig& config, const RenderOptions& options = {});
  ~MarkerImageRenderer();

  /// The full camera image (CV_8UC1) of markers at the given sensor-frame positions
  /// (row-major over the grid, as SensorConfig::MarkerPositions), under a session's
  /// `conditions` (SessionConditions::At): the markers moved by its creep, their darkening
  /// scaled by its dot_contrast, the light by its illumination gain and gradient, its stray
  /// light added and the whole scaled by its exposure. It is what the pipeline receives: the
  /// camera's frame (RenderCamera) converted to grey as a frame source converts it.
  /// @throws Error if the number of positions is not rows * cols.
  cv::Mat Render(const std::vector<Eigen::Vector3d>& markers_in_sensor,
                 std::uint64_t frame_index = 0, const FrameConditions& conditions = {}) const;
  /// The camera's own frame: CV_8UC3 (BGR) under coloured LEDs, else CV_8UC1; JPEG-compressed
  /// when the options ask.
  cv::Mat RenderCamera(const std::vector<Eigen::Vector3d>& markers_in_sensor,
                       std::uint64_t frame_index = 0, const FrameConditions& conditions = {}) const;
  /// The same before blur, noise and quantisation: linear light (CV_32FC1; in [0, 1] under
  /// nominal conditions).
  cv::Mat RenderIrradiance(const std::vector<Eigen::Vector3d>& markers_in_sensor,
                           const FrameConditions& conditions = {}) const;

  const RayField& rays() const { return rays_; }

 private:
  SensorConfig config_;
  RenderOptions options_;
  RayField rays_;
  cv::Mat base_;        // film and vignetting, CV_32FC1
  cv::Mat led_colour_;  // each channel's light relative to the grey, CV_32FC3; empty if white
};

/// The twin's camera looking at a dot board through the mirrors only (the elastic body
/// and glass not yet mounted, as the paper calibrates).
class BoardImageRenderer {
 public:
  BoardImageRenderer(const SensorConfig& config, const RenderOptions& options = {});

  cv::Mat Render(const DotBoard& board, const Rigid3& sensor_from_board,
                 std::uint64_t frame_index = 0) const;
  cv::Mat RenderIrradiance(const DotBoard& board, const Rigid3& sensor_from_board) const;

  const RayField& rays() const { return rays_; }

 private:
  SensorConfig config_;
  RenderOptions options_;
  RayField rays_;
  cv::Mat vignette_;  // CV_32FC1
};

}  // namespace tac3d
