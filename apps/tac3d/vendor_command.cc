// `tac3d import-vendor` and `tac3d eval vendor`: a real Tac3D from its vendor's files
// (docs/real-sensors.md).
#include <cstdio>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "tac3d/vendor_formats/vendor_calibration.h"
#include "tac3d/eval/vendor_evaluation.h"
#include "tac3d/vendor_formats/vendor_recording.h"

namespace tac3d::cli {

void RegisterImportVendor(CLI::App& app) {
  struct Args {
    std::string folder;
    std::string out = "sensor.yaml";
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "import-vendor", "Make a sensor YAML from a Tac3D's vendor calibration folder (its camera model, markers, gel)");
  cmd->add_option("folder", args->folder,
                  "the folder holding Reconstruction3D/parameters.yaml, DMP3_by_Zhang/markers.txt, sensor.yaml, "
                  "datasheet.yaml")
      ->required();
  cmd->add_option("--out", args->out, "sensor YAML to write")->capture_default_str();
  cmd->callback([args] {
    CheckOutputFile(args->out, "--out", {".yaml", ".yml"}, {args->folder});
    const SensorConfig config = ImportVendorSensor(args->folder);
    SaveSensorConfig(config, args->out);
    const DomeFitConfig& dome = config.vendor_camera->dome;
    std::printf("%s", fmt::format("sensor {}: {} x {} camera, {} x {} markers; dome fitted to the triangulated reference "
                                  "positions: radius {:.3f} mm, centre ({:.3f}, {:.3f}, {:.3f}) mm, {:.4f} mm RMS "
                                  "({:.4f} mm max) off it, pitch {:.4f} mm\nwrote {}\n",
                                  config.vendor_camera->serial_number, config.camera.intrinsics.width,
                                  config.camera.intrinsics.height, config.markers.rows, config.markers.cols,
                                  dome.radius_mm, dome.center_mm.x(), dome.center_mm.y(), dome.center_mm.z(),
                                  dome.rms_mm, dome.max_mm, dome.pitch_mm, args->out)
                          .c_str());
  });
}

void RegisterEvalVendor(CLI::App& eval) {
  struct Args {
    std::string config;
    std::string recording;
    VendorEvaluationOptions options;
    VendorForceOptions forces = {.cache_dir = DefaultCacheDir()};
    bool no_forces = false;
    bool no_distortion = false;
    bool no_refraction = false;
    bool json = false;
    double weight = 0.0;
    std::string support_resolve;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = eval.add_subcommand(
      "vendor", "A real Tac3D's imported calibration against a recording of the vendor's software");
  cmd->add_option("--config", args->config, "the sensor YAML `tac3d import-vendor` wrote")->required();
  cmd->add_option("--recording", args->recording, "the vendor's recording folder (or its <SN> folder)")->required();
  cmd->add_option("--reference-frame", args->options.reference_frame,
                  "the frame whose 3D_Positions - 3D_Displacements are the reference")
      ->capture_default_str();
  cmd->add_flag("--no-distortion", args->no_distortion, "triangulate without the lens distortion (to measure it)");
  cmd->add_flag("--no-refraction", args->no_refraction, "triangulate without the refraction (to measure it)");
  cmd->add_flag("--no-forces", args->no_forces, "the reference positions only (no FEM model of the gel)");
  VendorGelOptions& gel = args->forces.gel;
  cmd->add_option("--marker-depth-mm", gel.marker_depth_mm, "the gel's assumed marker depth under its surface")
      ->capture_default_str();
  cmd->add_option("--base-offset-mm", gel.base_offset_mm,
                  "the gel's base above the refraction plane (negative: a thicker gel)")
      ->capture_default_str();
  cmd->add_option("--base-diameter-mm", gel.base_diameter_mm,
                  "the gel's base diameter (0: where the markers' sphere meets the base)")
      ->capture_default_str();
  cmd->add_option("--refinement", gel.refinement, "the gel's FEM mesh refinement (1 = the paper's mesh)")
      ->capture_default_str();
  cmd->add_option("--min-resultant-n", args->forces.min_resultant_n,
                  "compare the frames whose recorded |resultant| exceeds this (N)")
      ->capture_default_str();
  cmd->add_option("--cache,--cache-dir", args->forces.cache_dir, "directory of cached compliance models")->capture_default_str();
  cmd->add_option("--weight", args->weight,
                  "the inverse's Tikhonov weight w, (mm/N)^2, as `tac3d run --weight` (default: the sensor's)");
  cmd->add_option("--support-resolve", args->support_resolve,
                  "the contact-support re-solve, on or off, as `tac3d run --support-resolve` (default: the sensor's)")
      ->check(CLI::IsMember({"on", "off"}));
  cmd->add_flag("--json", args->json, "print JSON");
  cmd->callback([args, cmd] {
    if (cmd->count("--weight") > 0) args->forces.weight = args->weight;
    if (cmd->count("--support-resolve") > 0) args->forces.support_resolve = args->support_resolve == "on";
    args->options.stereo.undistort = !args->no_distortion;
    args->options.stereo.refract = !args->no_refraction;
    args->forces.show_progress = ShowProgress(args->json);
    if (!args->no_forces) args->options.forces = args->forces;
    const VendorEvaluation evaluation = EvaluateVendorRecording(
        LoadSensorConfig(args->config), ReadVendorRecording(args->recording), args->options);
    if (args->json) {
      std::printf("%s\n", ToJson(evaluation).dump(2).c_str());
    } else {
      std::printf("%s", evaluation.Report().c_str());
    }
  });
}

}  // namespace tac3d::cli
