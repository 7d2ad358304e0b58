#include <cstdio>
#include <memory>

#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "tac3d/design/light_path_design.h"
#include "tac3d/design/light_path_drawing.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d::cli {
namespace {

struct DesignArgs {
  LightPathDesignOptions options;
  std::string base_config;
  std::string out = "sensor.yaml";
  std::string svg;
  std::string png;
  bool json = false;
  bool verbose = false;
};

nlohmann::json XZ(const Eigen::Vector2d& p) { return {p.x(), p.y()}; }
nlohmann::json Xyz(const Eigen::Vector3d& p) { return {p.x(), p.y(), p.z()}; }

nlohmann::json RootJson(const LightPathRoot& r) {
  return {{"valid", r.valid()},
          {"rejections", r.rejections},
          {"residuals", {r.residuals(0), r.residuals(1), r.residuals(2), r.residuals(3)}},
          {"max_residual", r.max_residual()},
          {"parallax_deg", r.parallax_deg},
          {"points_xz_mm",
           {{"O", XZ(r.camera)}, {"M", XZ(r.center)}, {"A0", XZ(r.a0)}, {"B0", XZ(r.b0)},
            {"A1", XZ(r.a1)}, {"B1", XZ(r.b1)}, {"A2", XZ(r.a2)}, {"B2", XZ(r.b2)},
            {"O_virtual", XZ(r.virtual_camera)}}}};
}

void Run(const DesignArgs& args) {
  CheckOutputFile(args.out, "--out", {".yaml", ".yml"}, {args.base_config});
  if (!args.svg.empty()) CheckOutputFile(args.svg, "--svg", {".svg"}, {args.base_config});
  if (!args.png.empty()) CheckOutputFile(args.png, "--png", {".png"}, {args.base_config});
  const SensorConfig base = args.base_config.empty() ? SensorConfig{} : LoadSensorConfig(args.base_config);
  const LightPathDesign design = DesignLightPath(args.options, base);
  const auto& o = args.options;

  nlohmann::json report;
  report["parameters"] = {{"h_mm", o.h_mm}, {"l_mm", o.l_mm}, {"d_mm", o.d_mm}, {"fov_deg", o.fov_deg}};
  report["summary"] = {{"starts", design.summary.starts},
                       {"converged", design.summary.converged},
                       {"distinct_roots", design.summary.distinct_roots},
                       {"valid_roots", design.summary.valid_roots},
                       {"seconds", design.summary.seconds}};
  report["roots"] = nlohmann::json::array();
  for (const auto& r : design.roots) report["roots"].push_back(RootJson(r));
  report["valid"] = design.chosen.has_value();

  if (design.chosen) {
    const LightPathRoot& root = design.roots[*design.chosen];
    const SensorConfig& config = *design.config;
    report["parallax_deg"] = root.parallax_deg;
    report["max_residual"] = root.max_residual();
    report["virtual_cameras"] = nlohmann::json::array();
    for (const auto& v : config.virtual_cameras) {
      report["virtual_cameras"].push_back(
          {{"name", v.name},
           {"position_mm", Xyz(v.sensor_from_vcam.translation())},
           {"optical_axis", Xyz(v.sensor_from_vcam.linear().col(2))},
           {"columns", {v.column_begin, v.column_end}},
           {"horizontal_fov_deg", o.fov_deg / 2}});
    }
    report["mirrors"] = nlohmann::json::array();
    for (const auto& m : config.mirrors) {
      const Rectangle3& s = m.surface;
      report["mirrors"].push_back({{"name", m.name},
                                   {"center_mm", Xyz(s.center)},
                                   {"normal", Xyz(s.normal())},
                                   {"length_mm", 2 * s.half_u},
                                   {"width_mm", 2 * s.half_v},
                                   {"end_a_mm", Xyz(s.center - s.half_u * s.u_axis)},
                                   {"end_b_mm", Xyz(s.center + s.half_u * s.u_axis)}});
    }
    SaveSensorConfig(config, args.out);
    report["config"] = args.out;
    const LightPathDrawing drawing(root, config);
    if (!args.svg.empty()) drawing.WriteSvg(args.svg);
    if (!args.png.empty()) drawing.WritePng(args.png);
  }

  if (args.json) {
    std::printf("%s\n", report.dump(2).c_str());
  } else {
    std::printf("light path for h = %g mm, l = %g mm, d = %g mm, FOV = %g deg\n", o.h_mm, o.l_mm,
                o.d_mm, o.fov_deg);
    std::printf("%d roots from %d starts (%.2f s), %d valid\n", design.summary.distinct_roots,
                design.summary.starts, design.summary.seconds, design.summary.valid_roots);
    // Most roots are impossible (15 found, 1 valid on the default sensor): their reasons run
    // to ~100 lines, which only someone changing the design needs.
    for (size_t i = 0; args.verbose && i < design.roots.size(); ++i) {
      const auto& r = design.roots[i];
      std::printf("  root %zu: %s (max residual %.1e)\n", i + 1, r.valid() ? "VALID" : "impossible",
                  r.max_residual());
      for (const auto& why : r.rejections) std::printf("      - %s\n", why.c_str());
    }
    if (design.chosen) {
      const LightPathRoot& r = design.roots[*design.chosen];
      std::printf("layout (x, z in mm, left half; the right half is its mirror image):\n");
      std::printf("  mirror 1: A1 (%.4f, %.4f) - B1 (%.4f, %.4f)\n", r.a1.x(), r.a1.y(), r.b1.x(), r.b1.y());
      std::printf("  mirror 2: B2 (%.4f, %.4f) - A2 (%.4f, %.4f)\n", r.b2.x(), r.b2.y(), r.a2.x(), r.a2.y());
      for (const auto& v : design.config->virtual_cameras) {
        const Eigen::Vector3d p = v.sensor_from_vcam.translation();
        std::printf("  %s at (%.4f, %.4f, %.4f) mm, image columns [%d, %d)\n", v.name.c_str(), p.x(),
                    p.y(), p.z(), v.column_begin, v.column_end);
      }
      std::printf("  parallax angle %.9f deg, max residual %.1e\n", r.parallax_deg, r.max_residual());
      std::printf("wrote %s\n", args.out.c_str());
    }
  }
  if (!design.chosen) {
    throw Error(fmt::format(
        "no valid mirror layout for h = {} mm, l = {} mm, d = {} mm, FOV = {} deg: all {} roots of "
        "the design equations are physically impossible ({})",
        o.h_mm, o.l_mm, o.d_mm, o.fov_deg, design.roots.size(),
        args.json      ? "each root's reasons are in the JSON's roots"
        : args.verbose ? "reasons above"
                       : "--verbose prints each root's reasons"));
  }
}

}  // namespace

void RegisterDesign(CLI::App& app) {
  auto args = std::make_shared<DesignArgs>();
  CLI::App* cmd = app.add_subcommand(
      "design", "Solve the mirror layout (paper Fig. 4) for a fingertip and camera");
  cmd->add_option("--h", args->options.h_mm, "camera to elastic body, mm")->capture_default_str();
  cmd->add_option("--l", args->options.l_mm, "fingertip length, mm")->capture_default_str();
  cmd->add_option("--d", args->options.d_mm, "elastic body thickness, mm")->capture_default_str();
  cmd->add_option("--fov", args->options.fov_deg, "camera horizontal field of view, deg")
      ->capture_default_str();
  cmd->add_option("--config", args->base_config,
                  "sensor YAML to start from (camera resolution, markers, body); default built-in");
  cmd->add_option("--out", args->out, "sensor YAML to write")->capture_default_str();
  cmd->add_option("--svg", args->svg, "write the cross-section drawing as SVG");
  cmd->add_option("--png", args->png, "write the cross-section drawing as PNG");
  cmd->add_flag("--json", args->json, "print the result as JSON");
  cmd->add_flag("--verbose", args->verbose, "also print every root found, each rejected one with its reasons");
  cmd->callback([args] { Run(*args); });
}

}  // namespace tac3d::cli
