// Image to TactileFrame per frame (median <= 1 ms on one core): tracking, stereo,
// displacement, F = K D, normals, contact, resultants and the live slip estimate, on twin
// frames of a moving press (/0) and of a press that also shears the surface along x (/1, so
// the slip estimate sees a tangential load); the slip estimate alone on the sheared press's
// frames (BM_SlipEstimate/0) and on those around its partial slip (/1, the friction-cone mu);
// and
// the throughput with the Tac3D UDP sender on, streaming every frame to a loopback client
// socket that drains what arrives. At 1920 x 1080 on a vendor-calibrated sensor
// (median <= 2 ms on one core), with the decoding of a 1920 x 1080 MJPEG frame beside
// it (BM_VendorImageToTactileFrame, BM_DecodeMjpeg1080p), and the two together as a camera's
// MJPEG frames reach the pipeline (BM_VendorMjpegToTactileFrame: median <= 5 ms on one core).
// Run: taskset -c 0 build/bin/bench_pipeline --benchmark_repetitions=10
//        --benchmark_report_aggregates_only=true
#include <array>
#include <cmath>
#include <filesystem>

#include <benchmark/benchmark.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tac3d/design/light_path_design.h"
#include "tac3d/imagefile/jpeg_decoder.h"
#include "tac3d/force/synthetic_compliance.h"
#include "tac3d/pipeline/pipeline.h"
#include "tac3d/protocol/udp_sender.h"
#include "tac3d/protocol/udp_socket.h"
#include "tac3d/twin/camera_renderer.h"
#include "tac3d/vendor_formats/test_hdl1_0001_folder.h"

namespace tac3d {
namespace {

// HDL1-0001 as `tac3d import-vendor` makes it from the fixture's calibration (1920 x 1080).
SensorConfig Hdl1Sensor() {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "tac3d_bench_hdl1_0001";
  testing::WriteHdl1VendorFolder(dir);
  return ImportVendorSensor(dir.string());
}

// The synthetic H (the cost does not depend on its values) on the sensor's grid.
Eigen::MatrixXd SyntheticCompliance(const SensorConfig& config) {
  return CalcSyntheticCompliance({.rows = config.markers.rows, .cols = config.markers.cols,
                                  .pitch_mm = config.markers.pitch_mm})
      .h;
}

// A pipeline past its reference and 16 frames of a press coming and going.
struct PressStream {
  SensorConfig config;
  Pipeline pipeline;
  std::vector<Frame> frames;

  explicit PressStream(double shear = 0.0, SensorConfig sensor = DefaultSensorConfig())
      : config(std::move(sensor)), pipeline(config, SyntheticCompliance(config), RestMarkerPositions(config), Options(config)) {
    // H's values do not change the cost; the synthetic one saves building the FEM here.
    const std::vector<Eigen::Vector3d> rest = RestMarkerPositions(config);
    const MarkerImageRenderer renderer(config);
    for (int k = 0; k < 16; ++k) {
      std::vector<Eigen::Vector3d> markers = rest;
      const double depth_mm = 0.6 * (0.5 - 0.5 * std::cos(2 * M_PI * k / 16.0));
      for (auto& p : markers) {
        const double bump = depth_mm * std::exp(-p.head<2>().squaredNorm() / 18.0);
        p.z() -= bump;
        p.x() += shear * bump;  // the surface dragged along x under the press
      }
      frames.push_back({renderer.Render(markers, k), 0.0, k});
    }
    TactileFrame out;
    for (int k = 0; k < 2; ++k) pipeline.Process({renderer.Render(rest, 100 + k), 0.0, k}, out);
  }
  // What `tac3d run` runs for the sensor (an imported one: no contact-support re-solve), with
  // the shortest reference.
  static PipelineOptions Options(const SensorConfig& sensor) {
    PipelineOptions options = DefaultPipelineOptions(sensor);
    options.reference_frames = 2;
    return options;
  }
};

// Image to TactileFrame over the stream's frames, in turn.
void ProcessFrames(benchmark::State& state, PressStream& stream) {
  TactileFrame out;
  size_t k = 0;
  for (auto _ : state) {
    stream.pipeline.Process(stream.frames[k++ % stream.frames.size()], out);
    benchmark::DoNotOptimize(out.resultant_force_n);
  }
  if (out.has(FrameFlag::kInitializing) || out.has(FrameFlag::kMarkersLost)) state.SkipWithError("bad frame");
}

void BM_ImageToTactileFrame(benchmark::State& state) {
  PressStream stream(state.range(0) ? 0.4 : 0.0);
  ProcessFrames(state, stream);
}
BENCHMARK(BM_ImageToTactileFrame)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// The same chain at 1920 x 1080 on HDL1-0001 (the vendor's camera model: tracking seeded from
// its reference pixels, VendorStereo's refracted rays), the press straight down.
void BM_VendorImageToTactileFrame(benchmark::State& state) {
  PressStream stream(0.0, Hdl1Sensor());
  ProcessFrames(state, stream);
}
BENCHMARK(BM_VendorImageToTactileFrame)->Unit(benchmark::kMicrosecond);

// A 1920 x 1080 MJPEG frame (one JPEG, quality 90, of a twin image of HDL1-0001) decoded whole
// to the pipeline's 8-bit grey image: /0 as OpenCV's camera capture does it (BGR, then
// cvtColor), /1 OpenCV's luma only (cv::IMREAD_GRAYSCALE), /2 the camera source's decoder
// (JpegGreyDecoder).
void BM_DecodeMjpeg1080p(benchmark::State& state) {
  const SensorConfig config = Hdl1Sensor();
  const cv::Mat grey = MarkerImageRenderer(config).Render(RestMarkerPositions(config), 0);
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  std::vector<std::uint8_t> jpeg;
  cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, 90});
  JpegGreyDecoder decoder;
  cv::Mat decoded, out;
  for (auto _ : state) {
    if (state.range(0) == 0) {
      decoded = cv::imdecode(jpeg, cv::IMREAD_COLOR);
      cv::cvtColor(decoded, out, cv::COLOR_BGR2GRAY);
    } else if (state.range(0) == 1) {
      out = cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
    } else if (!decoder.Decode(jpeg, 1920, 1080, std::nullopt, out).refusal.empty()) {
      state.SkipWithError("refused");
      break;
    }
    benchmark::DoNotOptimize(out.data);
  }
  if (out.cols != 1920 || out.rows != 1080) state.SkipWithError("not 1920 x 1080");
  state.counters["jpeg_kib"] = static_cast<double>(jpeg.size()) / 1024.0;
}
BENCHMARK(BM_DecodeMjpeg1080p)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

// The SlipEstimator's share: its Estimate alone on the sheared press's TactileFrames (/0), and
// on the pairs of them whose second reads partial slip (/1: the frame before, then that frame,
// so about half the calls take the friction-cone estimate of mu, its added cost).
void BM_SlipEstimate(benchmark::State& state) {
  PressStream stream(0.4);
  std::vector<TactileFrame> frames(stream.frames.size());
  for (size_t k = 0; k < frames.size(); ++k) stream.pipeline.Process(stream.frames[k], frames[k]);
  if (state.range(0) == 1) {
    std::vector<TactileFrame> partial_pairs;
    for (size_t k = 1; k < frames.size(); ++k) {
      if (frames[k].slip.state != SlipState::kPartialSlip) continue;
      partial_pairs.push_back(frames[k - 1]);
      partial_pairs.push_back(frames[k]);
    }
    if (partial_pairs.empty()) {
      state.SkipWithError("no frame of the sheared press reads partial slip");
      return;
    }
    frames = std::move(partial_pairs);
  }
  SlipEstimator estimator(stream.config.markers.rows * stream.config.markers.cols);
  size_t k = 0;
  std::array<std::int64_t, kNumSlipStates> states{};
  std::int64_t with_mu = 0;
  const bool pairs = state.range(0) == 1;
  for (auto _ : state) {
    // Each pair from a fresh history, as the pipeline's estimator saw it: else the replayed
    // pairs run on from each other's gross slip.
    if (pairs && k % 2 == 0) estimator.Reset();
    FrameSlip slip = estimator.Estimate(frames[k++ % frames.size()]);
    ++states[static_cast<int>(slip.state)];
    with_mu += !std::isnan(slip.friction);
    benchmark::DoNotOptimize(slip);
  }
  // Which paths ran: the share of frames in each state, and of those with mu.
  const double iterations = static_cast<double>(std::max<std::int64_t>(state.iterations(), 1));
  for (const SlipState s :
       {SlipState::kNone, SlipState::kStick, SlipState::kPartialSlip, SlipState::kGrossSlip}) {
    state.counters[SlipStateName(s)] = static_cast<double>(states[static_cast<int>(s)]) / iterations;
  }
  state.counters["with_mu"] = static_cast<double>(with_mu) / iterations;
}
BENCHMARK(BM_SlipEstimate)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// BM_VendorImageToTactileFrame's frames as an MJPEG camera sends them (each a JPEG of quality 90),
// decoded and processed: /0 decoding each whole (cv::imdecode's grey), /1 only the region the
// tracker reads next (JpegGreyDecoder, Pipeline::CalcReadRegion), as the camera source does;
// /2 as /1, the camera putting a restart marker after each row of MCUs (some do), so that the
// rows above the region are skipped unread.
// decoded_fraction: the share of the image's pixels decoded; entropy_decoded_rows: the share of
// its rows whose compressed data is read (down to the region's last: the entropy decoding's).
void BM_VendorMjpegToTactileFrame(benchmark::State& state) {
  PressStream stream(0.0, Hdl1Sensor());
  std::vector<std::vector<std::uint8_t>> jpegs;
  for (const Frame& frame : stream.frames) {
    cv::Mat bgr;
    cv::cvtColor(frame.image, bgr, cv::COLOR_GRAY2BGR);
    const int restart_interval = state.range(0) == 2 ? 1920 / 16 : 0;
    cv::imencode(".jpg", bgr, jpegs.emplace_back(),
                 {cv::IMWRITE_JPEG_QUALITY, 90, cv::IMWRITE_JPEG_RST_INTERVAL, restart_interval});
  }
  const bool partial = state.range(0) >= 1;
  JpegGreyDecoder decoder;
  Frame frame;
  TactileFrame out;
  double decoded_pixels = 0, entropy_rows = 0;
  size_t k = 0;
  for (auto _ : state) {
    const std::vector<std::uint8_t>& jpeg = jpegs[k % jpegs.size()];
    frame.index = static_cast<std::int64_t>(k++);
    if (partial) {
      const std::optional<cv::Rect> region = stream.pipeline.CalcReadRegion();
      const JpegDecodeResult result = decoder.Decode(jpeg, 1920, 1080, region, frame.image);
      frame.decoded_region = region ? std::optional<cv::Rect>(result.decoded) : std::nullopt;
      decoded_pixels += result.decoded.area();
      // With restart markers the rows above the region's row of MCUs are skipped.
      entropy_rows += result.decoded.br().y - (state.range(0) == 2 ? result.decoded.y / 16 * 16 : 0);
    } else {
      frame.image = cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
      decoded_pixels += frame.image.total();
      entropy_rows += frame.image.rows;
    }
    stream.pipeline.Process(frame, out);
    benchmark::DoNotOptimize(out.resultant_force_n);
  }
  if (out.has(FrameFlag::kInitializing) || out.has(FrameFlag::kMarkersLost)) state.SkipWithError("bad frame");
  const double frames = static_cast<double>(std::max<std::int64_t>(state.iterations(), 1));
  state.counters["decoded_fraction"] = decoded_pixels / (1920.0 * 1080.0 * frames);
  state.counters["entropy_decoded_rows"] = entropy_rows / (1080.0 * frames);
}
BENCHMARK(BM_VendorMjpegToTactileFrame)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

// Image -> TactileFrame -> Tac3D datagrams to 127.0.0.1, a client socket on the same machine
// taking them off its queue: frames/s end to end on loopback (no images in the stream).
void BM_ImageToUdpStream(benchmark::State& state) {
  PressStream stream;
  internal::UdpSocket client(ResolveEndpoint("127.0.0.1", 0), 1 << 22);
  UdpSenderOptions options;
  options.port = client.local_endpoint().port;
  UdpSender sender(options);
  std::array<std::uint8_t, 65536> buffer;
  Endpoint from;
  TactileFrame out;
  size_t k = 0;
  std::int64_t bytes = 0, datagrams = 0;
  for (auto _ : state) {
    stream.pipeline.Process(stream.frames[k++ % stream.frames.size()], out);
    sender.Send(out);
    while (const std::optional<std::size_t> n = client.Receive(buffer, 0.0, &from)) {
      bytes += static_cast<std::int64_t>(*n);
      ++datagrams;
    }
  }
  state.counters["frames_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()),
                                                      benchmark::Counter::kIsRate);
  state.counters["bytes_per_frame"] = static_cast<double>(bytes) / std::max<std::int64_t>(state.iterations(), 1);
  state.counters["datagrams_per_frame"] =
      static_cast<double>(datagrams) / std::max<std::int64_t>(state.iterations(), 1);
}
BENCHMARK(BM_ImageToUdpStream)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace tac3d

BENCHMARK_MAIN();
