// `tac3d friction-map`: a friction-coefficient map (paper section IV.B) from a twin dataset's
// images run through the pipeline, or from a `tac3d run` recording with poses from a CSV.
#include "friction_command.h"

#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <type_traits>
#include <variant>

#include "commands.h"
#include "twin_runs.h"
#include "tac3d/util/file_io.h"
#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/friction_eval/friction_evaluation.h"
#include "tac3d/friction/pose_track.h"
#include "tac3d/record/recording.h"
#include "tac3d/util/error.h"
#include "tac3d/util/progress.h"

namespace tac3d::cli {
namespace {

Eigen::Vector3d Vector(const std::vector<double>& v, const char* option) {
  if (v.size() != 3) throw Error(fmt::format("{} takes three numbers: X Y Z", option));
  const Eigen::Vector3d d(v[0], v[1], v[2]);
  if (!(d.norm() > 0) || !d.allFinite())
    throw Error(fmt::format("{} must be a non-zero finite vector", option));
  return d.normalized();
}

// Frames from a recording, with poses from the CSV, in strokes (AddFrameOfStrokes).
void AddRecording(const std::string& path,
                  const friction::PoseTrack& poses,
                  friction::FrictionMapBuilder& builder,
                  bool show_progress,
                  int* frames) {
  RecordingReader reader(path);
  std::error_code ec;
  const auto size = static_cast<long>(std::filesystem::file_size(path, ec));
  ProgressBar bar("recording", ec ? 1 : std::max(1L, size), show_progress);
  while (const std::optional<RecordedFrame> recorded = reader.Next()) {
    builder.AddFrameOfStrokes(recorded->frame, poses.At(recorded->frame.timestamp_s));
    ++*frames;
    if (!ec) bar.Update(reader.offset());
  }
  bar.Finish();
  if (reader.status() != RecordingStatus::kComplete) {
    std::fprintf(stderr, "warning: %s\n", reader.message().c_str());
  }
}

}  // namespace

void FrictionMapArgs::Add(CLI::App* cmd) {
  for (const friction::FrictionMapCommandOption& o : friction::FrictionMapCommandOptions()) {
    std::visit(
        [&](auto field) {
          CLI::Option* flag = cmd->add_option(o.Flag(), options.*field, o.help);
          if constexpr (std::is_same_v<std::decay_t<decltype(options.*field)>, bool>) {
            flag->default_str(options.*field ? "true" : "false");  // not CLI11's 1 and 0
          } else {
            flag->capture_default_str();
          }
        },
        o.field);
  }
  cmd->add_option(
         "--view", view, "PNG view direction X Y Z, world (default: its mean normal, from above)")
      ->expected(3);
  cmd->add_option("--up", up, "PNG up direction X Y Z, world (default: y)")->expected(3);
}

friction::FrictionMapOptions FrictionMapArgs::Options(const SensorConfig& sensor) const {
  const friction::FrictionMapOptions o = options.WithSensor(sensor);
  friction::ValidateCommandOptions(o, friction::OptionNaming::kFlag);
  return o;
}

friction::RenderOptions FrictionMapArgs::View(const friction::FrictionMapResult& map) const {
  friction::RenderOptions r;
  if (!view.empty()) {
    r.view_direction = Vector(view, "--view");
  } else {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& n : map.vertex_normals) mean += n;
    // Along the surface's mean normal, from above as the viewer looks (a surface facing down is
    // seen from its back): from below the image would be the viewer's mirror image.
    if (mean.norm() > 0) r.view_direction = (mean.z() > 0 ? -mean : mean).normalized();
  }
  if (!up.empty()) {
    r.up = Vector(up, "--up");
  } else if (std::abs(r.view_direction.y()) > 0.9) {
    r.up = Eigen::Vector3d::UnitX();
  }
  r.Validate();
  return r;
}

nlohmann::json ReplayMapInputs(const ReplayRun& run, const FrictionReplayRecorder& recorder) {
  const Eigen::Vector3d& gains = run.options.pipeline.force.gains;
  return {{"dataset", run.report.at("dataset")},
          {"gains", {gains.x(), gains.y(), gains.z()}},
          {"strokes", recorder.strokes()}};
}

void RegisterFrictionMap(CLI::App& app) {
  struct Args {
    ReplayArgs replay;
    std::string recording;
    std::string poses;
    std::string out = "friction_map";
    FrictionMapArgs map;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "friction-map",
      "Build an object's friction-coefficient map (paper IV.B) from a twin dataset's images or a "
      "recording with poses: PLY (mu per vertex), slip points CSV, PNG, JSON summary");
  ReplayArgs& r = args->replay;
  CLI::Option* dataset =
      cmd->add_option("--dataset", r.dataset, "twin dataset folder (tac3d simulate)");
  CLI::Option* recording =
      cmd->add_option("--recording", args->recording, "a tac3d run recording (TactileFrames)");
  CLI::Option* poses = cmd->add_option(
      "--poses", args->poses, "world_from_sensor CSV (t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz)");
  dataset->excludes(recording);
  recording->needs(poses);
  poses->needs(recording);
  AddReplayOptions(cmd, r);
  cmd->add_option("--out", args->out, "folder for map.ply, slip_points.csv, map.png, summary.json")
      ->capture_default_str();
  args->map.Add(cmd);
  cmd->add_flag("--json", args->json, "print the summary as JSON");
  cmd->callback([args] {
    if (args->replay.dataset.empty() && args->recording.empty())
      throw Error("give --dataset or --recording with --poses");
    const bool progress = !args->json;
    nlohmann::json summary = {{"out", args->out}};
    std::optional<friction::FrictionMapBuilder> builder;
    const auto start = std::chrono::steady_clock::now();
    int frames = 0;
    if (!args->replay.dataset.empty()) {
      const TwinDatasetReader reader(args->replay.dataset);
      const SensorConfig sensor = args->replay.config.empty()
                                      ? DatasetSensor(reader)
                                      : LoadSensorConfig(args->replay.config);
      builder.emplace(args->map.Options(sensor));
      FrictionReplayRecorder recorder(*builder);
      ReplayArgs a = args->replay;
      a.show_progress = progress;
      const ReplayRun run = RunReplay(a, [&](const TwinStep& step, const TactileFrame& frame) {
        recorder.Add(step, frame);
        ++frames;
      });
      summary.update(ReplayMapInputs(run, recorder));
    } else {
      const SensorConfig sensor = LoadSensorOrDefault(args->replay.config);
      builder.emplace(args->map.Options(sensor));
      const friction::PoseTrack track = friction::PoseTrack::ReadCsv(args->poses);
      AddRecording(args->recording, track, *builder, progress, &frames);
      summary["recording"] = args->recording;
      summary["poses"] = args->poses;
    }
    const double input_s = SecondsSince(start);
    ProgressBar bar("friction map", 4, progress);
    const friction::FrictionMapResult map =
        builder->Build([&](int done, int) { bar.Update(done); });
    bar.Finish();
    summary["frames_in"] = frames;
    summary["input_s"] = input_s;
    summary = friction::WriteFrictionMapOutputs(map, builder->options(), args->out,
                                                args->map.View(map), std::move(summary));
    if (args->json) {
      std::printf("%s\n", summary.dump(2).c_str());
      return;
    }
    std::printf("%d frames in %.1f s; %s\n", frames, input_s, map.summary.BriefReport().c_str());
    std::printf("wrote %s/{map.ply,map.png,slip_points.csv,summary.json}\n", args->out.c_str());
  });
}

}  // namespace tac3d::cli
