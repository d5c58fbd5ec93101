// The one-step map U^{n+1} = G U^n + f (engine/analysis/step_map.hpp), behind tsph spectrum.
#include "engine/case/case_build.hpp"
#include "engine/lattice.hpp"
#include "engine/analysis/step_map.hpp"

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include <functional>
#include <random>
#include <tuple>

namespace tsph {
namespace {

// The 1D bar (fixed left end, free right end, alpha 0.6): a solver and its dt.
struct Bar {
  std::unique_ptr<TaylorSph<1>> solver;
  double dt = 0.0;
};
Bar make_bar(int particles, double cfl, double alpha = 0.6, bool left_free = false, bool right_free = true,
             const std::function<double(double)>& initial_velocity = {}) {
  const double dx = 1.0 / (particles - 1), density = 2000.0, young = 8e7;
  LatticeBox<1> box;
  box.lower[0] = 0.0;
  box.node_count = {particles};
  box.spacing = dx;
  ParticleSet<1> real = make_real_lattice(box, density);
  if (initial_velocity)
    for (std::size_t i = 0; i < real.size(); ++i) real.velocity[0][i] = initial_velocity(real.position[0][i]);
  ParticleSet<1> virtual_particles = make_virtual_lattice(box, density);
  std::vector<BoundaryCondition<1>> boundaries{
      left_free ? BoundaryCondition<1>::free("left") : BoundaryCondition<1>::fixed("left"),
      right_free ? BoundaryCondition<1>::free("right") : BoundaryCondition<1>::fixed("right")};
  real.boundary.front() = 0;
  real.boundary.back() = 1;
  SolverSettings<1> settings;
  settings.smoothing_length = alpha * dx;
  Bar bar;
  bar.solver = std::make_unique<TaylorSph<1>>(std::move(real), std::move(virtual_particles),
                                              LinearElastic<1>(young, 0.0, density), settings, boundaries);
  bar.dt = cfl * dx / std::sqrt(young / density);
  return bar;
}

double spectral_radius(const Eigen::MatrixXd& map) {
  return Eigen::EigenSolver<Eigen::MatrixXd>(map, false).eigenvalues().cwiseAbs().maxCoeff();
}

// At CFL 1 the bar's scheme (Richtmyer's Lax-Wendroff with characteristic ends) is
// exact: its map is a permutation-like shift, every |lambda| <= 1. Above CFL 1 it is
// unstable: an eigenvalue leaves the unit circle. (A map that lost a coupling, or
// a wrong column, would fail one or the other.)
TEST(StepMap, BarIsStableAtCfl1AndUnstableAbove) {
  Bar stable = make_bar(41, 1.0);
  const auto layout = step_map_layout(*stable.solver, stable.dt);
  ASSERT_EQ(layout.unknowns.size(), 82u);
  const double radius = spectral_radius(assemble_step_map(*stable.solver, layout, 0.0, stable.dt));
  EXPECT_LE(radius, 1.0 + 1e-12);
  EXPECT_GT(radius, 1.0 - 1e-6);  // the undamped bar keeps its energy at CFL 1

  Bar unstable = make_bar(41, 1.1);
  const auto layout2 = step_map_layout(*unstable.solver, unstable.dt);
  EXPECT_GT(spectral_radius(assemble_step_map(*unstable.solver, layout2, 0.0, unstable.dt)), 1.01);
}

// At alpha >= 1 the ends' characteristic relations took their normal derivatives from
// the real set at n (forward Euler along the normal), and the bar's lowest standing waves
// grew: 1 + 1.59e-3 per step with both ends free (11 particles, alpha 1.2, CFL 0.9),
// 1 + 6.8e-4 fixed-free, 1 + 1.3e-4 at 41 particles. With the virtual set's at n+1/2
// every |lambda| is 1 to round-off (docs/notes/2026-12-06-alpha12-boundary-energy.md).
TEST(StepMap, BarEndsKeepTheEnergyAtAlpha12) {
  for (const auto& [particles, cfl, left_free] : {std::tuple{11, 0.9, true}, std::tuple{11, 0.5, true},
                                                   std::tuple{11, 0.9, false}, std::tuple{41, 0.9, true}}) {
    Bar bar = make_bar(particles, cfl, 1.2, left_free, true);
    const auto layout = step_map_layout(*bar.solver, bar.dt);
    EXPECT_LE(spectral_radius(assemble_step_map(*bar.solver, layout, 0.0, bar.dt)), 1.0 + 1e-6)
        << particles << " particles, CFL " << cfl << (left_free ? ", both ends free" : ", fixed-free");
  }
}

// A bar with both ends fixed, set breathing (v = x - L/2), alpha 1.2: its energy must not
// grow. With the virtual set's n+1/2 derivative of the velocity at the fixed ends too, a
// steady velocity field whose virtual gradient is uniform made the mean stress drift
// linearly: E / E0 reached 100 in 1000 steps at 11 particles, CFL 0.9 (a Jordan block at
// the eigenvalue 1: the spectral radius of BarEndsKeepTheEnergyAtAlpha12 stays 1).
// docs/notes/2026-12-06-boundary-second-order-tries.md.
TEST(StepMap, FixedFixedBarAtAlpha12DoesNotDrift) {
  for (const auto& [particles, cfl] : {std::pair{11, 0.9}, std::pair{11, 0.5}, std::pair{21, 0.9}, std::pair{41, 0.5}}) {
    Bar bar = make_bar(particles, cfl, 1.2, false, false, [](double x) { return x - 0.5; });
    TaylorSph<1>& solver = *bar.solver;
    const double dt = bar.dt;
    const double e0 = solver.kinetic_energy() + solver.strain_energy();
    double largest = 0.0;
    for (int k = 0; k < 3000; ++k) {
      solver.step(dt);
      largest = std::max(largest, solver.kinetic_energy() + solver.strain_energy());
    }
    EXPECT_LE(largest, e0) << particles << " particles, CFL " << cfl;
  }
}

// G U + f equals one ordinary solver step from U (the map is the step, and affine):
// the 2D cantilever, 21 x 3, a random state, under the full load.
TEST(StepMap, CantileverMapReproducesAStep) {
  // The 2D cantilever case at dx = 0.05 (21 x 3), under the full load (after the ramp).
  const CaseFile c = load_case(TSPH_SOURCE_DIR "/tools/cases/cantilever_2d.toml", {"geometry.spacing=0.05"});
  BuiltCase<2> built = build_case<2>(c);
  TaylorSph<2> solver = make_solver(c, built);
  const double dt = built.dt, t = 1.0;
  const auto layout = step_map_layout(solver, dt);
  // Plane stress: sxx, syy, sxy, vx, vy, and ux, uy for the hourglass stiffness (on by
  // default in 2D, as are the wall clamp and the surface extrapolation).
  ASSERT_EQ(layout.unknowns.size(), 21u * 3u * 7u);
  const Eigen::MatrixXd map = assemble_step_map(solver, layout, 0.0, dt);
  const auto n = static_cast<Eigen::Index>(layout.unknowns.size());
  const Eigen::VectorXd load = apply_step(solver, layout, Eigen::VectorXd::Zero(n), t, dt);
  EXPECT_GT(load.norm(), 0.0);
  std::mt19937 random(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Eigen::VectorXd state(n);
  for (Eigen::Index k = 0; k < n; ++k) state[k] = uniform(random);
  const Eigen::VectorXd stepped = apply_step(solver, layout, state, t, dt);
  EXPECT_LT((map * state + load - stepped).norm(), 1e-12 * stepped.norm());
}

// The hourglass stiffness's kick (SolverSettings::hourglass_kick) on the step map of
// the oscillating plate (tools/cases/plate_2d.toml at dx = 0.004, 51 x 6, small strain,
// alpha 1.2, stiffness 0.05): with the kick at u^n + dt/2 v^n (midpoint) a
// through-thickness mode of 0.48 rad per step grows by 2.1e-4 per step; with the kick
// at the displacement the step is heading for (predicted, the default) no mode of more
// than 0.1 rad per step leaves the unit circle. (The plate's bending mode, 1.4e-3 rad per
// step, grows by 5.3e-6 either way: the surface extrapolation's, issue 14.) Label slow:
// two 2 448 x 2 448 eigenvalue problems.
double largest_fast_eigenvalue(const std::string& kick) {
  const CaseFile c = load_case(TSPH_SOURCE_DIR "/tools/cases/plate_2d.toml",
                               {"geometry.spacing=0.004", "method.kinematics=small_strain", "method.alpha=1.2",
                                "method.hourglass_kick=\"" + kick + "\""});
  BuiltCase<2> built = build_case<2>(c);
  TaylorSph<2> solver = make_solver(c, built);
  const auto layout = step_map_layout(solver, built.dt);
  const Eigen::MatrixXd map = assemble_step_map(solver, layout, 0.0, built.dt);
  const Eigen::VectorXcd lambda = Eigen::EigenSolver<Eigen::MatrixXd>(map, false).eigenvalues();
  double largest = 0.0;
  for (Eigen::Index k = 0; k < lambda.size(); ++k)
    if (std::abs(std::arg(lambda[k])) > 0.1) largest = std::max(largest, std::abs(lambda[k]));
  return largest;
}

TEST(StepMap, PlateHourglassKickDampsTheThroughThicknessMode) {
  EXPECT_LE(largest_fast_eigenvalue("predicted"), 1.0 + 1e-9);
  EXPECT_GT(largest_fast_eigenvalue("midpoint"), 1.0 + 1e-4);
}

}  // namespace
}  // namespace tsph
