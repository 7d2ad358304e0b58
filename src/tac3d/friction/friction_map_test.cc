#include "tac3d/friction/friction_map.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <thread>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <utility>

#include "tac3d/friction/friction_output.h"
#include "tac3d/scene/ply.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::friction {
namespace {

using ::testing::HasSubstr;

// ---- A synthetic, analytic scan ----------------------------------------------------------
// A flat object, the plane z = 0 of the world, with mu = 0.3 for x < 0 and 0.9 for x >= 0.
// The sensor faces down (sensor z = world -z) with its outer surface's top (sensor z = 8 mm)
// on the plane, and slides along +x in strokes at several y. Per frame, markers within
// contact_radius_mm of the axis press with F_n = 0.03 .. 0.1 N; a seeded random fraction of
// them sticks to the object (no world motion, |F_t| = 0.5 mu F_n), the others slip with the
// sensor (|F_t| = mu F_n, opposite the sliding). Marker positions carry Gaussian noise of
// noise_mm per axis, forces of force_noise_n per axis.
constexpr double kTopMm = 8.0;
constexpr double kCoverMm = 0.5;

double TrueMu(double x_mm) { return x_mm < 0 ? 0.3 : 0.9; }

struct ScanSpec {
  std::vector<double> strokes_y_mm = {-3.0, 0.0, 3.0};
  double x_begin_mm = -10.0;
  double x_end_mm = 10.0;
  double step_mm = 0.25;  // sensor motion a frame
  double contact_radius_mm = 4.0;
  double stick_fraction = 0.2;
  double noise_mm = 0.002;
  double force_noise_n = 0.0005;
  // The first partial_slip_frames frames of a stroke after its first contact: partial slip,
  // partial_stick_fraction of the contact markers stuck and the others' force ratio
  // partial_slip_ratio mu (the force inverse mixes the stuck ones' lower ratio into theirs).
  int partial_slip_frames = 0;
  double partial_stick_fraction = 0.5;
  double partial_slip_ratio = 0.5;
  // The stuck markers of a partial-slip frame still move this fraction of the frame's step on
  // the object: the surface sticks, the cover's shear under it builds up.
  double partial_creep = 0.0;
  int static_press_frames = 0;  // then pressed without motion at static_press_x_mm
  double static_press_x_mm = 20.0;
};

struct Scan {
  std::vector<TactileFrame> frames;
  std::vector<Rigid3> poses;
  std::set<std::pair<std::int64_t, int>> true_slips;  // (frame index, marker)
  long true_pairs = 0;                                // markers in contact in adjacent frames
  std::set<std::int64_t> partial_slip_frames;         // frame indices
};

Rigid3 SensorPose(double x_mm, double y_mm) {
  Rigid3 pose = Rigid3::Identity();
  pose.linear() = Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitX()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(x_mm, y_mm, kTopMm);
  return pose;
}

class ScanMaker {
 public:
  explicit ScanMaker(const ScanSpec& spec) : spec_(spec), rng_(tac3d::testing::kRandomSeed) {
    for (int r = 0; r < 20; ++r) {
      for (int c = 0; c < 20; ++c) nominal_.emplace_back((c - 9.5) * 1.27, (r - 9.5) * 1.27);
    }
  }

  Scan Make() {
    for (double y : spec_.strokes_y_mm) {
      AddLiftedFrame(SensorPose(spec_.x_begin_mm, y));
      const int steps =
          static_cast<int>(std::round((spec_.x_end_mm - spec_.x_begin_mm) / spec_.step_mm));
      for (int k = 0; k <= steps; ++k)
        AddContactFrame(SensorPose(spec_.x_begin_mm + k * spec_.step_mm, y), true);
    }
    if (spec_.static_press_frames > 0) {
      AddLiftedFrame(SensorPose(spec_.static_press_x_mm, 0));
      for (int k = 0; k < spec_.static_press_frames; ++k)
        AddContactFrame(SensorPose(spec_.static_press_x_mm, 0), false);
    }
    return std::move(scan_);
  }

 private:
  TactileFrame NewFrame() {
    TactileFrame frame = TactileFrame::Sized(20, 20);
    frame.index = static_cast<std::int64_t>(scan_.frames.size());
    frame.timestamp_s = frame.index / 30.0;
    for (int i = 0; i < 400; ++i) {
      const Eigen::Vector2d& q = nominal_[i];
      frame.positions_mm[i] =
          Eigen::Vector3d(q.x(), q.y(), kTopMm - kCoverMm - q.squaredNorm() / 90.0);
      frame.normals[i] = Eigen::Vector3d(q.x() / 45.0, q.y() / 45.0, 1.0).normalized();
    }
    return frame;
  }

  void AddLiftedFrame(const Rigid3& pose) {
    scan_.frames.push_back(NewFrame());
    scan_.poses.push_back(pose);
    previous_world_.clear();
    stroke_frame_ = 0;
  }

  // sliding: markers slip unless drawn to stick; otherwise all stick.
  void AddContactFrame(const Rigid3& pose, bool sliding) {
    TactileFrame frame = NewFrame();
    std::normal_distribution<double> noise(0.0, spec_.noise_mm),
        force_noise(0.0, spec_.force_noise_n);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    std::vector<Eigen::Vector3d> world(400, Eigen::Vector3d::Constant(std::nan("")));
    const Eigen::Vector3d n(0, 0, 1);
    const bool partial =
        sliding && stroke_frame_ >= 1 && stroke_frame_ <= spec_.partial_slip_frames;
    const double stick_fraction = partial ? spec_.partial_stick_fraction : spec_.stick_fraction;
    if (partial) scan_.partial_slip_frames.insert(frame.index);
    ++stroke_frame_;
    for (int i = 0; i < 400; ++i) {
      const double r = nominal_[i].norm();
      if (r >= spec_.contact_radius_mm) continue;
      const bool had_contact = !previous_world_.empty() && !std::isnan(previous_world_[i].x());
      const bool stick = had_contact && (!sliding || uniform(rng_) < stick_fraction);
      const Eigen::Vector3d p_nominal(nominal_[i].x(), nominal_[i].y(), kTopMm - kCoverMm);
      const Eigen::Vector3d slid = pose * p_nominal;
      world[i] = !stick    ? slid
                 : partial ? Eigen::Vector3d(previous_world_[i] +
                                             spec_.partial_creep * (slid - previous_world_[i]))
                           : previous_world_[i];
      if (had_contact) {
        ++scan_.true_pairs;
        if (!stick) scan_.true_slips.insert({frame.index, i});
      }
      const Eigen::Vector3d p_true = pose.inverse() * world[i];
      frame.positions_mm[i] = p_true + Eigen::Vector3d(noise(rng_), noise(rng_), noise(rng_));
      frame.normals[i] = n;
      const double normal_force =
          0.03 + 0.07 * std::sqrt(1 - r * r / (spec_.contact_radius_mm * spec_.contact_radius_mm));
      const double ratio =
          (stick ? 0.5 : (partial ? spec_.partial_slip_ratio : 1.0)) * TrueMu(world[i].x());
      // The object drags the gel back against the sliding (+x world = +x sensor).
      const Eigen::Vector3d tangential(-ratio * normal_force, 0, 0);
      frame.forces_n[i] = -normal_force * n + tangential +
                          Eigen::Vector3d(force_noise(rng_), force_noise(rng_), force_noise(rng_));
      frame.contact[i] = true;
    }
    previous_world_ = std::move(world);
    scan_.frames.push_back(std::move(frame));
    scan_.poses.push_back(pose);
  }

  ScanSpec spec_;
  std::mt19937_64 rng_;
  std::vector<Eigen::Vector2d> nominal_;
  std::vector<Eigen::Vector3d> previous_world_;
  int stroke_frame_ = 0;  // contact frames so far in this stroke
  Scan scan_;
};

FrictionMapBuilder BuilderFor(const Scan& scan, const FrictionMapOptions& options = {}) {
  FrictionMapBuilder builder(options);
  for (size_t k = 0; k < scan.frames.size(); ++k) builder.AddFrame(scan.frames[k], scan.poses[k]);
  return builder;
}

struct Detection {
  double precision, recall, false_positive_rate;
};

Detection Score(const Scan& scan, const std::vector<SlipPoint>& slips) {
  long true_positive = 0;
  for (const SlipPoint& s : slips)
    true_positive += scan.true_slips.count({s.frame_index, s.marker});
  const long false_positive = static_cast<long>(slips.size()) - true_positive;
  const long stuck = scan.true_pairs - static_cast<long>(scan.true_slips.size());
  return {static_cast<double>(true_positive) / std::max<size_t>(slips.size(), 1),
          static_cast<double>(true_positive) / std::max<size_t>(scan.true_slips.size(), 1),
          static_cast<double>(false_positive) / std::max<long>(stuck, 1)};
}

// ---- Options -----------------------------------------------------------------------------

std::string ValidateError(const std::function<void(FrictionMapOptions&)>& change) {
  FrictionMapOptions options;
  change(options);
  try {
    options.Validate();
  } catch (const Error& e) {
    return e.what();
  }
  return "(valid)";
}

TEST(FrictionMapOptions, DefaultsAreValidAndEveryBoundThrows) {
  EXPECT_NO_THROW(FrictionMapOptions{}.Validate());
  const auto nan = std::nan("");
  const auto inf = std::numeric_limits<double>::infinity();
  struct Case {
    std::function<void(FrictionMapOptions&)> change;
    std::string message;
  };
  const std::vector<Case> cases = {
      {[](auto& o) { o.contact_threshold_n = -0.01; },
       "contact_threshold_n = -0.01 is out of range: must be >= 0 and finite"},
      {[&](auto& o) { o.contact_threshold_n = inf; }, "contact_threshold_n = inf"},
      {[](auto& o) { o.cover_thickness_mm = -0.1; },
       "cover_thickness_mm = -0.1 is out of range: must be in [0, 5]"},
      {[](auto& o) { o.cover_thickness_mm = 5.5; }, "cover_thickness_mm = 5.5"},
      {[](auto& o) { o.marker_noise_mm = 0; },
       "marker_noise_mm = 0 is out of range: must be > 0 and finite"},
      {[&](auto& o) { o.marker_noise_mm = nan; }, "marker_noise_mm = nan"},
      {[](auto& o) { o.pose_noise_mm = -1e-3; },
       "pose_noise_mm = -0.001 is out of range: must be >= 0 and finite"},
      {[](auto& o) { o.slip_sigmas = 0; },
       "slip_sigmas = 0 is out of range: must be > 0 and finite"},
      {[](auto& o) { o.voxel_size_mm = 0; },
       "voxel_size_mm = 0 is out of range: must be > 0 and finite"},
      {[](auto& o) { o.poisson_depth = 3; },
       "poisson_depth = 3 is out of range: must be in [4, 12]"},
      {[](auto& o) { o.poisson_depth = 13; }, "poisson_depth = 13"},
      {[](auto& o) { o.poisson_scale = 0.9; },
       "poisson_scale = 0.9 is out of range: must be in [1, 2]"},
      {[](auto& o) { o.poisson_scale = 2.5; }, "poisson_scale = 2.5"},
      {[](auto& o) { o.num_threads = -1; },
       "num_threads = -1 is out of range: must be in [0, 1024] (0: one a core)"},
      {[](auto& o) { o.num_threads = 1025; },
       "num_threads = 1025 is out of range: must be in [0, 1024] (0: one a core)"},
      {[](auto& o) { o.trim_distance_mm = 0; },
       "trim_distance_mm = 0 is out of range: must be > 0 and finite"},
      {[](auto& o) { o.radius_mm = -1; }, "radius_mm = -1 is out of range: must be > 0 and finite"},
      {[](auto& o) { o.alpha = -0.5; }, "alpha = -0.5 is out of range: must be >= 0 and finite"},
      {[&](auto& o) { o.alpha = inf; }, "alpha = inf"},
      {[](auto& o) { o.beta = -2; }, "beta = -2 is out of range: must be >= 0 and finite"},
      {[](auto& o) { o.normal_force_exponent = -1; },
       "normal_force_exponent = -1 is out of range: must be >= 0 and finite"},
      {[](auto& o) { o.min_slip_points = 0; }, "min_slip_points = 0 is out of range: must be >= 1"},
      {[](auto& o) { o.max_support_offset = 0; },
       "max_support_offset = 0 is out of range: must be in (0, 1]"},
      {[](auto& o) { o.gross_slip_margin = -1; },
       "gross_slip_margin = -1 is out of range: must be >= 0"},
      {[&](auto& o) { o.slip_contact_threshold_n = inf; }, "slip_contact_threshold_n = inf"},
  };
  for (const Case& c : cases)
    EXPECT_THAT(ValidateError(c.change), HasSubstr("FrictionMapOptions." + c.message));
  FrictionMapOptions bad;
  bad.radius_mm = 0;
  EXPECT_THROW(FrictionMapBuilder{bad}, Error);
}

TEST(FrictionMapOptions, SlipThresholdIsKSigmaOfTheDifferenceOfTwoPositions) {
  FrictionMapOptions options;
  EXPECT_NEAR(options.SlipThresholdMm(), 4.0 * std::sqrt(2.0) * 0.002, 1e-15);
  options.pose_noise_mm = 0.003;
  options.slip_sigmas = 3.0;
  EXPECT_NEAR(
      options.SlipThresholdMm(), 3.0 * std::sqrt(2.0 * (0.002 * 0.002 + 0.003 * 0.003)), 1e-15);
}

TEST(FrictionMapOptions, WithSensorTakesTheMarkersDepthAndKeepsTheRest) {
  SensorConfig sensor;
  sensor.markers.depth_mm = 0.8;
  FrictionMapOptions options;
  options.beta = 3.0;
  const FrictionMapOptions with = options.WithSensor(sensor);
  EXPECT_DOUBLE_EQ(with.cover_thickness_mm, 0.8);
  EXPECT_DOUBLE_EQ(with.beta, 3.0);
  EXPECT_DOUBLE_EQ(options.WithSensor(SensorConfig{}).cover_thickness_mm, 0.5);
}

// ---- Equations 5 and 6 -------------------------------------------------------------------

TEST(WeightedFriction, MatchesEquations5And6) {
  FrictionMapOptions options;  // r = 1.5, alpha = 1, beta = 2
  double weight_sum = -1;
  // w1 = (1.5 - 0.5) 0.4^2 = 0.16, w2 = (1.5 - 1.0) 0.8^2 = 0.32.
  EXPECT_NEAR(WeightedFriction({0.4, 0.8}, {0.5, 1.0}, options, &weight_sum),
              (0.16 * 0.4 + 0.32 * 0.8) / 0.48,
              1e-12);
  EXPECT_NEAR(weight_sum, 0.48, 1e-12);
  // alpha = beta = 0: every point weighs 1, the plain mean.
  options.alpha = 0;
  options.beta = 0;
  EXPECT_NEAR(WeightedFriction({0.4, 0.8, 0.3}, {0.5, 1.0, 1.4}, options, &weight_sum), 0.5, 1e-12);
  EXPECT_NEAR(weight_sum, 3.0, 1e-12);
  // A large beta all but ignores a small mu_i (a stuck marker misjudged as slipping).
  options.alpha = 1;
  options.beta = 8;
  EXPECT_NEAR(WeightedFriction({0.9, 0.9, 0.1}, {0.5, 0.5, 0.1}, options, nullptr), 0.9, 1e-6);
}

// gamma = 1, beta = 0: equation 5 becomes the ratio of the summed forces near the vertex,
// sum w |F_t| / sum w F_n (mu_i = |F_t| / F_n).
TEST(WeightedFriction, NormalForceWeightsGiveTheRatioOfSummedForces) {
  FrictionMapOptions options;
  options.alpha = 0;
  options.beta = 0;
  options.normal_force_exponent = 1;
  const std::vector<double> fn = {0.1, 0.01}, ft = {0.05, 0.02};
  double weight_sum = -1;
  EXPECT_NEAR(
      WeightedFriction({ft[0] / fn[0], ft[1] / fn[1]}, {0.2, 0.4}, options, &weight_sum, fn),
      (ft[0] + ft[1]) / (fn[0] + fn[1]),
      1e-12);
  EXPECT_NEAR(weight_sum, 0.11, 1e-12);
  // Without forces the exponent is ignored: the plain mean.
  EXPECT_NEAR(WeightedFriction({0.5, 2.0}, {0.2, 0.4}, options, nullptr), 1.25, 1e-12);
}

TEST(WeightedFriction, DegenerateWeights) {
  FrictionMapOptions options;
  double weight_sum = -1;
  EXPECT_TRUE(std::isnan(WeightedFriction({}, {}, options, &weight_sum)));
  EXPECT_EQ(weight_sum, 0.0);
  // All mu_i = 0 with beta > 0: every weight is 0, mu is their mean, 0.
  EXPECT_EQ(WeightedFriction({0.0, 0.0}, {0.1, 0.2}, options, &weight_sum), 0.0);
  EXPECT_EQ(weight_sum, 0.0);
  // All on the radius with alpha > 0: the mean.
  EXPECT_NEAR(WeightedFriction({0.2, 0.6}, {1.5, 1.5}, options, &weight_sum), 0.4, 1e-12);
}

// ---- Slip detection ----------------------------------------------------------------------

TEST(FrictionMapBuilder, SlipDetectorRecoversTheSyntheticTruth) {
  const Scan scan = ScanMaker({}).Make();
  const FrictionMapBuilder builder = BuilderFor(scan);
  const Detection d = Score(scan, builder.slip_points());
  EXPECT_GE(d.precision, 0.995);
  EXPECT_GE(d.recall, 0.995);
  std::cout << "precision " << d.precision << ", recall " << d.recall << ", stuck misjudged "
            << d.false_positive_rate << "\n";
  for (const SlipPoint& s : builder.slip_points()) {
    EXPECT_NEAR(s.p_in_world_mm.z(), 0.0, 0.02);  // on the object after the cover offset
  }
}

TEST(FrictionMapBuilder, SlowSlipNearTheThresholdAndNoiseEstimate) {
  // 0.02 mm a frame: 3.1 sigma of the difference above the 4 sigma threshold (0.0113 mm).
  ScanSpec spec;
  spec.step_mm = 0.02;
  spec.x_begin_mm = -2;
  spec.x_end_mm = 2;
  spec.strokes_y_mm = {0.0};
  spec.stick_fraction = 0.5;
  const Scan scan = ScanMaker(spec).Make();
  const FrictionMapBuilder builder = BuilderFor(scan);
  const Detection d = Score(scan, builder.slip_points());
  ASSERT_GT(scan.true_pairs, 5000);
  EXPECT_GE(d.precision, 0.99);
  EXPECT_GE(d.recall, 0.99);
  // P(chi^2_3 > 16) = 1.1e-3 of the stuck pairs.
  EXPECT_LT(d.false_positive_rate, 4e-3);
  std::cout << "slow slip: precision " << d.precision << ", recall " << d.recall
            << ", stuck misjudged " << d.false_positive_rate << "\n";
  const FrictionMapSummary summary = builder.Build().summary;
  EXPECT_EQ(summary.marker_pairs, scan.true_pairs);
  EXPECT_NEAR(summary.estimated_noise_mm, spec.noise_mm, 0.15 * spec.noise_mm);
}

// ---- The map -----------------------------------------------------------------------------

class FrictionMapTwoRegions : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    ScanSpec spec;
    spec.static_press_frames = 5;
    scan_ = new Scan(ScanMaker(spec).Make());
    std::vector<std::pair<int, int>> calls;
    result_ = new FrictionMapResult(
        BuilderFor(*scan_).Build([&](int done, int total) { calls.emplace_back(done, total); }));
    progress_calls_ = new std::vector<std::pair<int, int>>(calls);
  }
  static void TearDownTestSuite() {
    delete scan_;
    delete result_;
    delete progress_calls_;
  }
  static Scan* scan_;
  static FrictionMapResult* result_;
  static std::vector<std::pair<int, int>>* progress_calls_;
};
Scan* FrictionMapTwoRegions::scan_ = nullptr;
FrictionMapResult* FrictionMapTwoRegions::result_ = nullptr;
std::vector<std::pair<int, int>>* FrictionMapTwoRegions::progress_calls_ = nullptr;

TEST_F(FrictionMapTwoRegions, BuildsAMeshWithMuPerVertex) {
  const FrictionMapResult& m = *result_;
  const FrictionMapSummary& s = m.summary;
  EXPECT_EQ(s.status, FrictionMapStatus::kOk) << s.BriefReport();
  EXPECT_EQ(s.frames, static_cast<int>(scan_->frames.size()));
  EXPECT_GT(s.vertices, 1000);
  EXPECT_EQ(m.mu.size(), m.vertices_mm.size());
  EXPECT_EQ(m.confidence.size(), m.vertices_mm.size());
  EXPECT_EQ(m.slip_count.size(), m.vertices_mm.size());
  EXPECT_EQ(m.vertex_normals.size(), m.vertices_mm.size());
  EXPECT_EQ(static_cast<long>(m.slip_points.size()), s.slip_points);
  EXPECT_GT(s.poisson_time_s, 0.0);
  EXPECT_THAT(
      *progress_calls_,
      ::testing::ElementsAre(std::pair(1, 4), std::pair(2, 4), std::pair(3, 4), std::pair(4, 4)));
  std::cout << s.BriefReport() << "\n";
}

TEST_F(FrictionMapTwoRegions, RecoversMuOnEachSideAwayFromTheBoundary) {
  const FrictionMapResult& m = *result_;
  const double margin = 1.5 * FrictionMapOptions{}.radius_mm;  // eq. 5 mixes within r
  int low = 0, high = 0;
  double max_error[2] = {0, 0};
  for (size_t v = 0; v < m.vertices_mm.size(); ++v) {
    const Eigen::Vector3d& p = m.vertices_mm[v];
    if (std::abs(p.x()) < margin || p.x() > 14.0 || m.slip_count[v] < 3) continue;
    ASSERT_FALSE(std::isnan(m.mu[v]));
    const double truth = TrueMu(p.x());
    EXPECT_NEAR(m.mu[v], truth, 0.05 * truth) << "vertex " << v << " at " << p.transpose();
    ++(truth < 0.5 ? low : high);
    max_error[truth < 0.5 ? 0 : 1] =
        std::max(max_error[truth < 0.5 ? 0 : 1], std::abs(m.mu[v] - truth));
  }
  EXPECT_GT(low, 200);
  EXPECT_GT(high, 200);
  std::cout << "max |mu - truth|: " << max_error[0] << " (mu 0.3, " << low << " vertices), "
            << max_error[1] << " (mu 0.9, " << high << " vertices)\n";
}

TEST_F(FrictionMapTwoRegions, UnknownWhereThereIsNoSlipPoint) {
  const FrictionMapResult& m = *result_;
  // The static press at x = 20 +- 4 mm: surface, but no slip.
  int pressed = 0;
  for (size_t v = 0; v < m.vertices_mm.size(); ++v) {
    if (m.vertices_mm[v].x() < 15.5) continue;
    ++pressed;
    EXPECT_TRUE(std::isnan(m.mu[v]));
    EXPECT_EQ(m.slip_count[v], 0);
    EXPECT_EQ(m.confidence[v], 0.0);
  }
  // Poisson's octree is coarse where points are sparse: about a vertex per marker there.
  EXPECT_GT(pressed, 20);
  EXPECT_GE(m.summary.unknown_vertices, pressed);
  EXPECT_NEAR(m.summary.unknown_fraction,
              static_cast<double>(m.summary.unknown_vertices) / m.summary.vertices,
              1e-12);
  // Known vertices: mu within r of a slip point, a positive weight sum.
  for (size_t v = 0; v < m.vertices_mm.size(); ++v) {
    if (!std::isnan(m.mu[v])) {
      EXPECT_GT(m.slip_count[v], 0);
      EXPECT_GT(m.confidence[v], 0.0);
    }
  }
}

// The support test leaves the rim's vertices unknown, whose slip points all lie inward, and
// changes nothing inside.
TEST_F(FrictionMapTwoRegions, SupportOffsetTrimsTheRimOnly) {
  FrictionMapOptions options;
  options.max_support_offset = 0.25;
  const FrictionMapResult trimmed = BuilderFor(*scan_, options).Build();
  const FrictionMapResult& all = *result_;
  ASSERT_EQ(trimmed.vertices_mm.size(), all.vertices_mm.size());
  double all_min_x = 1e9, trimmed_min_x = 1e9;
  int interior = 0, dropped = 0;
  for (size_t v = 0; v < all.vertices_mm.size(); ++v) {
    const Eigen::Vector3d& p = all.vertices_mm[v];
    if (std::isnan(all.mu[v])) {
      EXPECT_TRUE(std::isnan(trimmed.mu[v]));
      continue;
    }
    all_min_x = std::min(all_min_x, p.x());
    if (std::isnan(trimmed.mu[v])) {
      ++dropped;
      continue;
    }
    trimmed_min_x = std::min(trimmed_min_x, p.x());
    EXPECT_DOUBLE_EQ(trimmed.mu[v], all.mu[v]);
    // Inside the scanned patch (strokes at y = -3..3 from x = -10 to 10, 4 mm contacts).
    if (std::abs(p.x()) < 8.0 && std::abs(p.y()) < 3.0) ++interior;
  }
  for (size_t v = 0; v < all.vertices_mm.size(); ++v) {
    const Eigen::Vector3d& p = all.vertices_mm[v];
    if (std::abs(p.x()) < 8.0 && std::abs(p.y()) < 3.0 && !std::isnan(all.mu[v])) {
      EXPECT_FALSE(std::isnan(trimmed.mu[v])) << "interior vertex " << v << " dropped";
    }
  }
  EXPECT_GT(interior, 200);
  EXPECT_GT(dropped, 20);
  EXPECT_GT(trimmed_min_x, all_min_x + 0.3);  // the stroke starts' rim went
}

TEST_F(FrictionMapTwoRegions, MeshLiesOnTheObjectsPlaneAfterTheCoverOffset) {
  const FrictionMapResult& m = *result_;
  int interior = 0;
  for (size_t v = 0; v < m.vertices_mm.size(); ++v) {
    const Eigen::Vector3d& p = m.vertices_mm[v];
    EXPECT_LT(std::abs(p.z()), FrictionMapOptions{}.trim_distance_mm);
    if (std::abs(p.x()) < 9 && std::abs(p.y()) < 4) {
      ++interior;
      EXPECT_NEAR(p.z(), 0.0, 0.02) << "vertex " << v << " at " << p.transpose();
      EXPECT_GT(m.vertex_normals[v].z(), 0.99) << "normals point out of the object, up";
    }
  }
  EXPECT_GT(interior, 500);
}

TEST_F(FrictionMapTwoRegions, SummaryReportAndJson) {
  const FrictionMapSummary& s = result_->summary;
  EXPECT_THAT(s.BriefReport(), HasSubstr("friction map ok:"));
  const nlohmann::json j = ToJson(s);
  EXPECT_EQ(j.at("status"), "ok");
  EXPECT_EQ(j.at("vertices"), s.vertices);
  EXPECT_EQ(j.at("slip_points"), s.slip_points);
  EXPECT_DOUBLE_EQ(j.at("poisson_time_s").get<double>(), s.poisson_time_s);
}

TEST_F(FrictionMapTwoRegions, WritesPlyAndPngOfTheMap) {
  const FrictionMapResult& m = *result_;
  const std::string dir = tac3d::testing::MakeTempDir("friction_map");
  WriteFrictionMapPly(m, dir + "/map.ply");
  const TriangleMesh mesh = ReadPly(dir + "/map.ply");
  ASSERT_EQ(mesh.vertices.size(), m.vertices_mm.size());
  EXPECT_EQ(mesh.triangles.size(), m.triangles.size());
  for (size_t v = 0; v < m.vertices_mm.size(); v += 97) {
    const double mu = mesh.vertex_properties.at("mu")[v];
    if (std::isnan(m.mu[v])) {
      EXPECT_TRUE(std::isnan(mu));
    } else {
      EXPECT_NEAR(mu, m.mu[v], 1e-6);
    }
  }
  // From above: blue (x < 0), red (x > 0) and grey (the static press) are all there. The mesh
  // fills its plot area, 586 x 504 of the 800 x 600 image beside the annotations.
  const RenderSummary png = WriteFrictionMapPng(m, dir + "/map.png");
  EXPECT_GT(png.covered_pixels, 60000);
  EXPECT_GT(png.band_pixels[static_cast<int>(FrictionBand::kLow)], 0.3 * png.covered_pixels);
  EXPECT_GT(png.band_pixels[static_cast<int>(FrictionBand::kHigh)], 0.3 * png.covered_pixels);
  EXPECT_GT(png.band_pixels[static_cast<int>(FrictionBand::kUnknown)], 0.05 * png.covered_pixels);
  WriteSlipPointsCsv(m.slip_points, dir + "/slips.csv");
  std::ifstream csv(dir + "/slips.csv");
  const long lines =
      std::count(std::istreambuf_iterator<char>(csv), std::istreambuf_iterator<char>(), '\n');
  EXPECT_EQ(lines, m.summary.slip_points + 1);
}

// ---- The friction force along the slip ---------------------------------------------------

TEST(FrictionMapBuilder, FrictionAlongTheSlipIsNotBiasedByForceNoise) {
  // 10 mN of force noise per axis against |F_t| = 0.3 F_n = 9-30 mN on the mu 0.3 half: the
  // noise across the slip adds to |F_t| in quadrature (the paper's mu_i, biased up), the
  // component against the slip only averages it out.
  ScanSpec spec;
  spec.strokes_y_mm = {0.0};
  spec.stick_fraction = 0.0;
  spec.force_noise_n = 0.01;
  const Scan scan = ScanMaker(spec).Make();
  FrictionMapOptions along;
  along.friction_along_slip = true;
  const auto mean_low_mu = [&](const FrictionMapOptions& options) {
    double sum = 0;
    int count = 0;
    const FrictionMapBuilder builder = BuilderFor(scan, options);
    for (const SlipPoint& s : builder.slip_points()) {
      if (s.p_in_world_mm.x() > -1.0 || s.normal_force_n < 0.06) continue;
      EXPECT_GE(s.mu, 0.0);
      sum += s.mu;
      ++count;
    }
    EXPECT_GT(count, 500);
    return sum / count;
  };
  const double paper = mean_low_mu(FrictionMapOptions{});
  const double projected = mean_low_mu(along);
  EXPECT_GT(paper - 0.3, 0.01);
  EXPECT_NEAR(projected, 0.3, 0.005);
  std::cout << "mean mu_i on mu 0.3: |F_t| / F_n " << paper << ", along the slip " << projected
            << "\n";
}

// ---- Gross slip -------------------------------------------------------------------------

TEST(FrictionMapBuilder, OnlyGrossSlipVotesSoPartialSlipDoesNotBiasMu) {
  // Each stroke starts with 10 frames of partial slip (half the contact stuck, the slipping
  // half at 0.5 mu) over the mu 0.3 half, then slides with the whole contact (no stick). The
  // stuck markers creep on the object by 30% of the step (the cover's shear builds up), so
  // every marker moves over the slip threshold: only their motion in the sensor frame, 70% of
  // the step, tells the partial slip from the steady sliding.
  ScanSpec spec;
  spec.stick_fraction = 0.0;
  spec.partial_slip_frames = 10;
  spec.partial_creep = 0.3;  // 0.075 mm a frame: over the slip threshold, so (b) must see it
  const Scan scan = ScanMaker(spec).Make();
  const int steps = static_cast<int>(std::round((spec.x_end_mm - spec.x_begin_mm) / spec.step_mm));
  const int strokes = static_cast<int>(spec.strokes_y_mm.size());
  FrictionMapOptions paper;
  FrictionMapOptions gross = paper;
  gross.gross_slip_only = true;
  FrictionMapOptions trimmed = gross;
  trimmed.gross_slip_margin = 2;
  const FrictionMapResult all = BuilderFor(scan, paper).Build();
  const FrictionMapResult steady = BuilderFor(scan, gross).Build();
  const FrictionMapResult steady_trimmed = BuilderFor(scan, trimmed).Build();
  // steps + 1 contact frames a stroke: the first has no pair, the next 10 partial slip. Noise
  // alone makes a steady frame look unsteady when one of its ~50 pressed markers moves over
  // 4 sigma in the sensor frame: P(chi^2_2 > 16) = 3.4e-4 a marker, under 2% of the frames.
  const int gross_frames = strokes * (steps + 1 - 1 - spec.partial_slip_frames);
  ASSERT_EQ(static_cast<int>(scan.partial_slip_frames.size()), strokes * spec.partial_slip_frames);
  EXPECT_LE(steady.summary.gross_slip_frames, gross_frames);
  EXPECT_GE(steady.summary.gross_slip_frames, 0.97 * gross_frames);
  EXPECT_EQ(all.summary.gross_slip_frames, steady.summary.gross_slip_frames);
  // No partial-slip frame votes; the margin takes 2 frames more off each end of a run.
  const auto voting_frames = [&](const FrictionMapResult& m) {
    std::set<std::int64_t> frames;
    for (const SlipPoint& s : m.slip_points) {
      if (!s.gross_slip) continue;
      frames.insert(s.frame_index);
      EXPECT_EQ(scan.partial_slip_frames.count(s.frame_index), 0u) << "frame " << s.frame_index;
    }
    return static_cast<int>(frames.size());
  };
  const int voting = voting_frames(steady);
  EXPECT_EQ(voting, steady.summary.gross_slip_frames);
  EXPECT_LE(voting_frames(steady_trimmed), voting - strokes * 2 * trimmed.gross_slip_margin);
  EXPECT_LT(steady.summary.voting_slip_points, all.summary.voting_slip_points);
  EXPECT_EQ(all.summary.voting_slip_points, all.summary.slip_points);
  // Where the strokes start (x in [-12, -6], mu 0.3): the paper's map is biased low by the
  // partial-slip frames, the gross-slip map is not.
  double worst_all = 0, worst_steady = 0;
  int compared = 0;
  for (size_t v = 0; v < all.vertices_mm.size(); ++v) {
    const Eigen::Vector3d& p = all.vertices_mm[v];
    if (p.x() < -12 || p.x() > -6 || std::abs(p.y()) > 3 || all.slip_count[v] < 3) continue;
    worst_all = std::max(worst_all, std::abs(all.mu[v] - 0.3));
    ++compared;
  }
  for (size_t v = 0; v < steady.vertices_mm.size(); ++v) {
    const Eigen::Vector3d& p = steady.vertices_mm[v];
    if (p.x() < -12 || p.x() > -6 || std::abs(p.y()) > 3 || std::isnan(steady.mu[v])) continue;
    worst_steady = std::max(worst_steady, std::abs(steady.mu[v] - 0.3));
  }
  EXPECT_GT(compared, 100);
  EXPECT_GT(worst_all, 0.03);
  EXPECT_LT(worst_steady, 0.015);
  std::cout << "stroke starts, largest |mu - 0.3|: every slip point " << worst_all
            << ", gross slip only " << worst_steady << "\n";
}

// ---- Degenerate streams ------------------------------------------------------------------

TEST(FrictionMapBuilder, NoContactNoSlipAndSkippedFrames) {
  FrictionMapBuilder empty{FrictionMapOptions{}};
  EXPECT_EQ(empty.Build().summary.status, FrictionMapStatus::kNoContact);
  const nlohmann::json j = ToJson(empty.Build().summary);
  EXPECT_TRUE(j.at("unknown_fraction").is_null());

  ScanSpec spec;
  spec.strokes_y_mm = {};
  spec.static_press_frames = 3;
  const Scan press = ScanMaker(spec).Make();
  const FrictionMapResult pressed = BuilderFor(press).Build();
  EXPECT_EQ(pressed.summary.status, FrictionMapStatus::kNoSlip);
  EXPECT_GT(pressed.summary.vertices, 0);
  EXPECT_EQ(pressed.summary.unknown_fraction, 1.0);

  // One frame of a few markers: too few points to reconstruct.
  Scan single = press;
  FrictionMapBuilder few{FrictionMapOptions{}};
  TactileFrame frame = single.frames[1];
  int kept = 0;
  for (int i = 0; i < frame.num_markers(); ++i) {
    if (frame.contact[i] && kept < 10) {
      ++kept;
    } else {
      frame.forces_n[i].setZero();
    }
  }
  ASSERT_EQ(kept, 10);
  few.AddFrame(frame, single.poses[1]);
  EXPECT_EQ(few.Build().summary.status, FrictionMapStatus::kTooFewPoints);

  FrictionMapBuilder skipping{FrictionMapOptions{}};
  frame = single.frames[1];
  frame.initialize_progress = 50;
  skipping.AddFrame(frame, single.poses[1]);
  EXPECT_EQ(skipping.Build().summary.frames_skipped, 1);
  EXPECT_TRUE(skipping.surface_points().empty());
}

TEST(FrictionMapBuilder, BreakStrokeStopsSlipAcrossAJump) {
  ScanSpec spec;
  spec.strokes_y_mm = {};
  spec.static_press_frames = 2;
  const Scan press = ScanMaker(spec).Make();
  FrictionMapBuilder builder{FrictionMapOptions{}};
  builder.AddFrame(press.frames[1], press.poses[1]);
  Rigid3 moved = press.poses[2];
  moved.translation().x() += 5;
  builder.BreakStroke();
  builder.AddFrame(press.frames[2], moved);
  EXPECT_TRUE(builder.slip_points().empty());
  builder.AddFrame(press.frames[2], press.poses[2]);  // no break: every marker jumps back 5 mm
  EXPECT_FALSE(builder.slip_points().empty());
}

// A frame with markers pressed between the slip and the contact thresholds, then a 5 mm jump:
// AddFrameOfStrokes ends the stroke at that frame (no marker over the contact threshold), so the
// jump makes no slip point; AddFrame alone pairs the two frames.
TEST(FrictionMapBuilder, AddFrameOfStrokesBreaksWhereNoMarkerPresses) {
  ScanSpec spec;
  spec.strokes_y_mm = {};
  spec.static_press_frames = 2;
  const Scan press = ScanMaker(spec).Make();
  TactileFrame light = press.frames[1];
  for (Eigen::Vector3d& f : light.forces_n) f *= 0.15;  // F_n 0.0045-0.015 N
  Rigid3 moved = press.poses[2];
  moved.translation().x() += 5;
  FrictionMapOptions options;
  options.slip_contact_threshold_n = 0.004;
  FrictionMapBuilder strokes{options}, plain{options};
  strokes.AddFrameOfStrokes(light, press.poses[1]);
  strokes.AddFrameOfStrokes(press.frames[2], moved);
  EXPECT_TRUE(strokes.slip_points().empty());
  plain.AddFrame(light, press.poses[1]);
  plain.AddFrame(press.frames[2], moved);
  EXPECT_FALSE(plain.slip_points().empty());
  strokes.AddFrameOfStrokes(press.frames[2], press.poses[2]);  // pressed: no break
  EXPECT_FALSE(strokes.slip_points().empty());
}

TEST(FrictionMapBuilder, RefusesBadFramesAndPoses) {
  FrictionMapBuilder builder{FrictionMapOptions{}};
  TactileFrame frame = TactileFrame::Sized(20, 20);
  frame.index = 7;
  frame.timestamp_s = 0.25;
  Rigid3 scaled = Rigid3::Identity();
  scaled.linear() *= 2.0;
  try {
    builder.AddFrame(frame, scaled);
    ADD_FAILURE() << "a scaled pose was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(),
                HasSubstr("frame 7 (t = 0.25 s): world_from_sensor is not a rigid transform"));
  }
  // A pose far beyond any scan (it crashed the reconstruction), and a valid marker at NaN.
  Rigid3 far = Rigid3::Identity();
  far.translation() = Eigen::Vector3d(1e300, 0, 0);
  try {
    builder.AddFrame(frame, far);
    ADD_FAILURE() << "a pose 1e300 mm away was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("translation 1e+300 mm is over the 1000000 mm a friction map spans"));
  }
  frame.positions_mm[5].y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(builder.AddFrame(frame, Rigid3::Identity()), Error);
  frame.forces_n.pop_back();
  EXPECT_THROW(builder.AddFrame(frame, Rigid3::Identity()), Error);
}

// More threads than cores crashed Open3D's Poisson: they are run as one a core.
TEST_F(FrictionMapTwoRegions, MoreThreadsThanCoresBuildTheSameMap) {
  FrictionMapOptions options;
  options.num_threads = 2 * static_cast<int>(std::thread::hardware_concurrency()) + 1;
  const FrictionMapResult many = BuilderFor(*scan_, options).Build();
  EXPECT_EQ(many.summary.status, FrictionMapStatus::kOk) << many.summary.BriefReport();
  EXPECT_GT(many.summary.vertices, 1000);
}

}  // namespace
}  // namespace tac3d::friction
