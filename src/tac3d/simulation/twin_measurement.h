#pragma once

#include <memory>
#include <vector>

#include "tac3d/fem/compliance.h"
#include "tac3d/frame/tactile_frame.h"
#include "tac3d/pipeline/pipeline.h"
#include "tac3d/simulation/simulation.h"

namespace tac3d::simulation {

/// What the sensor measures along a twin simulation: the simulation's rendered camera images
/// through the Pipeline a user runs on the sensor (`tac3d run`, tac3d.Pipeline), one step at a
/// time as the images are rendered. The pipeline's reference is taken from images of the sensor
/// at rest before step 0 (TwinSimulation::RenderAtRest), as a sensor started before it touches
/// anything takes it; every step is then measured, step 0 included.
class TwinMeasurement {
 public:
  /// @param sensor the sensor as its user has it: a scene's `sensor`, without the twin's
  ///   deviation (E, nu, refinement) or manufacturing spread, which the user does not know.
  /// @param model the sensor's compliance, as `tac3d run` loads it:
  ///   fem::LoadSharedComplianceModel(SensorBodyModelOptions(sensor), ...). Shared, not copied:
  ///   the measurements of one model (a worker's episodes) and the other pipelines of the
  ///   process hold one H and, at one weight, one inverse (Pipeline's shared H).
  /// @param options the pipeline's options; DefaultPipelineOptions(sensor) is what the sensor
  ///   runs with.
  /// @throws Error if model is null, or as Pipeline's constructor does (invalid options, a
  ///   model of another sensor).
  TwinMeasurement(const SensorConfig& sensor,
                  const std::shared_ptr<const fem::ComplianceModel>& model,
                  const PipelineOptions& options);

  /// Renders the pipeline's reference_frames images of `simulation`'s sensor at rest and hands
  /// them to the pipeline as its reference; returns them (a replay feeds them first).
  /// @pre called once, before Measure.
  /// @throws Error if the simulation renders no images.
  std::vector<Frame> TakeReference(const TwinSimulation& simulation);

  /// The pipeline's TactileFrame of `step`'s image, stamped with the step's time and index.
  /// @throws Error if the step has no image, or as Pipeline::Process does.
  TactileFrame Measure(const TwinStep& step);

  const Pipeline& pipeline() const { return pipeline_; }

 private:
  Pipeline pipeline_;
  bool reference_taken_ = false;
};

}  // namespace tac3d::simulation
