#include "tac3d/runtime/sensor_stream.h"

#include <algorithm>
#include <cstdio>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "tac3d/sensor/default_sensor.h"
#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/record/recording_replay.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"
#include "tac3d/util/seconds_since.h"
#include "tac3d/util/stoppable_sleep.h"
#include "tac3d/vendor_formats/vendor_frames.h"
#include "tac3d/vendor_formats/vendor_gel.h"

namespace tac3d::runtime {
namespace {

std::unique_ptr<FrameSource> OpenImageSource(const SensorRunSpec& spec, const SensorConfig& config) {
  if (spec.source.rfind("dataset:", 0) == 0) return OpenTwinDataset(spec.source.substr(8));
  CameraSourceOptions camera = spec.camera;
  if (camera.width == 0) camera.width = config.camera.intrinsics.width;
  if (camera.height == 0) camera.height = config.camera.intrinsics.height;
  if (spec.exposure > 0) camera.exposure = spec.exposure;
  return OpenFrameSource(spec.source, camera);
}

// The sensor's pipeline, its options checked before the model is loaded (or built: minutes);
// says which inverse it runs.
std::unique_ptr<Pipeline> MakePipeline(const SensorRunSpec& spec, const SensorConfig& config,
                                       const ModelLoader& load_model, const std::string& log_prefix) {
  const PipelineOptions options = spec.ToPipelineOptions(config);
  options.Validate();
  std::fprintf(stderr, "%sinverse: weight %g (mm/N)^2, contact-support re-solve %s%s\n", log_prefix.c_str(),
               options.force.weight, options.force.support_refinement ? "on" : "off",
               spec.weight || spec.support_resolve ? "" : " (the sensor's defaults)");
  const std::shared_ptr<const fem::ComplianceModel> model = load_model(config);
  // The sensors of one model share its H and the inverse's matrices (SharedTikhonovInverse).
  return std::make_unique<Pipeline>(config, fem::SharedH(model), model->marker_positions, options);
}

// Camera images through the Pipeline.
class PipelineStream final : public SensorStream {
 public:
  PipelineStream(const SensorRunSpec& spec, const ModelLoader& load_model, const std::string& log_prefix)
      : spec_(spec), log_prefix_(log_prefix) {
    const SensorConfig config = LoadSensorOrDefault(spec.config);
    source_ = OpenImageSource(spec, config);
    std::fprintf(stderr, "%ssource: %s\n", log_prefix_.c_str(), source_->Describe().c_str());
    pipeline_ = MakePipeline(spec, config, load_model, log_prefix_);
  }

  void Start(const StreamClock& clock) override { clock_ = clock; }

  Produced Next(const std::atomic<bool>& stop, ProducedFrame& out) override {
    const ReadStatus status = source_->Read(frame_);
    if (status == ReadStatus::kEnd) return Produced::kEnd;
    if (status == ReadStatus::kFailed) {
      failure_ = source_->last_error();
      return Produced::kEnd;
    }
    if (status == ReadStatus::kBadFrame) {
      last_skip_ = source_->last_error();
      std::fprintf(stderr, "%sskipped a bad frame: %s\n", log_prefix_.c_str(), last_skip_.c_str());
      return Produced::kSkipped;
    }
    // Paced on the run's clock (sensors in step), each wait at most a pacer's bound.
    if (spec_.speed && *spec_.speed > 0 &&
        !SleepUnlessStopped(std::min(frame_.timestamp_s / *spec_.speed - SecondsSince(clock_.epoch),
                                     ReplayPacer::kMaxWaitS),
                            &stop)) {
      return Produced::kEnd;
    }
    if (clock_.common) frame_.timestamp_s = SecondsSince(clock_.epoch);
    try {
      pipeline_->Process(frame_, out_);
      if (!spec_.NeedsWholeImages()) source_->SetDecodeRegion(pipeline_->CalcReadRegion());
    } catch (const Error& e) {
      last_skip_ = e.what();
      std::fprintf(stderr, "%sskipped frame %lld: %s\n", log_prefix_.c_str(),
                   static_cast<long long>(frame_.index), e.what());
      return Produced::kSkipped;
    }
    out.frame = &out_;
    out.image = &frame_.image;
    out.markers = &pipeline_->observation();
    return Produced::kFrame;
  }

  void Zero() override { pipeline_->RequestZero(); }
  bool ZeroRetakesReference() const override { return true; }

  StreamEnd End(long) const override {
    return {.failure = failure_.empty() ? "" : fmt::format("the frame source failed: {}", failure_),
            .warning = "",
            .last_skip = last_skip_};
  }

  std::string Describe() const override { return source_->Describe(); }

 private:
  SensorRunSpec spec_;
  std::string log_prefix_;
  std::unique_ptr<FrameSource> source_;
  std::unique_ptr<Pipeline> pipeline_;
  StreamClock clock_;
  Frame frame_;
  TactileFrame out_;
  std::string failure_;
  std::string last_skip_;
};

// A recording's frames were computed when it was recorded: a `$C` is said to be ignored, once.
void NoteIgnoredZero(const std::string& log_prefix, bool* noted) {
  if (!*noted) {
    std::fprintf(stderr, "%signored $C (zero): a recording's frames were computed when it was recorded\n",
                 log_prefix.c_str());
  }
  *noted = true;
}

// Says that a replay cut a pause of its recording (ReplayPacer::kMaxWaitS), if it did.
void NoteShortenedWait(const std::string& log_prefix, std::optional<double> wait_s) {
  if (!wait_s) return;
  std::fprintf(stderr, "%sa pause of %.4g s in the recording was replayed as %g s\n", log_prefix.c_str(), *wait_s,
               ReplayPacer::kMaxWaitS);
}

// With spec.recompute_forces: a recording's frames get their forces anew from their recorded
// displacements, through the pipeline `spec` gives the sensor of `spec.config`.
class ForceRecomputation {
 public:
  // `check` sees the sensor's config before its model is loaded (or built: minutes).
  ForceRecomputation(const SensorRunSpec& spec, const ModelLoader& load_model, const std::string& log_prefix,
                     const std::function<void(const SensorConfig&)>& check = {}) {
    if (!spec.recompute_forces) return;
    if (!load_model) throw Error("recomputing forces needs the sensor's compliance model: none was given");
    const SensorConfig config = LoadSensorOrDefault(spec.config);
    if (check) check(config);
    pipeline_ = MakePipeline(spec, config, load_model, log_prefix);
  }

  void Apply(TactileFrame& frame) {
    if (pipeline_) pipeline_->RecomputeForces(frame);
  }

 private:
  std::unique_ptr<Pipeline> pipeline_;
};

// A recording's frames as they were computed, at its recorded pace times `speed`.
class RecordingStream final : public SensorStream {
 public:
  RecordingStream(const std::string& path, const SensorRunSpec& spec, bool replace_sn, const ModelLoader& load_model,
                  const std::string& log_prefix)
      : path_(path), log_prefix_(log_prefix), replay_(path, {.speed = spec.speed.value_or(1.0)}) {
    if (replace_sn) sn_ = spec.sn;
    std::fprintf(stderr, "%ssource: %s%s\n", log_prefix_.c_str(), replay_.Describe().c_str(),
                 spec.recompute_forces ? ", forces recomputed from its displacements" : "");
    recompute_.emplace(spec, load_model, log_prefix_);
  }

  void Start(const StreamClock& clock) override { clock_ = clock; }

  // A recording holds no marker pixels: its images (when recorded) are shown without markers.
  Produced Next(const std::atomic<bool>& stop, ProducedFrame& out) override {
    current_ = replay_.Next(&stop);
    NoteShortenedWait(log_prefix_, replay_.TakeShortenedWait());
    if (!current_) return Produced::kEnd;
    recompute_->Apply(current_->frame);
    if (sn_) current_->frame.sn = *sn_;
    if (clock_.common) current_->frame.timestamp_s = SecondsSince(clock_.epoch);
    out.frame = &current_->frame;
    out.image = &current_->image;
    out.markers = nullptr;
    return Produced::kFrame;
  }

  void Zero() override { NoteIgnoredZero(log_prefix_, &zero_noted_); }
  bool ZeroRetakesReference() const override { return false; }

  // A truncated file (a writer killed mid-record) is a warning, a corrupt one a failure.
  StreamEnd End(long emitted) const override {
    const std::string message =
        fmt::format("{} (the {} frames before it were replayed)", replay_.message(), emitted);
    if (replay_.status() == RecordingStatus::kTruncated) return {.failure = "", .warning = message, .last_skip = ""};
    if (replay_.status() == RecordingStatus::kCorrupt) return {.failure = message, .warning = "", .last_skip = ""};
    return {};
  }

  std::string Describe() const override { return path_; }

 private:
  std::string path_;
  std::string log_prefix_;
  RecordingReplay replay_;
  std::optional<ForceRecomputation> recompute_;
  std::optional<std::string> sn_;
  StreamClock clock_;
  std::optional<RecordedFrame> current_;
  bool zero_noted_ = false;
};

// A vendor recording's sensors, their frames interleaved in the order of their sendTimestamps.
class VendorStream final : public SensorStream {
 public:
  VendorStream(const std::string& path, const SensorRunSpec& spec, bool replace_sn, const ModelLoader& load_model,
               const std::string& log_prefix)
      : path_(path), log_prefix_(log_prefix), speed_(spec.speed.value_or(1.0)), pacer_(speed_) {
    RecordingReplayOptions{.speed = speed_}.Validate();
    std::vector<std::string> described;
    for (VendorRecording& recording : ReadVendorRecordings(path)) {
      const double shift_mm = recording.MaxReferenceShiftMm();
      const std::int64_t no_resultant = recording.FramesWithNonFiniteResultant();
      sensors_.emplace_back(std::move(recording));
      const VendorFrames& sensor = sensors_.back();
      described.push_back(fmt::format(
          "{} ({} frames of {} markers, zero point moved up to {:.3f} mm{}{})", sensor.recording().serial_number,
          sensor.frames(), sensor.recording().markers(), shift_mm,
          sensor.has_normals() ? "" : ", no grid surface: normals zero",
          no_resultant == 0 || spec.recompute_forces ? ""
                            : fmt::format(", {} frame(s) with a NaN or infinite resultant, sent as recorded (null in "
                                          "JSON)",
                                          no_resultant)));
    }
    if (replace_sn && sensors_.size() > 1) {
      throw Error(fmt::format("vendor recording '{}' holds {} sensors: an SN to give them all would mix them up; "
                              "give one <SN> folder (vendor:{}/<SN>), or leave the SNs as recorded",
                              path, sensors_.size(), path));
    }
    if (replace_sn) sn_ = spec.sn;
    next_.assign(sensors_.size(), 0);
    std::fprintf(stderr, "%ssource: %s%s\n", log_prefix_.c_str(),
                 fmt::format("vendor recording {}: {} {}", path_, fmt::join(described, ", "),
                             speed_ > 0 ? fmt::format("at {}x", speed_) : "as fast as possible")
                     .c_str(),
                 spec.recompute_forces ? ", forces recomputed from its displacements" : "");
    if (spec.recompute_forces) {
      if (spec.config.empty()) {
        throw Error("recomputing a vendor recording's forces needs its sensor's config (`tac3d import-vendor`)");
      }
      if (sensors_.size() > 1) {
        throw Error(fmt::format("vendor recording '{}' holds {} sensors: recompute one at a time (vendor:{}/<SN>, "
                                "with that sensor's config)",
                                path, sensors_.size(), path));
      }
    }
    // The forces of a sensor come from its own gel's model.
    const auto same_sensor = [&](const SensorConfig& config) {
      const std::string& recorded_sn = sensors_.front().recording().serial_number;
      if (config.vendor_camera && !config.vendor_camera->serial_number.empty() &&
          config.vendor_camera->serial_number != recorded_sn) {
        throw Error(fmt::format("the recording is of sensor {}, the config '{}' of {}: its forces would come from "
                                "another gel",
                                recorded_sn, spec.config, config.vendor_camera->serial_number));
      }
    };
    recompute_.emplace(spec, load_model, log_prefix_, same_sensor);
  }

  void Start(const StreamClock& clock) override { clock_ = clock; }

  Produced Next(const std::atomic<bool>& stop, ProducedFrame& out) override {
    // The sensor whose next frame was sent first (the first sensor on a tie).
    std::optional<size_t> due;
    for (size_t s = 0; s < sensors_.size(); ++s) {
      if (next_[s] >= sensors_[s].frames()) continue;
      if (!due || sensors_[s].timestamp_s(next_[s]) < sensors_[*due].timestamp_s(next_[*due])) due = s;
    }
    if (!due) return Produced::kEnd;
    current_ = sensors_[*due].Frame(next_[*due]++);
    recompute_->Apply(current_);
    const bool due_now = pacer_.Wait(current_.timestamp_s, &stop);
    NoteShortenedWait(log_prefix_, pacer_.TakeShortenedWait());
    if (!due_now) return Produced::kEnd;
    if (sn_) current_.sn = *sn_;
    if (clock_.common) current_.timestamp_s = SecondsSince(clock_.epoch);
    out.frame = &current_;
    out.image = nullptr;
    out.markers = nullptr;
    return Produced::kFrame;
  }

  void Zero() override { NoteIgnoredZero(log_prefix_, &zero_noted_); }
  bool ZeroRetakesReference() const override { return false; }

  // Every file was read and checked when the stream was opened: nothing can fail later.
  StreamEnd End(long) const override { return {}; }

  std::string Describe() const override { return "vendor:" + path_; }

 private:
  std::string path_;
  std::string log_prefix_;
  double speed_;
  ReplayPacer pacer_;
  std::vector<VendorFrames> sensors_;
  std::vector<std::int64_t> next_;  // each sensor's next frame
  std::optional<ForceRecomputation> recompute_;
  std::optional<std::string> sn_;
  StreamClock clock_;
  TactileFrame current_;
  bool zero_noted_ = false;
};

}  // namespace

PipelineOptions SensorRunSpec::ToPipelineOptions(const SensorConfig& config) const {
  PipelineOptions options = DefaultPipelineOptions(config);
  options.sn = sn;
  options.reference_frames = reference_frames;
  if (weight) options.force.weight = *weight;
  if (support_resolve) options.force.support_refinement = *support_resolve;
  options.drift = drift;
  options.force.gains = gains;
  return options;
}

void SensorRunSpec::Validate() const {
  if (sn.empty()) throw Error("sensor: sn must not be empty");
  if (source.empty()) throw Error(fmt::format("sensor {}: source must not be empty", sn));
  if (speed && !IsPacedSource(source)) {
    throw Error(fmt::format("sensor {}: speed applies to recording:FILE, vendor:DIR or dataset:DIR only", sn));
  }
  try {
    if (speed) RecordingReplayOptions{.speed = *speed}.Validate();
    // Checked whatever the source, as the command line does: a file named but missing, or a
    // frame rate of NaN, is a mistake even where this source would not use it.
    if (!config.empty()) RequireRegularFile(config, "sensor config");
    ValidateFrameRate(camera.fps, "camera");
    ValidatePixelFormat(camera.pixel_format);
    ToPipelineOptions(SensorConfig{}).Validate();
    if (recompute_forces && !RecordingSourcePath(source) && !VendorSourcePath(source)) {
      throw Error("recompute_forces applies to recording:FILE and vendor:DIR only");
    }
    // The source's file or folder, past its scheme (recording:FILE, vendor:DIR, dataset:DIR).
    const std::string source_path = IsPacedSource(source) ? source.substr(source.find(':') + 1) : source;
    outputs.Validate({source_path, config});
  } catch (const Error& e) {
    throw Error(fmt::format("sensor {}: {}", sn, e.what()));
  }
}

std::optional<DriftMode> ParseDriftMode(const std::string& name) {
  for (const DriftMode mode : {DriftMode::kOff, DriftMode::kFlag, DriftMode::kRezero}) {
    if (name == DriftModeName(mode)) return mode;
  }
  return std::nullopt;
}

const char* DriftModeName(DriftMode mode) {
  switch (mode) {
    case DriftMode::kOff:
      return "off";
    case DriftMode::kFlag:
      return "flag";
    case DriftMode::kRezero:
      return "rezero";
  }
  return "?";
}

bool IsPacedSource(const std::string& source) {
  return source.rfind("dataset:", 0) == 0 || source.rfind("recording:", 0) == 0 || source.rfind("vendor:", 0) == 0;
}

CameraSourceOptions CameraWithSensorResolution() {
  CameraSourceOptions camera;
  camera.width = 0;
  camera.height = 0;
  return camera;
}

std::unique_ptr<SensorStream> OpenRecordingStream(const std::string& path,
                                                  const SensorRunSpec& spec,
                                                  bool replace_sn,
                                                  const ModelLoader& load_model,
                                                  const std::string& log_prefix) {
  return std::make_unique<RecordingStream>(path, spec, replace_sn, load_model, log_prefix);
}

std::unique_ptr<SensorStream> OpenVendorStream(const std::string& path,
                                               const SensorRunSpec& spec,
                                               bool replace_sn,
                                               const ModelLoader& load_model,
                                               const std::string& log_prefix) {
  return std::make_unique<VendorStream>(path, spec, replace_sn, load_model, log_prefix);
}

std::unique_ptr<SensorStream> OpenSensorStream(const SensorRunSpec& spec,
                                               const ModelLoader& load_model,
                                               const std::string& log_prefix) {
  if (const std::optional<std::string> path = RecordingSourcePath(spec.source)) {
    return OpenRecordingStream(*path, spec, /*replace_sn=*/true, load_model, log_prefix);
  }
  if (const std::optional<std::string> path = VendorSourcePath(spec.source)) {
    return OpenVendorStream(*path, spec, /*replace_sn=*/true, load_model, log_prefix);
  }
  return std::make_unique<PipelineStream>(spec, load_model, log_prefix);
}

ModelLoader CachedModelLoader(const std::string& cache_dir) {
  return [cache_dir](const SensorConfig& config) {
    MakeCacheDirectory(cache_dir);
    return fem::LoadSharedComplianceModel(SensorBodyModelOptions(config), cache_dir, /*show_progress=*/true);
  };
}

}  // namespace tac3d::runtime
