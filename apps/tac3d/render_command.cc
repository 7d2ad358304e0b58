#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>

#include <fmt/ranges.h>
#include <opencv2/imgcodecs.hpp>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "tac3d/io/marker_csv.h"
#include "tac3d/twin/camera_renderer.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d::cli {
namespace {

struct RenderArgs {
  std::string config;
  std::string out = "frame.png";
  RenderOptions options;
  bool no_noise = false;
  bool real_image_nuisances = false;  // markers only
  std::uint64_t frame = 0;
  // markers
  std::string positions;
  // board
  DotBoard board;
  bool asymmetric = false;
  std::vector<double> pose = {0, 0, 0, 0, 0, 0};
};

// A whole number >= 0 (CLI11's NonNegativeNumber names its bound, the largest double, in 310
// digits; and "-1" converts to the largest std::uint64_t).
const CLI::Validator kFrameIndex(
    [](std::string& input) {
      std::int64_t value = 0;
      return CLI::detail::lexical_cast(input, value) && value >= 0
                 ? std::string()
                 : fmt::format("'{}' must be a whole number >= 0", input);
    },
    "INDEX >= 0");

void AddCommon(CLI::App* cmd, RenderArgs& a) {
  cmd->add_option("--config", a.config, "sensor YAML (default: the built-in prototype)");
  cmd->add_option("--out", a.out, "PNG to write")->capture_default_str();
  cmd->add_option("--seed", a.options.seed, "noise seed")->capture_default_str();
  cmd->add_option("--frame", a.frame, "frame index (varies the noise)")
      ->capture_default_str()
      ->check(kFrameIndex);
  cmd->add_flag("--no-noise", a.no_noise, "no shot or read noise");
  cmd->add_option("--blur", a.options.blur_sigma_px, "lens blur sigma, px")->capture_default_str();
  cmd->add_option("--vignetting", a.options.vignetting, "light loss at the corners, fraction")
      ->capture_default_str();
  cmd->add_option("--tilt", a.options.illumination_tilt, "illumination change left to right, fraction")
      ->capture_default_str();
  cmd->add_option("--read-noise", a.options.read_noise_dn, "read noise, DN")->capture_default_str();
  cmd->add_option("--shot-gain", a.options.shot_noise_gain, "shot noise variance per DN")
      ->capture_default_str();
}

void Write(const cv::Mat& image, const std::string& path) {
  std::vector<std::uint8_t> png;
  if (!cv::imencode(".png", image, png)) throw Error(fmt::format("cannot encode '{}'", path));
  WriteTextFileAtomically(path, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
  std::printf("wrote %s (%dx%d)\n", path.c_str(), image.cols, image.rows);
}

void RunMarkers(RenderArgs a) {
  a.options.noise = !a.no_noise;
  CheckOutputFile(a.out, "--out", {".png"});
  const SensorConfig config = LoadSensorOrDefault(a.config);
  const auto markers = a.positions.empty() ? config.MarkerPositions()
                                           : ReadMarkerPositionsCsv(a.positions);
  const MarkerImageRenderer renderer(config, a.options);
  Write(renderer.RenderCamera(markers, a.frame), a.out);
}

void RunBoard(RenderArgs a) {
  a.options.noise = !a.no_noise;
  if (a.asymmetric) a.board.grid.layout = CalibrationBoard::Layout::kAsymmetric;
  CheckOutputFile(a.out, "--out", {".png"});
  for (double v : a.pose) {
    if (!std::isfinite(v)) throw Error(fmt::format("--pose {}: every number must be finite", fmt::join(a.pose, ",")));
  }
  const SensorConfig config = LoadSensorOrDefault(a.config);
  const BoardImageRenderer renderer(config, a.options);
  const Rigid3 pose = a.board.SensorFromBoard({a.pose[0], a.pose[1], a.pose[2]},
                                              {a.pose[3], a.pose[4], a.pose[5]});
  Write(renderer.Render(a.board, pose, a.frame), a.out);
}

}  // namespace

void RegisterRender(CLI::App& app) {
  CLI::App* render = app.add_subcommand("render", "Render the twin's camera image (PNG)");
  render->require_subcommand(1);

  auto markers = std::make_shared<RenderArgs>();
  CLI::App* m = render->add_subcommand(
      "markers", "The marker layer through mirrors, glass and silicone (undeformed by default)");
  AddCommon(m, *markers);
  m->add_option("--positions", markers->positions,
                "CSV of marker positions (x_mm,y_mm,z_mm, row-major), sensor frame");
  m->add_option("--jpeg-quality", markers->options.jpeg_quality,
                "JPEG-compress the frame at this quality, 1-100 (0: none)")
      ->capture_default_str();
  m->add_flag("--real-image-nuisances", markers->real_image_nuisances,
              "coloured uneven LEDs, blur 1.0 px and JPEG quality 85, as measured on a real "
              "camera's video (docs/render.md); the PNG is then the camera's colour frame");
  m->callback([markers, m] {
    if (markers->real_image_nuisances) {
      // The measured levels, except where --blur or --jpeg-quality asks for another.
      RenderOptions real = markers->options.WithRealImageNuisances();
      if (m->count("--blur") > 0) real.blur_sigma_px = markers->options.blur_sigma_px;
      if (m->count("--jpeg-quality") > 0) real.jpeg_quality = markers->options.jpeg_quality;
      markers->options = real;
    }
    RunMarkers(*markers);
  });

  auto board = std::make_shared<RenderArgs>();
  CLI::App* b = render->add_subcommand(
      "board", "A dot calibration board through the mirrors, before the elastic body is mounted");
  AddCommon(b, *board);
  b->add_option("--rows", board->board.grid.rows, "dot rows")->capture_default_str();
  b->add_option("--cols", board->board.grid.cols, "dot columns")->capture_default_str();
  b->add_option("--spacing", board->board.grid.spacing_mm, "dot spacing, mm")->capture_default_str();
  b->add_option("--dot", board->board.grid.dot_diameter_mm, "dot diameter, mm")->capture_default_str();
  b->add_flag("--asymmetric", board->asymmetric, "OpenCV's asymmetric circle grid");
  b->add_option("--pose", board->pose,
                "board centre x,y,z (mm) and rotation vector rx,ry,rz (deg), sensor frame")
      ->expected(6)
      ->delimiter(',');
  b->callback([board] { RunBoard(*board); });
}

}  // namespace tac3d::cli
