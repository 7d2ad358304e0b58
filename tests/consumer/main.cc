// Builds a half-space compliance and solves one Hertz press with the installed tac3d, then
// checks the contact radius against Hertz's: the Eigen objects cross the library boundary
// in both directions (shared_ptr to a compliance, matrices and vectors in the results).
#include <tac3d/contact/compliance.h>
#include <tac3d/contact/contact_solver.h>
#include <tac3d/contact/indenter.h>

#include <cmath>
#include <cstdio>
#include <memory>

int main() {
  using namespace tac3d::contact;
  const tac3d::ElasticMaterial material{1.0, 0.48};
  const double radius_mm = 10.0, force_n = 1.0;
  const double hertz_radius_mm = std::cbrt(3.0 * force_n * radius_mm * (1.0 - 0.48 * 0.48) / 4.0);
  const SurfaceGrid grid{25, 25, hertz_radius_mm / 8.0, hertz_radius_mm / 8.0};
  const ContactSolver solver(std::make_shared<HalfSpaceCompliance>(grid, material));
  ContactStep step;
  step.gap_mm = Indenter::Sphere(radius_mm).CalcGap(grid, Eigen::Vector2d::Zero());
  step.friction_coefficient = Eigen::VectorXd::Constant(grid.num_nodes(), 0.5);
  step.normal_force_n = force_n;
  const ContactResult result = solver.Solve(step, ContactState::Unloaded(grid.num_nodes()));
  const double area_mm2 = result.summary.num_contact * grid.cell_area_mm2();
  const double radius_error = std::sqrt(area_mm2 / M_PI) / hertz_radius_mm - 1.0;
  std::printf("status %s, normal force %.6f N, contact radius vs Hertz %+.2f%%\n",
              ToString(result.summary.status).c_str(),
              result.state.normal_force_n,
              100 * radius_error);
  const bool ok = result.summary.status == ContactStatus::kConverged &&
                  std::abs(result.state.normal_force_n - force_n) < 1e-9 &&
                  std::abs(radius_error) < 0.1;
  return ok ? 0 : 1;
}
