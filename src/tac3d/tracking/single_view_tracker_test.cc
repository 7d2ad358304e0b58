#include "tac3d/tracking/single_view_tracker.h"

#include <fstream>

#include <cmath>
#include <filesystem>
#include <random>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "tac3d/source/frame_source.h"
#include "tac3d/tracking/single_view_track.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"
#include "tac3d/vendor_formats/test_vendor_folder.h"

// A named namespace: the test program compiles test files together (unity batches), where
// another file's anonymous-namespace helpers would clash with these.
namespace tac3d::single_view_test {

// As marker_tracker_test: a centroid is off by a few hundredths of a pixel from the noise
// alone; a swapped identity would be a pitch (30 px here) off.
constexpr double kCentroidTolerancePx = 0.1;

constexpr int kRows = 8, kCols = 10;
constexpr double kPitchPx = 30.0, kDotRadiusPx = 4.0;
const cv::Size kImageSize(320, 240);
// mini_example.avi's frames without contact (docs/real-images.md: where the markers' mean
// displacement from frame 0 stays flat).
constexpr std::pair<int, int> kRestBefore = {0, 56}, kRestAfter = {210, 218};

// A GelSight-like grid: 8 x 10 dots 30 px apart, row 0 at the top.
std::vector<Eigen::Vector2d> GridCentres(const Eigen::Vector2d& first) {
  std::vector<Eigen::Vector2d> centres;
  for (int r = 0; r < kRows; ++r) {
    for (int c = 0; c < kCols; ++c) centres.push_back(first + kPitchPx * Eigen::Vector2d(c, r));
  }
  return centres;
}

// A press: each dot pushed outward from `at` by up to `depth_px` (a Gaussian of 50 px).
std::vector<Eigen::Vector2d> Pressed(std::vector<Eigen::Vector2d> centres, const Eigen::Vector2d& at,
                                     double depth_px) {
  for (auto& p : centres) {
    const Eigen::Vector2d d = p - at;
    p += depth_px * std::exp(-d.squaredNorm() / (2 * 50.0 * 50.0)) * d / 50.0;
  }
  return centres;
}

// A single-view camera frame as a GelSight shows one, with truth: dark dots (exact area
// coverage by 8 x 8 supersampling) on a film lit unevenly by coloured light (blue from the
// left, red from the right, green from the top), blurred by the lens, with 2 DN of noise,
// then converted to grey as the frame sources do (BT.601 luma). `hidden`: dots not drawn.
cv::Mat RenderFrame(const std::vector<Eigen::Vector2d>& centres, std::uint64_t seed,
                    const std::vector<int>& hidden = {}) {
  cv::Mat coverage(kImageSize, CV_32F, cv::Scalar(0));
  for (size_t k = 0; k < centres.size(); ++k) {
    if (std::find(hidden.begin(), hidden.end(), static_cast<int>(k)) != hidden.end()) continue;
    const Eigen::Vector2d& c = centres[k];
    for (int y = static_cast<int>(c.y() - kDotRadiusPx) - 1; y <= c.y() + kDotRadiusPx + 1; ++y) {
      for (int x = static_cast<int>(c.x() - kDotRadiusPx) - 1; x <= c.x() + kDotRadiusPx + 1; ++x) {
        if (x < 0 || y < 0 || x >= kImageSize.width || y >= kImageSize.height) continue;
        int inside = 0;
        for (int sy = 0; sy < 8; ++sy) {
          for (int sx = 0; sx < 8; ++sx) {
            const Eigen::Vector2d p(x - 0.5 + (sx + 0.5) / 8, y - 0.5 + (sy + 0.5) / 8);
            inside += (p - c).squaredNorm() <= kDotRadiusPx * kDotRadiusPx;
          }
        }
        coverage.at<float>(y, x) += inside / 64.0f;
      }
    }
  }
  std::mt19937_64 rng(testing::kRandomSeed + seed);
  std::normal_distribution<float> noise(0.0f, 2.0f);
  cv::Mat bgr(kImageSize, CV_32FC3);
  for (int y = 0; y < kImageSize.height; ++y) {
    for (int x = 0; x < kImageSize.width; ++x) {
      const float u = x / float(kImageSize.width), v = y / float(kImageSize.height);
      const cv::Vec3f film(60 + 150 * (1 - u), 50 + 90 * (1 - v), 30 + 120 * u);  // B, G, R
      bgr.at<cv::Vec3f>(y, x) = film * (1.0f - 0.85f * std::min(1.0f, coverage.at<float>(y, x)));
    }
  }
  cv::GaussianBlur(bgr, bgr, cv::Size(0, 0), 0.7);
  for (auto it = bgr.begin<cv::Vec3f>(); it != bgr.end<cv::Vec3f>(); ++it) {
    for (int ch = 0; ch < 3; ++ch) (*it)[ch] += noise(rng);
  }
  cv::Mat bgr8, grey;
  bgr.convertTo(bgr8, CV_8UC3);
  cv::cvtColor(bgr8, grey, cv::COLOR_BGR2GRAY);
  return grey;
}

// RMS of the valid markers' errors; every marker must be valid but those in `not_valid`.
double RmsError(const GridObservation& o, const std::vector<Eigen::Vector2d>& truth,
                const std::vector<int>& not_valid = {}) {
  double sum = 0;
  int valid = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    const bool expected = std::find(not_valid.begin(), not_valid.end(), static_cast<int>(i)) == not_valid.end();
    EXPECT_EQ(o.valid(static_cast<int>(i)), expected) << "marker " << i << ": " << ToString(o.state[i]);
    if (!o.valid(static_cast<int>(i))) continue;
    sum += (o.uv[i] - truth[i]).squaredNorm();
    ++valid;
  }
  return std::sqrt(sum / std::max(1, valid));
}

TEST(SingleViewTracker, FindsTheGridUnderColouredUnevenLightAndMeasuresEveryMarker) {
  const auto truth = GridCentres({25.3, 17.8});
  SingleViewTracker tracker(RenderFrame(truth, 0), 0, 0);
  ASSERT_EQ(tracker.grid().rows, kRows);
  ASSERT_EQ(tracker.grid().cols, kCols);
  EXPECT_NEAR(tracker.grid().column_step_px.x(), kPitchPx, 0.1);
  EXPECT_NEAR(tracker.grid().row_step_px.y(), kPitchPx, 0.1);
  const double rms = RmsError(tracker.reference(), truth);
  EXPECT_LT(rms, kCentroidTolerancePx);
  std::printf("reference: rms %.4f px\n", rms);
}

// A press growing to 12 px (0.4 pitch) at 3 px a frame and released; in one frame a dot is
// hidden (the object's texture over it): flagged, estimated from its neighbours, re-found.
TEST(SingleViewTracker, FollowsAPressAndFlagsAHiddenMarker) {
  const auto rest = GridCentres({25.3, 17.8});
  SingleViewTracker tracker(RenderFrame(rest, 0), kRows, kCols);
  const std::vector<double> depths = {3, 6, 9, 12, 12, 9, 6, 3, 0};
  const int hidden = 4 * kCols + 4;
  GridObservation o;
  for (size_t k = 0; k < depths.size(); ++k) {
    const auto truth = Pressed(rest, {160, 120}, depths[k]);
    const bool hide = k == 3;
    tracker.Track(RenderFrame(truth, k + 1, hide ? std::vector<int>{hidden} : std::vector<int>{}), o);
    const double rms = RmsError(o, truth, hide ? std::vector<int>{hidden} : std::vector<int>{});
    EXPECT_LT(rms, kCentroidTolerancePx) << "frame " << k;
    EXPECT_FALSE(o.acquired) << "frame " << k;
    if (hide) {
      EXPECT_EQ(o.state[hidden], MarkerState::kNotFound);
      EXPECT_TRUE(o.supported[hidden]);
      // Its neighbours' mean displacement, in a press whose strain there reaches 0.24: within
      // a tenth of the pitch, well inside the gate (0.2 pitch) that finds it again.
      EXPECT_LT((o.estimate_uv[hidden] - truth[hidden]).norm(), 0.1 * kPitchPx);
    }
    std::printf("frame %zu, press %.0f px: rms %.4f px\n", k, depths[k], rms);
  }
}

// The top row's dots are cut by the image's border: flagged, not measured with a centroid
// pulled inward, and placed by the lattice.
TEST(SingleViewTracker, MarkerCutByTheBorderIsFlaggedNotMeasured) {
  const auto truth = GridCentres({25.3, 1.5});
  SingleViewTracker tracker(RenderFrame(truth, 0), kRows, kCols);
  std::vector<int> top_row(kCols);
  for (int c = 0; c < kCols; ++c) top_row[c] = c;
  EXPECT_LT(RmsError(tracker.reference(), truth, top_row), kCentroidTolerancePx);
  for (int c : top_row) {
    EXPECT_EQ(tracker.reference().state[c], MarkerState::kPartlyOutside) << ToString(tracker.reference().state[c]);
    EXPECT_LT((tracker.reference().estimate_uv[c] - truth[c]).norm(), 0.5) << "marker " << c;
  }
}

// The grid placed so that its first or last row or column is cut by each border in turn: its
// dots' centres 1 px inside the image's edge (more than half of each dot seen) or 2 px outside
// it (a sliver of 2 px of a dot of 4 px radius), a blank lattice place beyond the opposite side
// (where a grid registered to the whole dots alone could as well be placed). In the reference
// frame and in a tracked frame moved by (0.6, -0.4) px: every whole dot measured within 0.1 px,
// every cut one flagged kPartlyOutside and placed at its own dot, within 0.5 px (along the
// border its own centroid, across it its neighbours' placement): none a pitch off.
TEST(SingleViewTracker, EveryVisibleMarkerFoundWhenARowOrColumnIsCutAtEachBorder) {
  const double right = kImageSize.width - 0.5 - (kCols - 1) * kPitchPx;
  const double bottom = kImageSize.height - 0.5 - (kRows - 1) * kPitchPx;
  for (const double inside : {1.0, -2.0}) {
    const std::vector<std::pair<const char*, Eigen::Vector2d>> cases = {{"left", {-0.5 + inside, 17.8}},
                                                                        {"right", {right - inside, 17.8}},
                                                                        {"top", {25.3, -0.5 + inside}},
                                                                        {"bottom", {25.3, bottom - inside}}};
    for (const auto& [border, first] : cases) {
      const std::string what = fmt::format("{} border, cut dots' centres {} px inside", border, inside);
      const auto rest = GridCentres(first);
      SingleViewTracker tracker(RenderFrame(rest, 0), kRows, kCols);
      GridObservation o = tracker.reference();
      for (int frame = 0; frame < 2; ++frame) {
        std::vector<Eigen::Vector2d> truth = rest;
        if (frame == 1) {
          for (auto& p : truth) p += Eigen::Vector2d(0.6, -0.4);
          tracker.Track(RenderFrame(truth, 1), o);
        }
        int cut = 0;
        for (int i = 0; i < kRows * kCols; ++i) {
          const Eigen::Vector2d& p = truth[i];
          const bool whole = p.x() - kDotRadiusPx > 0.5 && p.y() - kDotRadiusPx > 0.5 &&
                             p.x() + kDotRadiusPx < kImageSize.width - 1.5 &&
                             p.y() + kDotRadiusPx < kImageSize.height - 1.5;
          if (whole) {
            EXPECT_TRUE(o.valid(i)) << what << ", frame " << frame << ", marker " << i << ": " << ToString(o.state[i]);
            if (o.valid(i)) {
              EXPECT_LT((o.uv[i] - p).norm(), kCentroidTolerancePx) << what << ", marker " << i;
            }
            continue;
          }
          ++cut;
          EXPECT_EQ(o.state[i], MarkerState::kPartlyOutside) << what << ", frame " << frame << ", marker " << i << ": "
                                                             << ToString(o.state[i]);
          EXPECT_TRUE(o.supported[i]) << what << ", marker " << i;
          EXPECT_LT((o.estimate_uv[i] - p).norm(), 0.5) << what << ", frame " << frame << ", marker " << i;
        }
        EXPECT_EQ(cut, std::string(border) == "left" || std::string(border) == "right" ? kRows : kCols) << what;
      }
    }
  }
}

// A Tac3D half is a GridTracker over the half's columns: a column of dots cut by the half's
// border (its centres 0.2 px inside it) is flagged kPartlyOutside, never valid (a stereo pair
// must not triangulate a pulled centroid), and placed at its own dot within 0.5 px, in the
// acquired frame and in a tracked one moved by (-0.5, 0.7) px.
TEST(GridTracker, DotsCutByAHalfsBorderAreFlaggedAndPlacedAtTheirDots) {
  const auto rest = GridCentres({25.3, 17.8});
  constexpr int kHalfCols = 5;
  const cv::Rect half(0, 0, static_cast<int>(std::lround(rest[kHalfCols - 1].x() + 0.2)), kImageSize.height);
  std::vector<Eigen::Vector2d> nominal;
  for (int i = 0; i < kRows * kCols; ++i) {
    if (i % kCols < kHalfCols) nominal.push_back(rest[i]);
  }
  // Sized to these dots as the single-view tracker sizes them: a Tac3D dot spans nearly half
  // its pitch, and the default disk of 0.45 pitch holds it as this one holds these.
  MarkerTrackerOptions options;
  options.blob = SizeBlobOptionsToDots(options.blob, kDotRadiusPx / 2);
  options.blob_radius = (kDotRadiusPx + 2.5) / kPitchPx;
  GridTracker tracker(kRows, kHalfCols, half, nominal, options, "the left half");
  GridObservation o;
  for (int frame = 0; frame < 2; ++frame) {
    auto truth = rest;
    for (auto& p : truth) p += frame * Eigen::Vector2d(-0.5, 0.7);
    tracker.Track(RenderFrame(truth, frame), o);
    for (int i = 0; i < kRows * kHalfCols; ++i) {
      const Eigen::Vector2d& p = truth[i / kHalfCols * kCols + i % kHalfCols];
      if (i % kHalfCols < kHalfCols - 1) {
        EXPECT_TRUE(o.valid(i)) << "frame " << frame << ", marker " << i << ": " << ToString(o.state[i]);
        continue;
      }
      EXPECT_EQ(o.state[i], MarkerState::kPartlyOutside) << "frame " << frame << ", marker " << i << ": "
                                                         << ToString(o.state[i]);
      EXPECT_LT((o.estimate_uv[i] - p).norm(), 0.5) << "frame " << frame << ", marker " << i;
    }
  }
}

TEST(SingleViewTracker, NoGridOrABadImageThrows) {
  const cv::Mat blank(kImageSize, CV_8UC1, cv::Scalar(150));
  EXPECT_THROW(SingleViewTracker(blank, 0, 0), Error);
  const cv::Mat reference = RenderFrame(GridCentres({25.3, 17.8}), 0);
  EXPECT_THROW(SingleViewTracker(reference, -1, 0), Error);
  // A grid far larger than the image's: refused at once (it took minutes and all memory), and
  // one twice the image's lattice a side, which would leave most markers lost.
  using ::testing::HasSubstr;
  using ::testing::ThrowsMessage;
  EXPECT_THAT([&] { SingleViewTracker(reference, 1000, 1000); },
              ThrowsMessage<Error>(HasSubstr("1000 x 1000 markers must be within 0 .. 100 a side")));
  EXPECT_THAT([&] { SingleViewTracker(reference, 2 * kRows, 2 * kCols); },
              ThrowsMessage<Error>(HasSubstr(fmt::format("grid given holds only {} markers of the reference "
                                                         "frame's lattice, which spans {} x {}",
                                                         kRows * kCols, kRows, kCols))));
  EXPECT_THROW(SingleViewTracker(cv::Mat(), 0, 0), Error);
  SingleViewTracker tracker(reference, 0, 0);
  GridObservation o;
  EXPECT_THROW(tracker.Track(cv::Mat(120, 160, CV_8UC1, cv::Scalar(150)), o), Error);
  EXPECT_THROW(tracker.Track(cv::Mat(kImageSize, CV_8UC3, cv::Scalar::all(150)), o), Error);
}

// A folder of rendered frames through SingleViewSourceTracker: frame 0 skipped (the reference is
// frame 1), an unreadable file skipped and counted, rest frames with noise only, then a press of
// 12 px and its release. The summary's figures against the truth: every marker tracked, no swap,
// the deepest press in the frame rendered deepest with its largest displacement, and the jitter
// of noise alone (well under the 0.05 px the real video meets, above 0).
TEST(SingleViewSourceTracker, TracksAFolderFrameByFrameAndSummarisesTheRun) {
  const std::string dir = testing::MakeTempDir("single_view_source");
  const auto rest = GridCentres({25.3, 17.8});
  const std::vector<double> depths = {0, 0, 0, 0, 0, 0, 4, 8, 12, 8, 4, 0};
  std::vector<std::vector<Eigen::Vector2d>> truth;
  for (size_t k = 0; k < depths.size(); ++k) {
    truth.push_back(Pressed(rest, {160, 120}, depths[k]));
    ASSERT_TRUE(cv::imwrite(fmt::format("{}/f{:02d}.png", dir, 2 * k), RenderFrame(truth.back(), k)));
  }
  std::ofstream(dir + "/f05.png") << "not a PNG";
  SingleViewTrackOptions options;
  options.reference_frame = 1;
  options.rest_frames = {{1, 5}};
  SingleViewSourceTracker tracker(OpenSingleViewSource(dir), options);
  ASSERT_EQ(tracker.rows(), kRows);
  ASSERT_EQ(tracker.cols(), kCols);
  SingleViewTrackFrame frame;
  std::vector<std::int64_t> indices;
  int bad = 0;
  for (ReadStatus status; (status = tracker.Next(frame)) != ReadStatus::kEnd;) {
    if (status == ReadStatus::kBadFrame) {
      ++bad;
      EXPECT_THAT(tracker.last_error(), ::testing::HasSubstr("f05.png"));
      continue;
    }
    ASSERT_EQ(status, ReadStatus::kOk);
    indices.push_back(frame.index);
    // Sorted by name, the corrupt f05.png is the folder's frame 3, between rendered frames 2 and 3.
    const size_t rendered = frame.index < 3 ? frame.index : frame.index - 1;
    EXPECT_LT(RmsError(frame.markers, truth[rendered]), kCentroidTolerancePx) << "frame " << frame.index;
  }
  EXPECT_EQ(bad, 1);
  ASSERT_EQ(indices.size(), depths.size() - 1);
  EXPECT_EQ(indices.front(), 1);
  const SingleViewTrackSummary s = tracker.summary();
  EXPECT_EQ(s.frames, static_cast<std::int64_t>(depths.size()) - 1);
  EXPECT_EQ(s.bad_frames, 1);
  EXPECT_EQ(s.reference_tracked, kRows * kCols);
  EXPECT_EQ(s.inside_untracked, 0);
  EXPECT_EQ(s.max_lost, 0);
  EXPECT_EQ(s.swaps, 0);
  EXPECT_EQ(s.reacquisitions, 0);
  EXPECT_NEAR(s.pitch_px, kPitchPx, 0.1);
  double deepest = 0;
  for (size_t i = 0; i < rest.size(); ++i) deepest = std::max(deepest, (truth[8][i] - truth[1][i]).norm());
  EXPECT_EQ(s.deepest_frame, 9);  // rendered frame 8 (12 px), after the corrupt file
  EXPECT_NEAR(s.deepest_max_px, deepest, 0.15);
  EXPECT_EQ(s.rest_frames, 4);    // 1, 2, 4 and 5: 3 is the corrupt file
  EXPECT_GT(s.jitter_x_px, 0.0);
  EXPECT_LT(s.jitter_x_px, 0.05);
  EXPECT_LT(s.jitter_y_px, 0.05);
  EXPECT_LT(s.jitter_max_px, 0.1);
}

// Frames of a GelSight Mini's video, converted to grey (the fixture's README names the
// source): the grid found in each, every dot fully inside the image measured, the others
// (cut by the border) flagged.
TEST(SingleViewTracker, RealGelSightMiniFramesEveryMarkerInsideFound) {
  const std::filesystem::path dir = std::filesystem::path(TAC3D_TRACKING_TESTDATA) / "gelsight_mini";
  int frames = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".png") continue;
    const cv::Mat image = cv::imread(entry.path().string(), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(image.empty()) << entry.path();
    SingleViewTracker tracker(image, kRows, kCols);
    const GridObservation& o = tracker.reference();
    int inside = 0;
    for (int i = 0; i < kRows * kCols; ++i) {
      const Eigen::Vector2d& p = o.estimate_uv[i];
      // A dot is 9 px across: 6 px from the border it is whole.
      const bool whole = p.x() > 6 && p.y() > 6 && p.x() < image.cols - 7 && p.y() < image.rows - 7;
      inside += whole;
      if (whole) {
        EXPECT_TRUE(o.valid(i)) << entry.path().filename() << " marker " << i << ": " << ToString(o.state[i]);
      } else {
        EXPECT_FALSE(o.valid(i)) << entry.path().filename() << " marker " << i;
      }
    }
    std::printf("%s: %d of %d markers whole, %d valid\n", entry.path().filename().c_str(), inside, kRows * kCols,
                o.valid_markers);
    ++frames;
  }
  EXPECT_GE(frames, 3);
}

// The whole video (where ../shared/realdata is present): the acceptance run. Every marker
// whose dot is inside the image (not flagged kPartlyOutside, and its centre farther than the
// dots' radius + 2 px from the edge) is measured in every frame, none moves by more than half
// the pitch between frames (an identity swap), and in the frames without contact (before the
// press and after the release, docs/real-images.md) each marker's position scatters by at
// most 0.05 px RMS per axis about its mean over each stretch.
TEST(SingleViewTracker, RealGelSightMiniVideoTrackedWithoutLossSwapOrJitter) {
  TAC3D_REQUIRE_REALDATA(realdata);
  const std::string path = realdata + "/gelsight-mini/mini_example.avi";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " is absent";
  const std::unique_ptr<FrameSource> video = OpenVideoFile(path);
  Frame frame;
  ASSERT_EQ(video->Read(frame), ReadStatus::kOk);
  SingleViewTracker tracker(frame.image, kRows, kCols);
  const GridObservation& reference = tracker.reference();
  const int n = kRows * kCols;
  const double margin = tracker.grid().dot_radius_px + 2;
  const std::vector<std::pair<int, int>> rest = {{kRestBefore.first, kRestBefore.second},
                                                 {kRestAfter.first, kRestAfter.second}};
  // Per stretch and marker: sums of positions and of their squares.
  std::vector<Eigen::Vector2d> sum(2 * n, Eigen::Vector2d::Zero()), sum2(2 * n, Eigen::Vector2d::Zero());
  std::vector<int> count(2 * n, 0);
  std::vector<Eigen::Vector2d> last = reference.uv;
  GridObservation o = reference;
  int frames = 1, inside = 0, lost = 0, swaps = 0;
  do {
    if (frame.index > 0) tracker.Track(frame.image, o);
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d& p = o.estimate_uv[i];
      if (o.state[i] != MarkerState::kPartlyOutside && p.x() > margin && p.y() > margin &&
          p.x() < frame.image.cols - 1 - margin && p.y() < frame.image.rows - 1 - margin) {
        ++inside;
        lost += !o.valid(i);
        EXPECT_TRUE(o.valid(i)) << "frame " << frame.index << " marker " << i << ": " << ToString(o.state[i]);
      }
      if (!o.valid(i)) continue;
      if (last[i].allFinite()) swaps += (o.uv[i] - last[i]).norm() > 0.5 * tracker.pitch_px(i);
      last[i] = o.uv[i];
      for (int k = 0; k < 2; ++k) {
        if (frame.index < rest[k].first || frame.index > rest[k].second) continue;
        sum[k * n + i] += o.uv[i];
        sum2[k * n + i] += o.uv[i].cwiseProduct(o.uv[i]);
        ++count[k * n + i];
      }
    }
    frames += frame.index > 0;
  } while (video->Read(frame) == ReadStatus::kOk);
  EXPECT_EQ(frames, 219);
  EXPECT_GE(reference.valid_markers, 70);
  EXPECT_EQ(lost, 0) << "of " << inside << " marker-frames inside the image";
  EXPECT_EQ(swaps, 0);
  Eigen::Vector2d variance = Eigen::Vector2d::Zero();
  int samples = 0;
  for (int j = 0; j < 2 * n; ++j) {
    if (count[j] < 2) continue;
    const Eigen::Vector2d mean = sum[j] / count[j];
    variance += sum2[j] - count[j] * mean.cwiseProduct(mean);
    samples += count[j];
  }
  const Eigen::Vector2d jitter = (variance / samples).cwiseSqrt();
  EXPECT_LE(jitter.x(), 0.05);
  EXPECT_LE(jitter.y(), 0.05);
  std::printf("%d frames, %d markers in the reference; jitter at rest %.4f, %.4f px RMS\n", frames,
              reference.valid_markers, jitter.x(), jitter.y());
}

}  // namespace tac3d::single_view_test
