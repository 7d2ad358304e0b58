#include "tac3d/tracking/marker_tracker.h"

#include <cmath>
#include <fstream>
#include <numeric>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tac3d/design/light_path_design.h"
#include "tac3d/imagefile/jpeg_decoder.h"
#include "tac3d/sensor/test_sensor.h"
#include "tac3d/testing/testing.h"
#include "tac3d/twin/test_renderer.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using testing::DefaultRenderer;
using testing::DefaultSensor;
using testing::RenderFilmOnly;

// Centroid accuracy on twin frames: the darkness-weighted centroid of a dot's image against
// the exact ray-traced projection of its centre. The twin's noise (about 3 DN on a film of
// 150-210 DN) alone moves a centroid by a few hundredths of a pixel; 0.1 px is a fifth of
// the smallest dot's radius, and a swapped identity would be off by a pitch (>= 9 px).
constexpr double kCentroidTolerancePx = 0.1;

// The exact pixels of the markers, per half, through a sensor's optics.
std::array<std::vector<Eigen::Vector2d>, 2> TruePixels(const SensorConfig& sensor,
                                                       const std::vector<Eigen::Vector3d>& markers) {
  const OpticalLayout layout = sensor.MakeOpticalLayout(true);
  std::array<std::vector<Eigen::Vector2d>, 2> uv;
  for (ImageHalf half : kImageHalves) {
    for (const auto& p : markers) uv[static_cast<int>(half)].push_back(ProjectPoint(layout, half, p).value());
  }
  return uv;
}

struct PixelErrors {
  int valid = 0;
  double max_px = 0.0;
  double rms_px = 0.0;
};

// Centroid errors of the valid markers against the truth (over both halves).
PixelErrors Compare(const MarkerObservation& observation,
               const std::array<std::vector<Eigen::Vector2d>, 2>& truth) {
  PixelErrors e;
  for (int h = 0; h < 2; ++h) {
    const HalfObservation& half = observation.halves[h];
    for (size_t i = 0; i < half.uv.size(); ++i) {
      if (!half.valid(static_cast<int>(i))) {
        EXPECT_TRUE(std::isnan(half.uv[i].x()) && std::isnan(half.uv[i].y())) << "invalid marker " << i;
        continue;
      }
      const double error = (half.uv[i] - truth[h][i]).norm();
      e.max_px = std::max(e.max_px, error);
      e.rms_px += error * error;
      ++e.valid;
    }
  }
  e.rms_px = std::sqrt(e.rms_px / std::max(1, e.valid));
  return e;
}

// Smooth fields on the marker layer (mm): a lateral shift with a Gaussian profile about the
// centre (shear under a rubbing object), and a dent pushed in along -z.
std::vector<Eigen::Vector3d> Sheared(const Eigen::Vector2d& shift_mm, double sigma_mm) {
  auto markers = DefaultSensor().MarkerPositions();
  for (auto& p : markers) {
    const double g = sigma_mm > 0 ? std::exp(-p.head<2>().squaredNorm() / (2 * sigma_mm * sigma_mm)) : 1.0;
    p.head<2>() += g * shift_mm;
  }
  return markers;
}

std::vector<Eigen::Vector3d> Dented(double depth_mm, double sigma_mm) {
  auto markers = DefaultSensor().MarkerPositions();
  for (auto& p : markers) p.z() -= depth_mm * std::exp(-p.head<2>().squaredNorm() / (2 * sigma_mm * sigma_mm));
  return markers;
}

TEST(MarkerTracker, UndeformedFrameEveryMarkerFoundWithinTolerance) {
  const auto markers = DefaultSensor().MarkerPositions();
  MarkerTracker tracker(DefaultSensor());
  const MarkerObservation observation = tracker.Track(DefaultRenderer().Render(markers));
  const PixelErrors e = Compare(observation, TruePixels(DefaultSensor(), markers));
  EXPECT_EQ(e.valid, 800);
  EXPECT_EQ(observation.summary.paired_markers, 400);
  EXPECT_TRUE(observation.summary.acquired);
  EXPECT_FALSE(observation.summary.grid_lost);
  EXPECT_LT(e.max_px, kCentroidTolerancePx);
  std::printf("undeformed: rms %.4f px, max %.4f px\n", e.rms_px, e.max_px);
}

// A real sensor is not the nominal one: the twin's camera is turned 1 deg about its axis and
// moved 0.3 mm sideways; the tracker still indexes against the nominal sensor.
TEST(MarkerTracker, AcquiresGridOfAMiscalibratedSensor) {
  SensorConfig truth = DefaultSensor();
  truth.camera.sensor_from_cam.rotate(Eigen::AngleAxisd(DegToRad(1.0), Eigen::Vector3d::UnitZ()));
  truth.camera.sensor_from_cam.pretranslate(Eigen::Vector3d(0.3, -0.2, 0.0));
  const MarkerImageRenderer renderer(truth);
  const auto markers = DefaultSensor().MarkerPositions();
  const auto true_uv = TruePixels(truth, markers);
  MarkerTracker tracker(DefaultSensor());
  // How far the real grid is from the nominal one.
  double offset = 0;
  for (ImageHalf h : kImageHalves) {
    for (size_t i = 0; i < markers.size(); ++i) {
      offset = std::max(offset, (true_uv[static_cast<int>(h)][i] - tracker.nominal_uv(h)[i]).norm());
    }
  }
  EXPECT_GT(offset, 4.0);
  const MarkerObservation observation = tracker.Track(renderer.Render(markers));
  const PixelErrors e = Compare(observation, true_uv);
  EXPECT_EQ(e.valid, 800);
  EXPECT_LT(e.max_px, kCentroidTolerancePx);
  std::printf("miscalibrated by up to %.1f px: rms %.4f px, max %.4f px\n", offset, e.rms_px, e.max_px);
}

// Acquisition of already deformed frames: the affine fit cannot follow a dent or a shear, the
// growth from matched neighbours does.
TEST(MarkerTracker, AcquiresShearedAndDentedFrames) {
  const std::vector<std::pair<const char*, std::vector<Eigen::Vector3d>>> cases = {
      {"uniform shear 0.5 mm", Sheared({0.5, 0.0}, 0.0)},
      {"local shear 1 mm", Sheared({0.0, 1.0}, 4.0)},
      {"dent 1 mm", Dented(1.0, 4.0)},
  };
  for (const auto& [name, markers] : cases) {
    MarkerTracker tracker(DefaultSensor());
    const MarkerObservation observation = tracker.Track(DefaultRenderer().Render(markers));
    const PixelErrors e = Compare(observation, TruePixels(DefaultSensor(), markers));
    EXPECT_EQ(e.valid, 800) << name;
    EXPECT_LT(e.max_px, kCentroidTolerancePx) << name;
    std::printf("%s: rms %.4f px, max %.4f px\n", name, e.rms_px, e.max_px);
  }
}


// A shear that grows and shrinks by up to one marker pitch (1.27 mm) per frame at its
// centre, to two pitches either way (a strain of up to 0.26), turning back abruptly:
// identities are kept by tracking alone (no re-acquisition).
TEST(MarkerTracker, SequenceMovingUpToOnePitchPerFrameKeepsIdentities) {
  const double pitch = DefaultSensor().markers.pitch_mm;
  const std::vector<double> amplitude_pitches = {0, 0.5, 1.5, 2, 1, 0, -1, -2, -1, 0};
  const Eigen::Vector2d direction(std::cos(DegToRad(30)), std::sin(DegToRad(30)));
  MarkerTracker tracker(DefaultSensor());
  MarkerObservation observation;
  for (size_t k = 0; k < amplitude_pitches.size(); ++k) {
    const auto markers = Sheared(amplitude_pitches[k] * pitch * direction, 6.0);
    tracker.Track(DefaultRenderer().Render(markers, k), observation);
    const PixelErrors e = Compare(observation, TruePixels(DefaultSensor(), markers));
    EXPECT_EQ(e.valid, 800) << "frame " << k;
    EXPECT_LT(e.max_px, kCentroidTolerancePx) << "frame " << k;
    EXPECT_EQ(observation.summary.acquired, k == 0) << "frame " << k;
    std::printf("frame %zu, shear %+.1f pitch: rms %.4f px, max %.4f px\n", k, amplitude_pitches[k],
                e.rms_px, e.max_px);
  }
}

// The whole grid jumps by one pitch between two frames (in x, back, in y, diagonally): inside
// the grid that looks like no motion with every identity one off; the border tells. Every
// marker keeps its identity (a swapped one would be a pitch, >= 9 px, off) or is flagged.
TEST(MarkerTracker, WholeGridJumpOfOnePitchIsNotMisindexed) {
  const double pitch = DefaultSensor().markers.pitch_mm;
  for (const Eigen::Vector2d& jump : {Eigen::Vector2d(pitch, 0), Eigen::Vector2d(-pitch, 0),
                                      Eigen::Vector2d(0, pitch), Eigen::Vector2d(pitch, pitch)}) {
    MarkerTracker tracker(DefaultSensor());
    tracker.Track(DefaultRenderer().Render(DefaultSensor().MarkerPositions(), 8));
    auto markers = DefaultSensor().MarkerPositions();
    for (auto& p : markers) p.head<2>() += jump;
    const MarkerObservation observation = tracker.Track(DefaultRenderer().Render(markers, 9));
    const PixelErrors e = Compare(observation, TruePixels(DefaultSensor(), markers));
    EXPECT_LT(e.max_px, kCentroidTolerancePx) << "jump " << jump.transpose();
    EXPECT_TRUE(observation.summary.acquired) << "jump " << jump.transpose();
    std::printf("jump (%+.2f, %+.2f) mm: %d valid, rms %.4f px, max %.4f px\n", jump.x(), jump.y(),
                e.valid, e.rms_px, e.max_px);
  }
}

// A border side hidden (not a jump: nothing appears beyond the opposite side) is flagged
// while tracking goes on, without re-acquisition.
TEST(MarkerTracker, HiddenBorderSideIsNotTakenForAJump) {
  const auto markers = DefaultSensor().MarkerPositions();
  const auto truth = TruePixels(DefaultSensor(), markers);
  const int cols = DefaultSensor().markers.cols;
  const cv::Mat film = RenderFilmOnly();
  cv::Mat image = DefaultRenderer().Render(markers, 10);
  for (int h = 0; h < 2; ++h) {
    for (int i = 0; i < static_cast<int>(markers.size()); i += cols) {
      cv::Mat mask = cv::Mat::zeros(image.size(), CV_8UC1);
      cv::circle(mask, cv::Point(std::lround(truth[h][i].x()), std::lround(truth[h][i].y())), 5, 255, -1);
      film.copyTo(image, mask);
    }
  }
  MarkerTracker tracker(DefaultSensor());
  tracker.Track(DefaultRenderer().Render(markers, 11));
  const MarkerObservation observation = tracker.Track(image);
  EXPECT_FALSE(observation.summary.acquired);
  const PixelErrors e = Compare(observation, truth);
  EXPECT_EQ(e.valid, 800 - 2 * DefaultSensor().markers.rows);
  EXPECT_LT(e.max_px, kCentroidTolerancePx);
}

// Markers hidden (painted over with the film), in the first frame and while tracking.
TEST(MarkerTracker, TenPercentOfMarkersHiddenAreFlaggedAndTheRestMeasured) {
  const auto markers = DefaultSensor().MarkerPositions();
  const auto truth = TruePixels(DefaultSensor(), markers);
  const cv::Mat film = RenderFilmOnly();
  std::mt19937 rng(testing::kRandomSeed);
  std::vector<int> order(markers.size());
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  const std::vector<int> hidden(order.begin(), order.begin() + 40);
  cv::Mat image = DefaultRenderer().Render(markers, 1);
  for (int h = 0; h < 2; ++h) {
    for (int i : hidden) {
      cv::Mat mask = cv::Mat::zeros(image.size(), CV_8UC1);
      cv::circle(mask, cv::Point(std::lround(truth[h][i].x()), std::lround(truth[h][i].y())), 5, 255, -1);
      film.copyTo(image, mask);
    }
  }
  MarkerTracker tracker(DefaultSensor());
  for (const bool first_frame : {true, false}) {
    if (!first_frame) {
      tracker.Reset();
      tracker.Track(DefaultRenderer().Render(markers, 2));
    }
    const MarkerObservation observation = tracker.Track(image);
    for (int h = 0; h < 2; ++h) {
      for (int i : hidden) {
        EXPECT_EQ(observation.halves[h].state[i], MarkerState::kNotFound) << "marker " << i;
      }
      EXPECT_EQ(observation.halves[h].valid_markers, 360);
      EXPECT_FALSE(observation.halves[h].grid_lost);
      // The viewer draws a hidden marker where the tracker takes it to be: within 1 px of its
      // true pixel (a pitch is at least 9 px); a measured one at its centroid.
      const HalfObservation& half = observation.halves[h];
      ASSERT_EQ(half.estimate_uv.size(), markers.size());
      for (int i : hidden) EXPECT_LT((half.estimate_uv[i] - truth[h][i]).norm(), 1.0) << "marker " << i;
      for (int i = 0; i < static_cast<int>(markers.size()); ++i) {
        if (half.valid(i)) {
          EXPECT_EQ(half.estimate_uv[i], half.uv[i]) << "marker " << i;
        }
      }
    }
    const PixelErrors e = Compare(observation, truth);
    EXPECT_EQ(e.valid, 720);
    EXPECT_LT(e.max_px, kCentroidTolerancePx);
    EXPECT_EQ(observation.summary.acquired, first_frame);
  }
}

// Five dark specks (dust, a scratch) drawn into a frame, three between two markers, two
// overlapping a marker's dot. Every marker a speck does not touch is measured as usual. A
// speck beside a dot merges with it and pulls its centroid off: flagged. One on top of a
// dot makes a slightly bigger dot whose centroid it pulls by about a pixel: that cannot be
// told from the shape, so it may stay valid, but never as another marker.
TEST(MarkerTracker, FiveSpuriousBlobsAreFlaggedAndTheRestMeasured) {
  const auto markers = DefaultSensor().MarkerPositions();
  const auto truth = TruePixels(DefaultSensor(), markers);
  MarkerTracker tracker(DefaultSensor());
  std::mt19937 rng(testing::kRandomSeed);
  std::array<std::vector<Eigen::Vector2d>, 2> specks;
  cv::Mat image = DefaultRenderer().Render(markers, 3);
  for (int k = 0; k < 5; ++k) {
    const int h = k % 2;
    const auto& nominal = tracker.nominal_uv(kImageHalves[h]);
    std::uniform_int_distribution<int> pick(0, static_cast<int>(nominal.size()) - 2);
    const int i = pick(rng);
    const Eigen::Vector2d p = k < 3 ? Eigen::Vector2d(0.5 * (nominal[i] + nominal[i + 1]))
                                    : Eigen::Vector2d(nominal[i] + Eigen::Vector2d(1.5, 0));
    specks[h].push_back(p);
    cv::circle(image, cv::Point(std::lround(p.x()), std::lround(p.y())), 3, 30, -1, cv::LINE_AA);
  }
  for (const bool first_frame : {true, false}) {
    if (!first_frame) {
      tracker.Reset();
      tracker.Track(DefaultRenderer().Render(markers, 4));
    }
    const MarkerObservation observation = tracker.Track(image);
    int touched = 0, flagged = 0;
    for (int h = 0; h < 2; ++h) {
      const HalfObservation& half = observation.halves[h];
      const auto& pitch = tracker.pitch_px(kImageHalves[h]);
      for (size_t i = 0; i < markers.size(); ++i) {
        double nearest = 1e9;
        for (const auto& s : specks[h]) nearest = std::min(nearest, (truth[h][i] - s).norm());
        const double error = half.valid(i) ? (half.uv[i] - truth[h][i]).norm() : 0.0;
        if (nearest > 0.6 * pitch[i]) {
          EXPECT_TRUE(half.valid(i)) << "half " << h << " marker " << i;
          EXPECT_LT(error, kCentroidTolerancePx) << "half " << h << " marker " << i;
          continue;
        }
        ++touched;
        flagged += !half.valid(i);
        EXPECT_LT(error, 1.5) << "half " << h << " marker " << i;
      }
    }
    EXPECT_GE(flagged, 3);  // at least one per speck between two dots
    std::printf("5 specks (%s): %d markers touched, %d flagged, %d valid\n",
                first_frame ? "acquisition" : "tracking", touched, flagged,
                observation.halves[0].valid_markers + observation.halves[1].valid_markers);
  }
}

void ExpectGridLost(const MarkerObservation& observation) {
  EXPECT_TRUE(observation.summary.grid_lost);
  EXPECT_EQ(observation.summary.paired_markers, 0);
  EXPECT_EQ(observation.summary.invalid_markers, 800);
  for (const HalfObservation& half : observation.halves) {
    EXPECT_TRUE(half.grid_lost);
    EXPECT_EQ(half.state_counts[static_cast<int>(MarkerState::kGridLost)], 400);
    for (const auto& uv : half.uv) EXPECT_TRUE(std::isnan(uv.x()));
  }
}

TEST(MarkerTracker, PureNoiseFrameIsFlaggedAndTrackingRecovers) {
  const auto markers = DefaultSensor().MarkerPositions();
  MarkerTracker tracker(DefaultSensor());
  tracker.Track(DefaultRenderer().Render(markers, 5));
  cv::Mat noise(480, 640, CV_8UC1);
  cv::RNG rng(testing::kRandomSeed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  ExpectGridLost(tracker.Track(noise));
  ExpectGridLost(tracker.Track(noise));  // as the first frame after a loss, too
  const MarkerObservation back = tracker.Track(DefaultRenderer().Render(markers, 6));
  EXPECT_TRUE(back.summary.acquired);
  EXPECT_EQ(back.summary.paired_markers, 400);
  EXPECT_LT(Compare(back, TruePixels(DefaultSensor(), markers)).max_px, kCentroidTolerancePx);
}

TEST(MarkerTracker, BlackFrameIsFlaggedAndTrackingRecovers) {
  const auto markers = DefaultSensor().MarkerPositions();
  MarkerTracker tracker(DefaultSensor());
  const MarkerObservation black = tracker.Track(cv::Mat::zeros(480, 640, CV_8UC1));
  ExpectGridLost(black);
  // With no grid, every marker is taken to be at its nominal pixel (where the viewer draws it).
  for (ImageHalf h : kImageHalves) EXPECT_EQ(black.half(h).estimate_uv, tracker.nominal_uv(h));
  const MarkerObservation back = tracker.Track(DefaultRenderer().Render(markers, 7));
  EXPECT_TRUE(back.summary.acquired);
  EXPECT_EQ(back.summary.paired_markers, 400);
  EXPECT_LT(Compare(back, TruePixels(DefaultSensor(), markers)).max_px, kCentroidTolerancePx);
  ExpectGridLost(tracker.Track(cv::Mat::zeros(480, 640, CV_8UC1)));  // while tracking
}

// A frame as an MJPEG camera sends it: colour JPEG (YCbCr 4:2:0), quality 90.
std::vector<std::uint8_t> CompressAsCamera(const cv::Mat& grey) {
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  std::vector<std::uint8_t> jpeg;
  EXPECT_TRUE(cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, 90}));
  return jpeg;
}

void ExpectSameMarkers(const MarkerObservation& a, const MarkerObservation& b, size_t frame) {
  for (int h = 0; h < 2; ++h) {
    EXPECT_EQ(a.halves[h].state, b.halves[h].state) << "frame " << frame;
    for (size_t i = 0; i < a.halves[h].uv.size(); ++i) {
      if (!a.halves[h].valid(static_cast<int>(i))) continue;
      ASSERT_EQ(a.halves[h].uv[i], b.halves[h].uv[i]) << "frame " << frame << ", half " << h << ", marker " << i;
    }
  }
}

// The shearing sequence (up to a pitch a frame), JPEG-compressed: decoding only the tracker's read
// region gives the markers a whole decode gives, to the last bit; the first frame, and the one
// after the grid is lost (a dark frame), are decoded whole.
TEST(MarkerTracker, DecodingOnlyTheReadRegionMeasuresTheSameMarkers) {
  const double pitch = DefaultSensor().markers.pitch_mm;
  const std::vector<double> amplitude_pitches = {0, 0.5, 1.5, 2, 1, 0, -1, -2, -1, 0};
  const Eigen::Vector2d direction(std::cos(DegToRad(30)), std::sin(DegToRad(30)));
  std::vector<std::vector<std::uint8_t>> jpegs;
  for (size_t k = 0; k < amplitude_pitches.size(); ++k) {
    jpegs.push_back(CompressAsCamera(DefaultRenderer().Render(Sheared(amplitude_pitches[k] * pitch * direction, 6.0), k)));
  }
  jpegs.insert(jpegs.begin() + 5, CompressAsCamera(cv::Mat(480, 640, CV_8UC1, cv::Scalar(3))));  // the light off
  MarkerTracker whole_tracker(DefaultSensor()), partial_tracker(DefaultSensor());
  JpegGreyDecoder decoder;
  cv::Mat whole, partial;
  MarkerObservation expected, observation;
  int partial_frames = 0;
  for (size_t k = 0; k < jpegs.size(); ++k) {
    ASSERT_EQ(decoder.Decode(jpegs[k], 640, 480, std::nullopt, whole).refusal, "");
    whole_tracker.Track(whole, expected);
    const std::optional<cv::Rect> region = partial_tracker.CalcReadRegion();
    // Whole: the first frame, and the one after the dark frame.
    EXPECT_EQ(!region, k == 0 || k == 6) << "frame " << k;
    const JpegDecodeResult decoded = decoder.Decode(jpegs[k], 640, 480, region, partial);
    ASSERT_EQ(decoded.refusal, "");
    if (region) {
      ++partial_frames;
      EXPECT_LT(decoded.decoded.area(), 0.9 * 640 * 480) << "frame " << k << ": " << decoded.decoded;
    }
    partial_tracker.Track(partial, observation, region ? std::optional<cv::Rect>(decoded.decoded) : std::nullopt);
    if (k == 5) {
      // Lost in a partly decoded frame: not searched for in it, so the next one is decoded whole.
      ExpectGridLost(observation);
      EXPECT_FALSE(observation.summary.acquired);
      continue;
    }
    EXPECT_EQ(observation.summary.paired_markers, 400) << "frame " << k;
    EXPECT_EQ(observation.summary.acquired, k == 0 || k == 6) << "frame " << k;
    ExpectSameMarkers(expected, observation, k);
  }
  EXPECT_EQ(partial_frames, 9);
}

// The camera path's decoder (an exact inverse DCT) and OpenCV's (libjpeg's integer one) differ
// by a grey level in a few pixels: the markers they give agree far inside the tracker's noise.
TEST(MarkerTracker, TheCameraDecoderAndOpenCvsGiveTheSameMarkersWithinNoise) {
  const double pitch = DefaultSensor().markers.pitch_mm;
  MarkerTracker ours_tracker(DefaultSensor()), opencv_tracker(DefaultSensor());
  JpegGreyDecoder decoder;
  cv::Mat ours;
  MarkerObservation from_ours, from_opencv;
  double largest_px = 0;
  for (int k = 0; k < 6; ++k) {
    const std::vector<std::uint8_t> jpeg =
        CompressAsCamera(DefaultRenderer().Render(Sheared(0.3 * k * pitch * Eigen::Vector2d::UnitX(), 6.0), k));
    ASSERT_EQ(decoder.Decode(jpeg, 640, 480, std::nullopt, ours).refusal, "");
    ours_tracker.Track(ours, from_ours);
    opencv_tracker.Track(cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE), from_opencv);
    for (int h = 0; h < 2; ++h) {
      ASSERT_EQ(from_ours.halves[h].state, from_opencv.halves[h].state) << "frame " << k;
      for (size_t i = 0; i < from_ours.halves[h].uv.size(); ++i) {
        if (!from_ours.halves[h].valid(static_cast<int>(i))) continue;
        largest_px = std::max(largest_px, (from_ours.halves[h].uv[i] - from_opencv.halves[h].uv[i]).norm());
      }
    }
  }
  EXPECT_LT(largest_px, 0.01);  // 0.005 px here; tracking's RMS error against truth is 0.018 px
}

TEST(MarkerTracker, ImageOfWrongSizeTypeOrEmptyThrows) {
  MarkerTracker tracker(DefaultSensor());
  EXPECT_THROW(tracker.Track(cv::Mat::zeros(240, 320, CV_8UC1)), Error);
  EXPECT_THROW(tracker.Track(cv::Mat::zeros(480, 640, CV_8UC3)), Error);
  EXPECT_THROW(tracker.Track(cv::Mat::zeros(480, 640, CV_16UC1)), Error);
  EXPECT_THROW(tracker.Track(cv::Mat()), Error);
  // A bad frame changes nothing: the next good one is acquired as usual.
  EXPECT_EQ(tracker.Track(DefaultRenderer().Render(DefaultSensor().MarkerPositions())).summary.paired_markers, 400);
}

TEST(MarkerTracker, CorruptPngFileThrows) {
  std::vector<std::uint8_t> png;
  cv::imencode(".png", DefaultRenderer().Render(DefaultSensor().MarkerPositions()), png);
  // Keep the signature and header, garble the compressed data, cut the end off.
  for (size_t k = 64; k < png.size(); k += 7) png[k] ^= 0x5A;
  png.resize(png.size() / 2);
  const std::string path = testing::MakeTempDir("corrupt") + "/frame.png";
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(png.data()), png.size());
  const cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
  ASSERT_TRUE(image.empty());
  MarkerTracker tracker(DefaultSensor());
  EXPECT_THROW(tracker.Track(image), Error);
  EXPECT_THROW(tracker.Track(cv::imdecode(png, cv::IMREAD_GRAYSCALE)), Error);
}

TEST(MarkerTracker, InvalidOptionsOrSensorThrow) {
  MarkerTrackerOptions options;
  options.search_radius = 0.6;
  EXPECT_THROW(MarkerTracker(DefaultSensor(), options), Error);
  options = {};
  options.min_valid_fraction = 0.0;
  EXPECT_THROW(MarkerTracker(DefaultSensor(), options), Error);
  options = {};
  options.blob.background_kernel_px = 10;
  EXPECT_THROW(MarkerTracker(DefaultSensor(), options), Error);
  options = {};
  options.index.match_gate = 0.5;
  EXPECT_THROW(MarkerTracker(DefaultSensor(), options), Error);
  EXPECT_THROW(MarkerTracker(SensorConfig{}), Error);  // no mirrors designed
}

}  // namespace
}  // namespace tac3d
