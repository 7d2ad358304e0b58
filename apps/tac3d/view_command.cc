// `tac3d view`: the live viewer's page on a recording's (tac3d's or the vendor's) or a dataset's frames, with a time
// slider, and a friction map's mesh in the paper's bands (docs/viewer.md).

#include <cstdio>
#include <memory>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "tac3d/runtime/run_outputs.h"
#include "tac3d/runtime/sensor_stream.h"
#include "tac3d/util/error.h"
#include "tac3d/vendor_formats/vendor_recording.h"
#include "view_data.h"

namespace tac3d::cli {
namespace {

using runtime::CachedModelLoader;
using runtime::FrameOutputArgs;
using runtime::HoldViewer;
using runtime::OpenRecordingStream;
using runtime::OpenSensorStream;
using runtime::OpenVendorStream;
using runtime::OpenViewer;
using runtime::SensorRunSpec;
using runtime::SensorStream;

FrameOutputArgs DefaultViewer() {
  FrameOutputArgs viewer;
  viewer.web = "127.0.0.1:8080";
  viewer.web_hold_s = -1.0;  // until Ctrl-C
  return viewer;
}

struct ViewArgs {
  std::string recording;
  std::string vendor;
  std::string dataset;
  std::string friction_map;
  SensorRunSpec sensor;  // a dataset's pipeline: config, sn, reference_frames
  std::string cache_dir = DefaultCacheDir();
  FrameOutputArgs viewer = DefaultViewer();
};

void View(const ViewArgs& a) {
  if (!a.recording.empty() + !a.vendor.empty() + !a.dataset.empty() > 1) {
    throw Error("view: --recording, --vendor and --dataset exclude each other");
  }
  if (a.recording.empty() && a.vendor.empty() && a.dataset.empty() && a.friction_map.empty()) {
    throw Error("view: give --recording FILE, --vendor DIR or --dataset DIR, and/or --friction-map DIR_OR_PLY");
  }
  a.viewer.Validate();
  auto data = std::make_shared<ViewData>();
  if (!a.friction_map.empty()) data->LoadFrictionMap(a.friction_map);
  SensorRunSpec spec = a.sensor;
  spec.speed = 0.0;  // read as fast as possible: the page scrubs them
  std::unique_ptr<SensorStream> stream;
  if (!a.recording.empty()) stream = OpenRecordingStream(a.recording, spec, /*replace_sn=*/false);
  if (!a.vendor.empty()) {
    // The page's time slider scrubs one sensor.
    const std::vector<std::string> sensors = FindVendorRecordingFolders(a.vendor);
    if (sensors.size() > 1) {
      throw Error(fmt::format("view: '{}' holds the recordings of {} sensors; the viewer scrubs one: give its "
                              "<SN> folder, one of {}",
                              a.vendor, sensors.size(), fmt::join(sensors, ", ")));
    }
    stream = OpenVendorStream(a.vendor, spec, /*replace_sn=*/false);
  }
  if (!a.dataset.empty()) {
    spec.source = "dataset:" + a.dataset;
    spec.speed.reset();
    stream = OpenSensorStream(spec, CachedModelLoader(a.cache_dir));
  }
  if (stream) {
    data->LoadFrames(*stream, stream->Describe());
    std::fprintf(stderr, "%ld frames\n", data->frames());
  }
  const std::shared_ptr<WebServer> viewer =
      OpenViewer(a.viewer, [data](const std::string& target) { return data->Handle(target); });
  HoldViewer(viewer.get(), a.viewer.web_hold_s);
}

}  // namespace

void RegisterView(CLI::App& app) {
  auto a = std::make_shared<ViewArgs>();
  CLI::App* cmd = app.add_subcommand(
      "view",
      "Scrub a recording's (tac3d's or the vendor's) or a twin dataset's frames in the viewer page; show a "
      "friction map");
  cmd->add_option("--recording", a->recording, "a recording (tac3d run --record)");
  cmd->add_option("--vendor", a->vendor,
                  "a recording of the vendor's software: its <SN> folder, or the folder holding it "
                  "(docs/real-sensors.md)");
  cmd->add_option("--dataset", a->dataset, "a twin dataset, its images through the pipeline");
  cmd->add_option("--friction-map", a->friction_map, "map.ply of tac3d friction-map, or its folder");
  cmd->add_option("--config", a->sensor.config, "with --dataset: sensor YAML (default: the built-in prototype)");
  cmd->add_option("--cache,--cache-dir", a->cache_dir, "with --dataset: directory of cached compliance models")
      ->capture_default_str();
  cmd->add_option("--sn", a->sensor.sn, "with --dataset: the sensor's serial number")->capture_default_str();
  cmd->add_option("--reference-frames", a->sensor.reference_frames, "with --dataset: static frames taken as the reference")
      ->capture_default_str();
  cmd->add_option("--web", a->viewer.web, "serve the page on HOST:PORT")->capture_default_str();
  cmd->add_option("--web-root", a->viewer.web_root, "the viewer page's folder (default: the built one)");
  cmd->add_option("--web-hold", a->viewer.web_hold_s, "serve this many seconds (-1: until Ctrl-C)")
      ->capture_default_str();
  cmd->callback([a, cmd] {
    if (a->dataset.empty()) {
      RefuseOptions(*cmd, {"--config", "--cache", "--sn", "--reference-frames"}, "applies to --dataset only");
    }
    View(*a);
  });
}

}  // namespace tac3d::cli
