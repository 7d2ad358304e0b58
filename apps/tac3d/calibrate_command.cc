#include <cstdio>
#include <filesystem>
#include <memory>

#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "tac3d/calib/virtual_stereo_calibration.h"
#include "tac3d/twin/calibration_set.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d::cli {
namespace {

struct BoardArgs {
  CalibrationBoard board;
  bool asymmetric = false;
};

void AddBoardOptions(CLI::App* cmd, BoardArgs& a) {
  cmd->add_option("--rows", a.board.rows, "dot rows (asymmetric default: 9)")->capture_default_str();
  cmd->add_option("--cols", a.board.cols, "dot columns (asymmetric default: 4)")->capture_default_str();
  cmd->add_option("--spacing", a.board.spacing_mm, "dot spacing, mm")->capture_default_str();
  cmd->add_option("--dot", a.board.dot_diameter_mm, "dot diameter, mm")->capture_default_str();
  cmd->add_flag("--asymmetric", a.asymmetric, "OpenCV's asymmetric circle grid");
}

CalibrationBoard MakeBoard(const BoardArgs& a, const CLI::App& cmd) {
  CalibrationBoard board = a.board;
  if (a.asymmetric) {
    board.layout = CalibrationBoard::Layout::kAsymmetric;
    if (cmd.count("--rows") == 0) board.rows = 9;
    if (cmd.count("--cols") == 0) board.cols = 4;
  }
  return board;
}

struct RenderSetArgs {
  std::string config;
  std::string out;
  CalibrationSetOptions set;
  BoardArgs board;
};

void RunRenderSet(RenderSetArgs a, const CLI::App& cmd) {
  a.set.board = MakeBoard(a.board, cmd);
  a.set.render.seed = a.set.seed;
  a.set.progress = true;
  SensorPerturbationOptions perturbation;
  perturbation.seed = a.set.seed;
  const SensorConfig truth = PerturbSensor(LoadSensorOrDefault(a.config), perturbation);
  const CalibrationSet set = WriteCalibrationSet(truth, a.set, a.out);
  std::printf("wrote %zu images (reference: %s), board.yaml and truth.yaml to %s\n",
              set.sensor_from_board.size(), set.board_file.reference_image.c_str(), a.out.c_str());
}

struct CalibrateArgs {
  std::string images;
  std::string board;
  std::string config;
  std::string out;
  bool json = false;
  VirtualStereoCalibrationOptions options;
};

nlohmann::json PoseJson(const Rigid3& pose) {
  const Eigen::AngleAxisd aa(pose.linear());
  const Eigen::Vector3d r = RadToDeg(aa.angle()) * aa.axis();
  const Eigen::Vector3d t = pose.translation();
  return {{"position_mm", {t.x(), t.y(), t.z()}}, {"rotation_vector_deg", {r.x(), r.y(), r.z()}}};
}

nlohmann::json IntrinsicsJson(const CameraIntrinsics& c) {
  return {{"fx", c.fx}, {"fy", c.fy}, {"cx", c.cx}, {"cy", c.cy},
          {"distortion", {c.distortion[0], c.distortion[1], c.distortion[2], c.distortion[3], c.distortion[4]}}};
}

void RunCalibrate(CalibrateArgs a) {
  if (a.images.empty()) throw Error("calibrate: --images DIR is required (or use `calibrate render-set`)");
  if (a.out.empty()) throw Error("calibrate: --out FILE is required");
  CheckOutputFile(a.out, "--out", {".yaml", ".yml"}, {a.images, a.board, a.config});
  const std::string board_path =
      a.board.empty() ? (std::filesystem::path(a.images) / "board.yaml").string() : a.board;
  const CalibrationBoardFile board = LoadCalibrationBoardFile(board_path);
  const SensorConfig nominal = LoadSensorOrDefault(a.config);
  a.options.progress = !a.json;
  const std::vector<CalibrationImage> images = LoadCalibrationImages(a.images, nominal.camera.intrinsics.width,
                                                                      nominal.camera.intrinsics.height);
  const VirtualStereoCalibration result = CalibrateVirtualStereo(images, board, nominal, a.options);
  SaveSensorConfig(result.ApplyTo(nominal), a.out);

  const VirtualStereoCalibration::Summary& s = result.summary;
  if (a.json) {
    nlohmann::json views = nlohmann::json::array();
    for (const CalibrationViewReport& v : result.views) {
      nlohmann::json j = {{"name", v.name}, {"used", v.used}};
      if (v.used) {
        j["rms_px"] = {v.rms_px[0], v.rms_px[1]};
        j["edge_width_px"] = {v.edge_width_px[0], v.edge_width_px[1]};
      } else {
        j["refusal"] = v.refusal;
      }
      views.push_back(j);
    }
    nlohmann::json cameras = nlohmann::json::object();
    for (ImageHalf half : kImageHalves) {
      const int h = static_cast<int>(half);
      cameras[std::string(ToString(half))] = {{"sensor_from_vcam", PoseJson(result.sensor_from_vcam[h])},
                                              {"intrinsics", IntrinsicsJson(result.intrinsics[h])}};
    }
    nlohmann::json j = ToJson(s);
    j.update({{"views", views},
              {"cameras", cameras},
              {"right_from_left", PoseJson(result.right_from_left)},
              {"seconds", s.seconds},
              {"out", a.out}});
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  for (const CalibrationViewReport& v : result.views) {
    if (v.used) {
      std::printf("%-24s RMS left %.4f px, right %.4f px (dot edge %.2f / %.2f px)\n", v.name.c_str(),
                  v.rms_px[0], v.rms_px[1], v.edge_width_px[0], v.edge_width_px[1]);
    } else {
      std::printf("%-24s refused: %s\n", v.name.c_str(), v.refusal.c_str());
    }
  }
  std::printf("used %d of %d images; reprojection RMS %.4f px (each half alone: %.4f, %.4f px; "
              "reference view %.4f px); %.2f s\n",
              s.views_used, s.images, s.rms_px, s.mono_rms_px[0], s.mono_rms_px[1],
              s.reference_rms_px, s.seconds);
  for (ImageHalf half : kImageHalves) {
    const int h = static_cast<int>(half);
    const Eigen::Vector3d t = result.sensor_from_vcam[h].translation();
    const CameraIntrinsics& c = result.intrinsics[h];
    std::printf("vcam_%s: centre (%.3f, %.3f, %.3f) mm, fx %.2f fy %.2f cx %.2f cy %.2f px, "
                "k1 %.4f k2 %.4f\n",
                std::string(ToString(half)).c_str(), t.x(), t.y(), t.z(), c.fx, c.fy, c.cx, c.cy,
                c.distortion[0], c.distortion[1]);
  }
  std::printf("wrote %s\n", a.out.c_str());
}

}  // namespace

void RegisterCalibrate(CLI::App& app) {
  auto args = std::make_shared<CalibrateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate", "Calibrate the two virtual cameras from a folder of dot-board images");
  cmd->require_subcommand(0, 1);
  cmd->add_option("--images", args->images, "folder of board images (PNG, JPEG, BMP, TIFF)");
  cmd->add_option("--board", args->board, "board description (default: IMAGES/board.yaml)");
  cmd->add_option("--config", args->config,
                  "nominal sensor YAML: image size, column ranges, starting intrinsics "
                  "(default: the built-in prototype)");
  cmd->add_option("--out", args->out, "calibrated sensor YAML to write");
  cmd->add_flag("--json", args->json, "print JSON");
  cmd->add_option("--min-views", args->options.min_views, "fewest good views")->capture_default_str();
  cmd->add_option("--max-edge-width", args->options.max_edge_width_px,
                  "refuse views whose dot edges are wider (blurred), px")
      ->capture_default_str();
  cmd->add_option("--max-view-rms", args->options.max_view_rms_px,
                  "refuse views whose reprojection RMS is larger, px")
      ->capture_default_str();
  cmd->add_option("--bias-rounds", args->options.bias_correction_rounds,
                  "rounds of the dots' perspective-bias correction (0: none)")
      ->capture_default_str();

  auto set = std::make_shared<RenderSetArgs>();
  CLI::App* render = cmd->add_subcommand(
      "render-set", "Render a calibration set with the twin (a perturbed copy of the sensor)");
  render->add_option("--out", set->out, "folder to write")->required();
  render->add_option("--config", set->config, "nominal sensor YAML to perturb (default: built-in)");
  render->add_option("--count", set->set.views, "random board poses besides the reference view")
      ->check(CLI::Range(1, kMaxCalibrationViews))
      ->capture_default_str();
  render->add_option("--seed", set->set.seed, "seed of the perturbation, the poses and the noise")
      ->capture_default_str();
  render->add_option("--range", set->set.position_range_mm, "board centre within +- this, mm")
      ->capture_default_str();
  render->add_option("--tilt", set->set.max_tilt_deg, "largest board tilt, deg")->capture_default_str();
  AddBoardOptions(render, set->board);
  render->callback([set, render] { RunRenderSet(*set, *render); });

  cmd->callback([args, cmd] {
    if (cmd->got_subcommand("render-set")) return;
    RunCalibrate(*args);
  });
}

}  // namespace tac3d::cli
