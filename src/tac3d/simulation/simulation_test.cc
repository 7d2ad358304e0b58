#include "tac3d/simulation/simulation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include <nlohmann/json.hpp>

#include "tac3d/sensor/default_sensor.h"
#include "tac3d/sensor/test_sensor.h"
#include "tac3d/simulation/test_scenes.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::simulation {
namespace {

using ::testing::HasSubstr;
using testing::SmallTwinBody;
using testing::SmallTwinBodyAt;
using testing::SphereScene;

SimulationOptions NoImages() {
  SimulationOptions options;
  options.render_images = false;
  return options;
}

Eigen::Vector3d SumOfSurfaceForces(const TwinStep& step, double area) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& t : step.surface.tractions_mpa) sum += area * t;
  return sum;
}

TEST(TwinSimulation, PressThenSlideObeysContactAndFriction) {
  // Steps at t = 0, 0.2, ..., 2: separated, pressed 0.1 mm at t = 1, slid 0.5 mm by t = 2.
  const Scene scene =
      SphereScene({{0.0, {0, 0, -0.05}}, {1.0, {0, 0, 0.1}}, {2.0, {0.5, 0, 0.1}}}, 11);
  TwinSimulation sim(scene, SmallTwinBody(), NoImages());
  std::vector<TwinStep> steps;
  const SimulationSummary summary = sim.Run([&](const TwinStep& s) { steps.push_back(s); });
  ASSERT_EQ(steps.size(), 11u);
  EXPECT_EQ(summary.non_converged_steps, 0);
  EXPECT_EQ(summary.contact_at_grid_edge_steps, 0);
  const double area = SmallTwinBody()->grid.cell_area_mm2();

  // Separated: nothing.
  EXPECT_EQ(steps[0].solver.at("status"), "separated");
  EXPECT_EQ(steps[0].total_force_n, Eigen::Vector3d::Zero());

  const TwinStep& pressed = steps[5];
  EXPECT_LT(pressed.total_force_n.z(), -0.01);
  // Centred: no tangential force or moment beyond the coupling's rounding.
  EXPECT_LT(pressed.total_force_n.head<2>().norm(), 1e-3 * -pressed.total_force_n.z());
  for (const TwinStep* s : {&steps[5], &steps[10]}) {
    EXPECT_LT((SumOfSurfaceForces(*s, area) - s->total_force_n).norm(), 1e-12);
    Eigen::Vector3d moment = Eigen::Vector3d::Zero(), markers = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < s->surface.positions_mm.size(); ++i) {
      moment += s->surface.positions_mm[i].cross(area * s->surface.tractions_mpa[i]);
      EXPECT_LE(s->surface.tractions_mpa[i].z(), 0.0) << "a tensile pressure at node " << i;
    }
    for (const Eigen::Vector3d& f : s->marker_forces_n) markers += f;
    EXPECT_LT((moment - s->total_moment_nmm).norm(), 1e-9);
    // The contact (radius ~0.7 mm) lies inside the marker patches.
    EXPECT_LT((markers - s->total_force_n).norm(), 1e-12);
    EXPECT_LT(s->solver.at("max_penetration_mm").get<double>(), 1e-5);
  }
  // The centre marker moves in (down) under the press; its neighbours less.
  const std::vector<Eigen::Vector3d>& rest = SmallTwinBody()->marker_positions;
  const double centre_dz = pressed.marker_positions_mm[4].z() - rest[4].z();
  EXPECT_LT(centre_dz, -0.01);
  EXPECT_GT(pressed.marker_positions_mm[1].z() - rest[1].z(), centre_dz);

  // Slid 0.5 mm: gross sliding, the object drags the surface along -x (its motion relative to
  // the sensor) with |Q| = mu P, and every slipping node has |q| = mu p.
  const TwinStep& slid = steps[10];
  EXPECT_NEAR(slid.total_force_n.x() / slid.total_force_n.z(), 0.3, 0.3 * 0.02);
  EXPECT_LT(slid.total_force_n.x(), 0.0);
  int slipping = 0;
  for (size_t i = 0; i < slid.surface.states.size(); ++i) {
    if (slid.surface.states[i] != tac3d::ContactState::kSlip) continue;
    ++slipping;
    const Eigen::Vector3d& t = slid.surface.tractions_mpa[i];
    EXPECT_NEAR(t.head<2>().norm(), 0.3 * -t.z(), 1e-4 * -t.z() + 1e-9) << i;
  }
  EXPECT_GT(slipping, 0);
  EXPECT_EQ(slid.marker_slip[4], 1);
  // The friction truth: the sphere's mu at every node that touches it, NaN elsewhere.
  ASSERT_EQ(slid.surface.friction.size(), slid.surface.states.size());
  for (size_t i = 0; i < slid.surface.states.size(); ++i) {
    if (slid.surface.states[i] == tac3d::ContactState::kSeparated) {
      EXPECT_TRUE(std::isnan(slid.surface.friction[i])) << i;
    } else {
      EXPECT_EQ(slid.surface.friction[i], 0.3) << i;
    }
  }
}

std::vector<TwinStep> RunAll(const Scene& scene,
                             std::shared_ptr<const TwinBodyModel> model,
                             const SimulationOptions& options) {
  std::vector<TwinStep> steps;
  TwinSimulation(scene, std::move(model), options).Run([&](const TwinStep& s) {
    steps.push_back(s);
  });
  return steps;
}

double MaxMarkerDifference(const TwinStep& a, const TwinStep& b) {
  double d = 0.0;
  for (size_t m = 0; m < a.marker_positions_mm.size(); ++m) {
    d = std::max(d, (a.marker_positions_mm[m] - b.marker_positions_mm[m]).norm());
  }
  return d;
}

TEST(TwinSimulation, YoungsModulusScaleIsTheModelBuiltAtThatModulus) {
  // Pressed 0.1 mm, then slid into gross slip. The contact is displacement-driven: at 2E the
  // same indentation takes twice the tractions and forces, and moves the markers as much.
  const Scene scene =
      SphereScene({{0.0, {0, 0, -0.05}}, {1.0, {0, 0, 0.1}}, {2.0, {0.5, 0, 0.1}}}, 11);
  SimulationOptions doubled = NoImages();
  doubled.youngs_modulus_scale = 2.0;
  const std::vector<TwinStep> at_e = RunAll(scene, SmallTwinBody(), NoImages());
  const std::vector<TwinStep> scaled = RunAll(scene, SmallTwinBody(), doubled);
  const std::vector<TwinStep> built = RunAll(scene, SmallTwinBodyAt(2.0), NoImages());
  ASSERT_EQ(scaled.size(), at_e.size());
  ASSERT_EQ(built.size(), at_e.size());
  for (size_t k = 5; k < at_e.size(); ++k) {
    const double f = at_e[k].total_force_n.norm();
    ASSERT_GT(f, 0.01) << "step " << k << " is not in contact";
    EXPECT_LT((scaled[k].total_force_n - 2.0 * at_e[k].total_force_n).norm(), 1e-4 * f) << k;
    EXPECT_LT((scaled[k].total_force_n - built[k].total_force_n).norm(), 1e-4 * f) << k;
    EXPECT_LT(MaxMarkerDifference(scaled[k], at_e[k]), 1e-6) << k;
    EXPECT_LT(MaxMarkerDifference(scaled[k], built[k]), 1e-6) << k;
    EXPECT_EQ(scaled[k].surface.states, at_e[k].surface.states) << k;
  }
}

TEST(TwinSimulation, ContactOptionsReachTheSolverWindowedOrNot) {
  // Pressed 0.01 mm: a contact on a small part of the 13 x 13 grid, solved on a window around it
  // unless the options turn windows off (tac3d simulate --no-window).
  const Scene scene = SphereScene({{0.0, {0, 0, 0.01}}, {1.0, {0, 0, 0.01}}}, 2);
  SimulationOptions whole_grid = NoImages();
  whole_grid.contact.windowed = false;
  TwinSimulation windowed_sim(scene, SmallTwinBody(), NoImages());
  TwinSimulation whole_sim(scene, SmallTwinBody(), whole_grid);
  const TwinStep windowed = windowed_sim.Step();
  const TwinStep whole = whole_sim.Step();
  const contact::SurfaceGrid& grid = whole_sim.compliance().grid();
  ASSERT_EQ(whole.solver["status"], "converged");
  EXPECT_EQ(whole.solver["window"], nlohmann::json::array({grid.nx, grid.ny}));
  EXPECT_LT(windowed.solver["window"][0].get<int>() * windowed.solver["window"][1].get<int>(),
            grid.num_nodes()) << windowed.solver.dump();
  EXPECT_LT((windowed.total_force_n - whole.total_force_n).norm(),
            1e-6 * whole.total_force_n.norm());
}

TEST(TwinSimulation, HistoryCarriesTheShiftFromStepToStep) {
  // Pressed, then shifted 0.02 mm (partial slip): the tangential force comes from the history.
  const Scene moved = SphereScene({{0.0, {0, 0, 0.1}}, {1.0, {0.02, 0, 0.1}}}, 5);
  TwinSimulation with_history(moved, SmallTwinBody(), NoImages());
  TwinStep last;
  with_history.Run([&](const TwinStep& s) { last = s; });
  // The object moved -0.02 mm in the sensor frame, accumulated over 4 increments.
  EXPECT_NEAR(with_history.state().shift_mm.x(), -0.02, 1e-12);
  EXPECT_NEAR(with_history.state().shift_mm.y(), 0.0, 1e-12);
  // The same final pose pressed from unloaded has (almost) no tangential force.
  const Scene fresh = SphereScene({{0.0, {0.02, 0, 0.1}}, {1.0, {0.02, 0, 0.1}}}, 2);
  TwinSimulation without(fresh, SmallTwinBody(), NoImages());
  const TwinStep only = without.Step();
  EXPECT_LT(last.total_force_n.x(), 0.0);
  EXPECT_GT(std::abs(last.total_force_n.x()), 20.0 * std::abs(only.total_force_n.x()));
  // Partial slip: below the friction limit.
  EXPECT_LT(std::abs(last.total_force_n.x()), 0.3 * -last.total_force_n.z());
  // Lifting off resets the state.
  const Scene lift = SphereScene({{0.0, {0, 0, 0.1}}, {1.0, {0, 0, -0.2}}}, 2);
  TwinSimulation lifted(lift, SmallTwinBody(), NoImages());
  lifted.Step();
  EXPECT_GT(lifted.state().pressure_mpa.maxCoeff(), 0.0);
  lifted.Step();
  EXPECT_EQ(lifted.state().pressure_mpa.maxCoeff(), 0.0);
}

TEST(TwinSimulation, TangentialLoadRampsThroughPartialSlipIntoGrossSlip) {
  // Pressed 0.1 mm by t = 1, held; from t = 1 a tangential load along 30 deg rises at 0.6 mu P
  // a second to 1.2 mu P (reached at t = 3; mu P at t = 2.67). Steps every 0.1 s.
  Scene scene = SphereScene({{0.0, {0, 0, -0.05}}, {1.0, {0, 0, 0.1}}, {3.0, {0, 0, 0.1}}}, 31);
  TangentialLoadRamp ramp;
  ramp.start_s = 1.0;
  ramp.rate_per_s = 0.6;
  ramp.final_load = 1.2;
  ramp.direction_deg = 30.0;
  scene.trajectory.tangential_load = ramp;
  TwinSimulation sim(scene, SmallTwinBody(), NoImages());
  std::vector<TwinStep> steps;
  const SimulationSummary summary = sim.Run([&](const TwinStep& s) { steps.push_back(s); });
  ASSERT_EQ(steps.size(), 31u);
  EXPECT_EQ(summary.non_converged_steps, 0);
  EXPECT_EQ(summary.contact_at_grid_edge_steps, 0);
  const double mu = 0.3;
  const Eigen::Vector2d direction = ramp.Direction();
  int partial = 0, gross = 0;
  double previous_q = 0.0;
  for (size_t k = 10; k < steps.size(); ++k) {
    SCOPED_TRACE(k);
    const TwinStep& s = steps[k];
    const double p = -s.total_force_n.z();
    ASSERT_GT(p, 0.01);
    const Eigen::Vector2d q = s.total_force_n.head<2>();
    // The true load is the one asked for (of the previous step's capacity: P is held to
    // ~1 %), capped by the capacity, along the load's direction.
    const double load = ramp.LoadAt(s.t_s);
    EXPECT_NEAR(q.norm() / (mu * p), std::min(load, 1.0), 0.02);
    if (load > 0.05) {
      EXPECT_GT(q.normalized().dot(direction), 0.9999);
    }
    EXPECT_GE(q.norm(), previous_q - 1e-3 * mu * p);
    previous_q = q.norm();
    int stick = 0, slip = 0;
    for (const tac3d::ContactState state : s.surface.states) {
      stick += state == tac3d::ContactState::kStick;
      slip += state == tac3d::ContactState::kSlip;
    }
    ASSERT_GT(stick + slip, 0);
    if (load <= 0.9) {
      EXPECT_GT(stick, 0) << "stuck at " << load << " mu P";
    }
    if (load >= 0.3 && load <= 0.9) {
      EXPECT_GT(slip, 0) << "no partial slip at " << load << " mu P";
    }
    if (load > 1.0) {
      EXPECT_EQ(stick, 0) << "not sliding as a whole at " << load << " mu P";
    }
    partial += stick > 0 && slip > 0;
    gross += stick == 0;
  }
  EXPECT_GE(partial, 8);
  EXPECT_GE(gross, 4);
  EXPECT_EQ(summary.gross_sliding_steps, gross);
  // The load drags the object along its direction: the sensor moved the other way in x-y, and
  // the pose held while it slid as a whole.
  const Eigen::Vector2d moved = steps[26].world_from_sensor.translation().head<2>();
  EXPECT_GT(moved.norm(), 1e-3);
  EXPECT_LT(moved.normalized().dot(direction), -0.9999);
  EXPECT_EQ(steps.back().world_from_sensor.translation(), steps[27].world_from_sensor.translation());
}

int CountNodes(const TwinStep& step, tac3d::ContactState state) {
  return static_cast<int>(
      std::count(step.surface.states.begin(), step.surface.states.end(), state));
}

TEST(TwinSimulation, CallersLoadsPressAndLoadTheContactStepByStep) {
  // The sphere (mu 0.3) placed just touching and held there; a controller's loads each step.
  const Scene scene = SphereScene({{0.0, {0, 0, 0}}, {1.0, {0, 0, 0}}}, 6);
  TwinSimulation sim(scene, SmallTwinBody(), NoImages());
  const double mu = 0.3;
  auto step = [&](double p, double qx) { return sim.Step(StepLoads{p, {qx, 0.0}}); };

  const TwinStep free = step(0.0, 0.0);  // no normal force: nothing touches
  EXPECT_EQ(free.total_force_n, Eigen::Vector3d::Zero());
  EXPECT_EQ(free.solver["status"], "separated");

  const TwinStep pressed = step(0.5, 0.0);
  EXPECT_NEAR(-pressed.total_force_n.z(), 0.5, 1e-3);
  EXPECT_NEAR(pressed.total_force_n.head<2>().norm(), 0.0, 1e-6);

  // Q = 0.1 N < mu P = 0.15 N: held, the centre stuck, the rim slipping.
  const TwinStep held = step(0.5, 0.1);
  EXPECT_EQ(held.solver["status"], "converged");
  EXPECT_NEAR(held.total_force_n.x(), 0.1, 1e-4);
  EXPECT_NEAR(held.total_force_n.y(), 0.0, 1e-4);
  EXPECT_GT(CountNodes(held, tac3d::ContactState::kStick), 0);
  EXPECT_GT(CountNodes(held, tac3d::ContactState::kSlip), 0);

  // Q = 0.2 N > mu P: the contact slides as a whole, carrying mu P, the object where it began.
  const TwinStep slid = step(0.5, 0.2);
  // A step's pose is where its object was placed: the next step's shows the held load's drag,
  // along +x, so the sensor moved along -x.
  const Eigen::Vector3d dragged =
      slid.world_from_sensor.translation() - held.world_from_sensor.translation();
  EXPECT_LT(dragged.x(), -1e-3);
  EXPECT_NEAR(dragged.y(), 0.0, 1e-9);
  EXPECT_EQ(slid.solver["status"], "gross sliding");
  EXPECT_EQ(CountNodes(slid, tac3d::ContactState::kStick), 0);
  EXPECT_NEAR(slid.total_force_n.x(), mu * -slid.total_force_n.z(), 1e-3);

  // Squeezed harder, the same load holds again.
  const TwinStep regripped = step(1.0, 0.2);
  EXPECT_EQ(regripped.solver["status"], "converged");
  EXPECT_NEAR(-regripped.total_force_n.z(), 1.0, 2e-3);
  EXPECT_NEAR(regripped.total_force_n.x(), 0.2, 1e-4);
  EXPECT_GT(CountNodes(regripped, tac3d::ContactState::kStick), 0);

  step(1.0, 0.2);
  EXPECT_THROW(
      {
        try {
          step(1.0, 0.2);
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), HasSubstr("all 6 steps of scene 'sphere' are simulated"));
          throw;
        }
      },
      Error);
  EXPECT_THROW(sim.Step(), Error);  // the trajectory's step, as the caller's: none left
}

TEST(TwinSimulation, CallersLoadsAreChecked) {
  Scene scene = SphereScene({{0.0, {0, 0, 0}}, {1.0, {0, 0, 0}}}, 3);
  TwinSimulation sim(scene, SmallTwinBody(), NoImages());
  EXPECT_THROW(
      {
        try {
          sim.Step(StepLoads{-1.0, {0.0, 0.0}});
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), HasSubstr("StepLoads.normal_force_n must be in [0, 1000] N, got -1"));
          throw;
        }
      },
      Error);
  EXPECT_THROW(
      {
        try {
          sim.Step(StepLoads{1.0, {std::nan(""), 0.0}});
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), HasSubstr("StepLoads.tangential_force_n must be at most 1000 N long"));
          throw;
        }
      },
      Error);
  // 1e160 N overflowed into a zero tangential force and no slip.
  EXPECT_THAT([&] { sim.Step(StepLoads{1.0, {1e160, 0.0}}); },
              ::testing::ThrowsMessage<Error>(
                  HasSubstr("StepLoads.tangential_force_n must be at most 1000 N long, got (1e+160, 0)")));
  scene.trajectory.tangential_load = TangentialLoadRamp{};
  TwinSimulation ramped(scene, SmallTwinBody(), NoImages());
  EXPECT_THROW(
      {
        try {
          ramped.Step(StepLoads{1.0, {0.0, 0.0}});
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), HasSubstr("has a trajectory.tangential_load"));
          throw;
        }
      },
      Error);
}

TEST(TwinSimulation, WritesADatasetTheReaderReadsBack) {
  const Scene scene = SphereScene({{0.0, {0, 0, -0.05}}, {1.0, {0.1, 0, 0.1}}}, 4);
  SimulationOptions options;  // with images
  TwinSimulation sim(scene, SmallTwinBody(), options);
  const std::string dir = testing::MakeTempDir("simulation") + "/run";
  std::vector<TwinStep> steps;
  {
    TwinDatasetWriter writer(dir, {{"name", scene.name}});
    const SimulationSummary summary = sim.Run([&](const TwinStep& s) {
      writer.Write(s);
      steps.push_back(s);
    });
    writer.UpdateHeader({{"summary", ToJson(summary)}});
    EXPECT_GT(summary.timings.render_s, 0.0);
    EXPECT_GT(summary.timings.write_s, 0.0);
  }
  const TwinDatasetReader reader(dir);
  ASSERT_EQ(reader.steps(), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(reader.header().at("summary").at("steps"), 4);
  const TwinStep got = reader.Read(3, /*with_surface=*/true);
  EXPECT_EQ(got.marker_positions_mm, steps[3].marker_positions_mm);
  EXPECT_EQ(got.total_force_n, steps[3].total_force_n);
  EXPECT_EQ(got.surface.tractions_mpa, steps[3].surface.tractions_mpa);
  EXPECT_EQ(got.solver, steps[3].solver);
  EXPECT_EQ(got.image.size(), cv::Size(640, 480));
  EXPECT_LT(got.total_force_n.z(), 0.0);
}

// A session's nuisances: each step carries its truth, the markers have crept, the image is
// darker, and the dataset keeps it.
TEST(TwinSimulation, ConditionsGiveEachStepItsTruth) {
  Scene scene = SphereScene({{0.0, {0, 0, -0.5}}, {1.0, {0, 0, -0.5}}}, 3);  // clear of the ball
  const TwinStep nominal = TwinSimulation(scene, SmallTwinBody()).Step();
  scene.conditions.session_s = 1.0;
  scene.conditions.illumination_gain = 0.5;
  scene.conditions.creep_mm = 0.02;
  TwinSimulation sim(scene, SmallTwinBody());
  const TwinStep first = sim.Step();
  EXPECT_TRUE(first.conditions.is_null());  // t = 0: nothing yet
  sim.Step();
  const TwinStep last = sim.Step();  // t = 1 s: the session's end
  ASSERT_FALSE(last.conditions.is_null());
  EXPECT_DOUBLE_EQ(last.conditions.at("illumination_gain").get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(last.conditions.at("creep_mm")[2].get<double>(), -0.02);
  for (size_t m = 0; m < last.marker_positions_mm.size(); ++m) {
    EXPECT_TRUE(last.marker_positions_mm[m].isApprox(
        nominal.marker_positions_mm[m] + Eigen::Vector3d(0, 0, -0.02), 1e-12));
  }
  EXPECT_LT(cv::mean(last.image)[0], 0.6 * cv::mean(first.image)[0]);

  const std::string dir = testing::MakeTempDir("simulation_conditions") + "/run";
  TwinDatasetWriter(dir, {{"name", scene.name}}).Write(last);
  EXPECT_EQ(TwinDatasetReader(dir).Read(last.index).conditions, last.conditions);
}

TEST(TwinSimulation, BadInputsThrowWithClearMessages) {
  const Scene scene = SphereScene({{0.0, {0, 0, 0}}, {1.0, {0, 0, 0.1}}}, 2);
  SimulationOptions stiffness = NoImages();
  stiffness.youngs_modulus_scale = 0.0;
  EXPECT_THROW(
      {
        try {
          TwinSimulation(scene, SmallTwinBody(), stiffness);
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), HasSubstr("youngs_modulus_scale must be in (0, 10], got 0"));
          throw;
        }
      },
      Error);
  SimulationOptions bad = NoImages();
  bad.max_steps = -1;
  EXPECT_THROW(
      {
        try {
          TwinSimulation(scene, SmallTwinBody(), bad);
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), HasSubstr("max_steps"));
          throw;
        }
      },
      Error);
  Scene other = scene;
  other.sensor = DefaultSensorConfig();  // 20 x 20 markers
  EXPECT_THROW(
      {
        try {
          TwinSimulation(other, SmallTwinBody(), NoImages());
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), HasSubstr("3 x 3 markers, the scene's sensor 20 x 20"));
          throw;
        }
      },
      Error);
  Scene empty = scene;
  empty.objects.clear();
  EXPECT_THROW(TwinSimulation(empty, SmallTwinBody(), NoImages()), Error);
  SimulationOptions limited = NoImages();
  limited.max_steps = 1;
  EXPECT_EQ(TwinSimulation(scene, SmallTwinBody(), limited).num_steps(), 1);
}

}  // namespace
}  // namespace tac3d::simulation
