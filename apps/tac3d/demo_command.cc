#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "commands.h"
#include "tac3d/design/light_path_design.h"
#include "tac3d/design/light_path_drawing.h"
#include "tac3d/eval/marker_evaluation.h"
#include "tac3d/io/marker_csv.h"
#include "tac3d/twin/camera_renderer.h"
#include "tac3d/util/error.h"

namespace tac3d::cli {
namespace {

void WritePng(const cv::Mat& image, const std::string& path) {
  if (!cv::imwrite(path, image)) throw Error(fmt::format("cannot write '{}'", path));
}

double Milliseconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since).count();
}

// A prescribed smooth dent (not a contact simulation): markers under a round pad pushed
// in by depth_mm with a Gaussian profile, to show the renderer on a deformed layer.
std::vector<Eigen::Vector3d> Dent(std::vector<Eigen::Vector3d> markers, double depth_mm,
                                  double radius_mm) {
  for (auto& p : markers) {
    const double r2 = p.head<2>().squaredNorm();
    p.z() -= depth_mm * std::exp(-r2 / (radius_mm * radius_mm));
  }
  return markers;
}

void Run(const std::string& out) {
  MakeDirectory(out);
  nlohmann::json report;
  const auto t0 = std::chrono::steady_clock::now();

  std::printf("[1/4] designing the light path of the built-in sensor (paper Fig. 4)\n");
  const SensorConfig prototype;
  LightPathDesignOptions options;
  options.h_mm = prototype.light_path.h_mm;
  options.l_mm = prototype.light_path.l_mm;
  options.d_mm = prototype.light_path.d_mm;
  options.fov_deg = prototype.light_path.fov_deg;
  const LightPathDesign design = DesignLightPath(options, prototype);
  if (!design.config) throw Error("the built-in sensor has no valid mirror layout");
  const SensorConfig& config = *design.config;
  const LightPathRoot& root = design.roots[*design.chosen];
  SaveSensorConfig(config, out + "/sensor.yaml");
  const LightPathDrawing drawing(root, config);
  drawing.WriteSvg(out + "/design.svg");
  drawing.WritePng(out + "/design.png");
  report["design"] = {{"roots", design.summary.distinct_roots},
                      {"valid_roots", design.summary.valid_roots},
                      {"parallax_deg", root.parallax_deg},
                      {"max_residual", root.max_residual()}};
  for (const auto& v : config.virtual_cameras) {
    const Eigen::Vector3d p = v.sensor_from_vcam.translation();
    report["design"]["virtual_cameras"][v.name] = {p.x(), p.y(), p.z()};
  }
  std::printf("      %d roots, %d valid; parallax %.6f deg -> %s/sensor.yaml, design.svg, design.png\n",
              design.summary.distinct_roots, design.summary.valid_roots, root.parallax_deg,
              out.c_str());

  std::printf("[2/4] rendering the marker layer through mirrors, glass and silicone\n");
  auto t = std::chrono::steady_clock::now();
  const MarkerImageRenderer renderer(config);
  const double setup_ms = Milliseconds(t);
  const auto undeformed = config.MarkerPositions();
  t = std::chrono::steady_clock::now();
  WritePng(renderer.Render(undeformed, 0), out + "/markers_undeformed.png");
  const double frame_ms = Milliseconds(t);
  const auto dented = Dent(undeformed, 0.8, 4.0);
  WriteMarkerPositionsCsv(dented, out + "/markers_dent.csv");
  WritePng(renderer.Render(dented, 1), out + "/markers_dent.png");
  report["render"] = {{"setup_ms", setup_ms}, {"frame_ms", frame_ms}};
  std::printf("      markers_undeformed.png, markers_dent.png (%.0f ms set-up, %.1f ms a frame)\n",
              setup_ms, frame_ms);

  std::printf("[3/4] rendering a dot calibration board before the elastic body is mounted\n");
  const BoardImageRenderer board_renderer(config);
  DotBoard board;
  WritePng(board_renderer.Render(board, board.SensorFromBoard({0, 0, 0}, {8, -5, 0})),
           out + "/calibration_board.png");
  std::printf("      calibration_board.png\n");

  std::printf("[4/4] measuring the markers: the twin's perturbed sensor calibrated from 21 rendered\n"
              "      board views, then its marker layer under shear, dent and twist tracked,\n"
              "      triangulated and corrected for refraction\n");
  const nlohmann::json markers = EvaluateMarkers({});
  report["markers"] = markers;
  for (const char* model : {"polynomial", "exact", "none"}) {
    const nlohmann::json& m = markers.at("by_model").at(model);
    std::printf("      refraction %-10s position RMSE %.4f mm, displacement RMSE %.4f mm\n", model,
                m.at("position_rmse_mm").get<double>(), m.at("displacement_rmse_mm").get<double>());
  }

  report["total_seconds"] = Milliseconds(t0) / 1000.0;
  std::ofstream(out + "/report.json") << report.dump(2) << "\n";
  std::printf("done in %.1f s: %s/report.json\n", Milliseconds(t0) / 1000.0, out.c_str());
}

}  // namespace

void RegisterDemo(CLI::App& app) {
  auto out = std::make_shared<std::string>("out/demo");
  CLI::App* cmd = app.add_subcommand("demo", "Run the pipeline on the built-in digital twin");
  cmd->add_option("--out", *out, "output directory")->capture_default_str();
  cmd->callback([out] { Run(*out); });
}

}  // namespace tac3d::cli
