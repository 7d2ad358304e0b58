#include "tac3d/fem/elastic_solver.h"

#include <SuiteSparse_config.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::fem {
namespace {

// A cantilever-like bar fixed at x = 0.
struct Bar {
  HexMesh mesh = BuildBoxMesh({0, 1, 2, 3, 4}, {0, 1}, {0, 0.5, 1});
  std::vector<bool> fixed = std::vector<bool>(mesh.num_dofs(), false);
  Bar() {
    for (int n = 0; n < mesh.num_nodes(); ++n) {
      if (mesh.nodes[n].x() == 0.0) {
        for (int c = 0; c < 3; ++c) fixed[3 * n + c] = true;
      }
    }
  }
};

TEST(ElasticSolver, ResponseInChunksMatchesSingleSolves) {
  const Bar bar;
  const ElasticSolver solver(bar.mesh, ElasticMaterial{1.0, 0.48}, bar.fixed);
  const int cases = 7;
  Eigen::SparseMatrix<double> forces(bar.mesh.num_dofs(), cases);
  for (int k = 0; k < cases; ++k)
    forces.insert(3 * (bar.mesh.num_nodes() - 1 - k) + k % 3, k) = 1.0;
  Eigen::SparseMatrix<double> readout(2, bar.mesh.num_dofs());
  readout.insert(0, 3 * (bar.mesh.num_nodes() - 1) + 2) = 1.0;
  readout.insert(1, 3 * 5 + 0) = 0.5;
  const Eigen::MatrixXd response = solver.CalcResponse(readout, forces, false, 3);
  for (int k = 0; k < cases; ++k) {
    const Eigen::VectorXd u = solver.Solve(Eigen::VectorXd(forces.col(k)));
    EXPECT_THAT(response.col(k), EigenNear(readout * u, 1e-12)) << "case " << k;
  }
  // The response is not trivially zero: the tip moves under a tip load.
  EXPECT_GT(response.cwiseAbs().maxCoeff(), 1.0);
  EXPECT_EQ(solver.summary().num_fixed_dofs, 3 * 6);
  EXPECT_EQ(solver.summary().num_free_dofs, bar.mesh.num_dofs() - 3 * 6);
}

TEST(ElasticSolver, FixedDofsKeepTheirPrescribedValues) {
  const Bar bar;
  const ElasticSolver solver(bar.mesh, ElasticMaterial{1.0, 0.3}, bar.fixed);
  Eigen::VectorXd prescribed = Eigen::VectorXd::Zero(bar.mesh.num_dofs());
  for (int n = 0; n < bar.mesh.num_nodes(); ++n) prescribed(3 * n + 1) = 0.25;
  // A rigid translation of the support with no load moves everything rigidly.
  const Eigen::VectorXd u = solver.Solve(Eigen::VectorXd::Zero(bar.mesh.num_dofs()), prescribed);
  EXPECT_THAT(u, EigenNear(prescribed, 1e-12));
}

TEST(ElasticSolver, ThrowsWhenRigidMotionIsFree) {
  const Bar bar;
  std::vector<bool> none(bar.mesh.num_dofs(), false);
  // The singular stiffness is not positive definite: CHOLMOD's factorisation stops at a pivot.
  EXPECT_THAT([&] { ElasticSolver(bar.mesh, ElasticMaterial{}, none); },
              ::testing::ThrowsMessage<Error>(::testing::AllOf(
                  ::testing::HasSubstr("factorisation of the 90 x 90 free-DOF stiffness"),
                  ::testing::HasSubstr("not positive definite"))));
  std::vector<bool> all(bar.mesh.num_dofs(), true);
  EXPECT_THROW(ElasticSolver(bar.mesh, ElasticMaterial{}, all), Error);
}

// CHOLMOD's allocator failing: the analysis then returns no factor, as it does when the factor
// of a 1.26 million-DOF mesh overflows its 32-bit indices ("problem too large"), which costs
// minutes and gigabytes to reach honestly. Eigen would factorise through the null factor.
TEST(ElasticSolver, ThrowsWhenCholmodsAnalysisFails) {
  const Bar bar;
  struct FailingAllocator {
    decltype(SuiteSparse_config.malloc_func) saved = SuiteSparse_config.malloc_func;
    FailingAllocator() {
      SuiteSparse_config.malloc_func = [](size_t) -> void* { return nullptr; };
    }
    ~FailingAllocator() { SuiteSparse_config.malloc_func = saved; }
  };
  const auto build = [&] {
    const FailingAllocator failing;
    ElasticSolver(bar.mesh, ElasticMaterial{}, bar.fixed);
  };
  EXPECT_THAT(build,
              ::testing::ThrowsMessage<Error>(::testing::AllOf(
                  ::testing::HasSubstr("analysis of the 72 x 72 free-DOF stiffness matrix"),
                  ::testing::HasSubstr("out of memory"))));
  // The allocator restored, the same system factors.
  EXPECT_NO_THROW(ElasticSolver(bar.mesh, ElasticMaterial{}, bar.fixed));
}

TEST(ElasticSolver, ThrowsOnBadInput) {
  const Bar bar;
  EXPECT_THROW(ElasticSolver(bar.mesh, ElasticMaterial{}, std::vector<bool>(5, true)), Error);
  EXPECT_THROW(ElasticSolver(bar.mesh, ElasticMaterial{1.0, 0.5}, bar.fixed), Error);
}

}  // namespace
}  // namespace tac3d::fem
