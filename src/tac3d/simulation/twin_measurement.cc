#include "tac3d/simulation/twin_measurement.h"

#include "tac3d/util/error.h"

namespace tac3d::simulation {
namespace {

// The pipeline of the model's H, shared (fem::SharedH), not copied.
Pipeline MakeSharedPipeline(const SensorConfig& sensor,
                            const std::shared_ptr<const fem::ComplianceModel>& model,
                            const PipelineOptions& options) {
  if (!model) throw Error("TwinMeasurement: no compliance model given");
  return Pipeline(sensor, fem::SharedH(model), model->marker_positions, options);
}

}  // namespace

TwinMeasurement::TwinMeasurement(const SensorConfig& sensor,
                                 const std::shared_ptr<const fem::ComplianceModel>& model,
                                 const PipelineOptions& options)
    : pipeline_(MakeSharedPipeline(sensor, model, options)) {}

std::vector<Frame> TwinMeasurement::TakeReference(const TwinSimulation& simulation) {
  TAC3D_DEMAND(!reference_taken_);
  std::vector<Frame> frames = simulation.RenderAtRest(pipeline_.options().reference_frames);
  TactileFrame out;
  for (const Frame& frame : frames) pipeline_.Process(frame, out);
  reference_taken_ = true;
  return frames;
}

TactileFrame TwinMeasurement::Measure(const TwinStep& step) {
  TAC3D_DEMAND(reference_taken_);
  if (step.image.empty()) {
    throw Error(
        fmt::format("TwinMeasurement: step {} has no image (simulate with images)", step.index));
  }
  TactileFrame out;
  pipeline_.Process(Frame{step.image, step.t_s, step.index}, out);
  return out;
}

}  // namespace tac3d::simulation
