#pragma once

// One sensor of a run: its source (a camera, video, image folder or twin dataset through the
// Pipeline, or a recording replayed) as a stream of TactileFrames for the frame loop. Shared by
// `tac3d run`'s one sensor (RunSingleSensor), the run file's sensors (RunSensorGroup), `tac3d
// view` and Python's tac3d.run.

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <Eigen/Core>

#include "tac3d/runtime/run_outputs.h"
#include "tac3d/fem/compliance.h"
#include "tac3d/pipeline/pipeline.h"
#include "tac3d/source/frame_source.h"

namespace tac3d::runtime {

/// Camera options whose width and height (0) are taken from the sensor config.
CameraSourceOptions CameraWithSensorResolution();

/// What one sensor of a run reads, how it computes its frames and where they go: the
/// one-sensor flags of `tac3d run`, or one entry of a run file (docs/pipeline.md).
struct SensorRunSpec {
  std::string sn = PipelineOptions{}.sn;
  /// camera:N, /dev/videoN, a video file, an image folder, dataset:DIR, recording:FILE or
  /// vendor:DIR.
  std::string source;
  std::string config;  ///< sensor YAML; "" the built-in prototype
  int reference_frames = PipelineOptions{}.reference_frames;
  /// Tikhonov weight w, (mm/N)^2, and the contact-support re-solve; unset: the sensor's
  /// (DefaultForceOptions).
  std::optional<double> weight;
  std::optional<bool> support_resolve;
  Eigen::Vector3d gains = Eigen::Vector3d::Ones();  ///< force gains Cx, Cy, Cz
  /// recording:FILE and vendor:DIR: the forces computed anew from the recorded displacements
  /// through the pipeline's inverse for `config` (Pipeline::RecomputeForces), not replayed.
  bool recompute_forces = false;
  DriftOptions drift = PipelineOptions{}.drift;     ///< drift at rest: flag, rezero or off
  /// recording:FILE and vendor:DIR: replay speed (unset: 1, the recorded pace; 0 as fast as
  /// possible);
  /// dataset:DIR: paced at this times its timestamps (unset: as fast as possible).
  std::optional<double> speed;
  CameraSourceOptions camera = CameraWithSensorResolution();
  double exposure = 0.0;  ///< camera exposure in driver units; 0 automatic
  /// udp, record, record_images, overwrite, json; sn is set from `sn` for pipelines.
  FrameOutputArgs outputs;
  /// A viewer shows the camera's images (one a run file's sensors share; outputs.web is this
  /// sensor's own).
  bool shared_viewer = false;

  /// Whether the camera's images are shown or recorded (a viewer, record_images), so decoded
  /// whole; else an MJPEG camera's frames are decoded only where the tracker reads
  /// (FrameSource::SetDecodeRegion).
  bool NeedsWholeImages() const { return shared_viewer || !outputs.web.empty() || outputs.record_images; }

  /// The pipeline's options for this sensor: DefaultPipelineOptions(config) with sn,
  /// reference_frames, weight, support_resolve, gains and drift as given.
  PipelineOptions ToPipelineOptions(const SensorConfig& config) const;
  /// Checks what can be checked before any work.
  /// @throws Error naming the field: an empty sn or source, a negative speed or one for a
  ///   source that is not paced (IsPacedSource), the pipeline's options, the outputs'.
  void Validate() const;
};

/// The drift mode named "off", "flag" or "rezero" (as --drift and the run file name them), or
/// nullopt for another name.
std::optional<DriftMode> ParseDriftMode(const std::string& name);
/// "off", "flag" or "rezero".
const char* DriftModeName(DriftMode mode);

/// Whether `speed` applies to `source`: dataset:DIR, recording:FILE and vendor:DIR, paced by
/// their timestamps.
bool IsPacedSource(const std::string& source);

/// The compliance model of a sensor config: the CLI loads (or builds) it from its cache, one
/// copy for every sensor of the same gel (CachedModelLoader); tests give a stand-in. The
/// pipelines of one model object share its H and their inverse's matrices.
using ModelLoader = std::function<std::shared_ptr<const fem::ComplianceModel>(const SensorConfig&)>;

/// How a stream's frames are timed, set when its loop starts.
struct StreamClock {
  std::chrono::steady_clock::time_point epoch;  ///< a dataset's pace counts from here
  /// Stamp each frame with seconds since `epoch` (the one clock of a run file's sensors)
  /// instead of the source's own timestamps.
  bool common = false;
};

/// How a stream ended, once its loop is over.
struct StreamEnd {
  std::string failure;  ///< why the source broke (a camera unplugged, a corrupt file); "" none
  std::string warning;  ///< worth saying but not a failure (a truncated recording)
  std::string last_skip;  ///< why the last skipped (bad) frame was skipped; "" none
};

/// One sensor's TactileFrames, one at a time (not thread-safe; one thread per stream).
class SensorStream {
 public:
  virtual ~SensorStream() = default;
  virtual void Start(const StreamClock& clock) = 0;
  /// As FrameProducer: a pipeline's stream gives its tracker's markers too.
  virtual Produced Next(const std::atomic<bool>& stop, ProducedFrame& out) = 0;
  /// A `$C`: retake the reference.
  virtual void Zero() = 0;
  /// ZeroHandler::retakes_reference: a pipeline's stream's does; a recording's only notes it.
  virtual bool ZeroRetakesReference() const = 0;
  /// @param emitted frames the loop emitted, for the messages.
  virtual StreamEnd End(long emitted) const = 0;
  virtual std::string Describe() const = 0;
};

/// Opens the sensor's source and, unless it is a recording (recording:FILE, vendor:DIR), its
/// config, compliance model and pipeline (spec.speed is used with paced sources only).
/// @throws Error if the source cannot be opened (a camera missing, a folder without images)
///   or the config is invalid.
/// @param log_prefix before each line it prints on stderr ("SN: " for a run file's sensors).
std::unique_ptr<SensorStream> OpenSensorStream(const SensorRunSpec& spec,
                                               const ModelLoader& load_model,
                                               const std::string& log_prefix = "");

/// A recording's frames as they were computed, replayed at spec.speed (unset: 1) times the
/// recorded pace, with spec.sn when `replace_sn`, else the recorded SN. With
/// spec.recompute_forces, their forces are computed anew (Pipeline::RecomputeForces) for the
/// sensor of spec.config, whose model `load_model` gives.
/// @throws Error if the file is not a recording, or recompute_forces has no model loader.
std::unique_ptr<SensorStream> OpenRecordingStream(const std::string& path,
                                                  const SensorRunSpec& spec,
                                                  bool replace_sn,
                                                  const ModelLoader& load_model = {},
                                                  const std::string& log_prefix = "");

/// A vendor recording's frames (docs/real-sensors.md): `path` is its `<SN>` folder or the
/// recording folder holding one or several (FindVendorRecordingFolders), each read whole and
/// checked first (ReadVendorRecordings). Each sensor's frames (VendorFrames: the vendor's fields
/// as recorded, normals and contact as tac3d makes them) keep its SN and sendTimestamp; several
/// sensors' frames come interleaved in the order of their timestamps (one clock, the vendor's),
/// at spec.speed (unset: 1) times that pace. With `replace_sn`, spec.sn replaces the SN. A `$C`
/// is noted and ignored. With spec.recompute_forces, the forces are computed anew from the
/// recorded displacements (Pipeline::RecomputeForces) for the sensor of spec.config (required),
/// one sensor at a time.
/// @throws Error naming the file of a missing, malformed or truncated field, for `replace_sn`
///   or recompute_forces with several sensors, or recompute_forces without a config, with
///   another sensor's config or without a model loader.
std::unique_ptr<SensorStream> OpenVendorStream(const std::string& path,
                                               const SensorRunSpec& spec,
                                               bool replace_sn,
                                               const ModelLoader& load_model = {},
                                               const std::string& log_prefix = "");

/// The compliance model from `cache_dir`, built there the first time (~1 min); one copy for
/// the whole process, shared by every sensor of the same gel (fem::LoadSharedComplianceModel).
ModelLoader CachedModelLoader(const std::string& cache_dir);

}  // namespace tac3d::runtime
