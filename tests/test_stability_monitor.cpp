// The stability monitor's physical bounds (issue 14, item 4; docs/reliability.md,
// "Unphysical state"): for each criterion a state just past its bound is stopped with a
// diagnosis naming the particle, the criterion, the value and the bound, and a state just
// inside it (or a legitimate large deformation) passes. The states are set on a solver's
// state and checked directly (TaylorSph::check_stability), so the bounds are tested
// exactly; one run per criterion goes through step() end to end.
#include "engine/lattice.hpp"
#include "engine/region.hpp"
#include "engine/taylor_sph.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <regex>
#include <string>

namespace tsph {
namespace {

constexpr double kDensity = 2000.0;
constexpr double kYoung = 8e7;
constexpr double kDx = 0.01;
constexpr int kNodes = 15;  // 15 x 15 real particles, 14 x 14 virtual ones

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// A free 2D block (alpha 1.2, plane stress), at rest and unstressed.
TaylorSph<2> block(Kinematics kinematics = Kinematics::small_strain) {
  LatticeBox<2> box;
  box.spacing = kDx;
  box.node_count = {kNodes, kNodes};
  ParticleSet<2> real = make_real_lattice(box, kDensity);
  auto virtual_particles = make_virtual_lattice(box, kDensity);
  const double tol = 1e-9 * kDx, upper = (kNodes - 1) * kDx;
  for (int d = 0; d < 2; ++d) {
    assign_boundary(real, Region<2>::half_space("low", Vector<2>::Zero(), Vector<2>(-Vector<2>::Unit(d))), 0, tol);
    assign_boundary(real, Region<2>::half_space("high", Vector<2>::Constant(upper), Vector<2>::Unit(d)), 0, tol);
  }
  SolverSettings<2> settings;
  settings.smoothing_length = 1.2 * kDx;
  settings.kinematics = kinematics;
  return TaylorSph<2>(std::move(real), std::move(virtual_particles), LinearElastic<2>(kYoung, 0.3, kDensity),
                      settings, {BoundaryCondition<2>::free("faces")});
}

double wave_speed() { return LinearElastic<2>(kYoung, 0.3, kDensity).p_wave_speed(kDensity); }
double p_wave_modulus() { return kDensity * wave_speed() * wave_speed(); }
double stable_dt() { return 0.5 * kDx / wave_speed(); }
constexpr std::size_t kInside = 7 * kNodes + 7;  // the centre particle, (0.07, 0.07)

/// The diagnosis of check_stability on the solver's state, "" if it passes.
std::string check(TaylorSph<2>& solver) {
  try {
    solver.check_stability(stable_dt());
  } catch (const SolutionDiverged& e) {
    return e.what();
  }
  return {};
}

/// The diagnosis names the step, the time, the particle and its position.
void expect_names_particle(const std::string& m, std::size_t particle) {
  EXPECT_TRUE(std::regex_search(m, std::regex("diverged at step 1 \\(t = [0-9.e+-]+ s\\): real particle " +
                                              std::to_string(particle) + " at \\([0-9.e+-]+, [0-9.e+-]+\\) ")))
      << m;
}

void set_density(TaylorSph<2>& solver, std::size_t i, double density) {
  ParticleSet<2>& real = solver.state().real;
  real.density[i] = density;
  real.volume[i] = real.mass[i] / density;
}

TEST(StabilityMonitor, DensityAboveFiveTimesTheReferenceIsStopped) {
  TaylorSph<2> solver = block(Kinematics::updated_lagrangian);
  set_density(solver, kInside, 0.99 * kMaxDensityRatio * kDensity);
  EXPECT_EQ(check(solver), "");
  set_density(solver, kInside, 1.01 * kMaxDensityRatio * kDensity);
  const std::string m = check(solver);
  expect_names_particle(m, kInside);
  EXPECT_TRUE(contains(m, "has an unphysical density: rho / rho0 = 5.05 (J = rho0 / rho = 0.19802) is above the "
                          "bound 5 (rho0 = 2000 kg/m^3)")) << m;
  EXPECT_TRUE(contains(m, "likely cause: the initial state or the loads")) << m;
}

TEST(StabilityMonitor, DensityBelowAFifthOfTheReferenceIsStopped) {
  TaylorSph<2> solver = block(Kinematics::updated_lagrangian);
  set_density(solver, 3, 1.01 * kMinDensityRatio * kDensity);
  EXPECT_EQ(check(solver), "");
  set_density(solver, 3, 0.99 * kMinDensityRatio * kDensity);
  const std::string m = check(solver);
  expect_names_particle(m, 3);
  EXPECT_TRUE(contains(m, "is below the bound 0.2")) << m;
  EXPECT_TRUE(contains(m, "expanded to more than 5 times its volume")) << m;
}

TEST(StabilityMonitor, StressAboveFiveTimesThePWaveModulusIsStopped) {
  TaylorSph<2> solver = block();
  ParticleSet<2>& real = solver.state().real;
  const double bound = kMaxStressOverModulus * p_wave_modulus();
  // A shear stress counts twice in sigma : sigma.
  real.stress[2][kInside] = 0.99 * bound / std::sqrt(2.0);
  EXPECT_EQ(check(solver), "");
  real.stress[2][kInside] = 1.01 * bound / std::sqrt(2.0);
  const std::string m = check(solver);
  expect_names_particle(m, kInside);
  EXPECT_TRUE(contains(m, "has an unphysical stress: |sigma| = ")) << m;
  EXPECT_TRUE(contains(m, "Pa is above the bound 5 M = ")) << m;
}

TEST(StabilityMonitor, SpeedAboveThePWaveSpeedRelativeToTheMeanIsStopped) {
  TaylorSph<2> solver = block();
  ParticleSet<2>& real = solver.state().real;
  double mass = 0.0;
  for (double m : real.mass) mass += m;
  // Only particle kInside moves, at V: relative to the mean velocity it moves at
  // V (1 - m / M).
  const double to_relative = 1.0 - real.mass[kInside] / mass;
  real.velocity[1][kInside] = 0.99 * wave_speed() / to_relative;
  EXPECT_EQ(check(solver), "");
  real.velocity[1][kInside] = 1.01 * wave_speed() / to_relative;
  const std::string m = check(solver);
  expect_names_particle(m, kInside);
  EXPECT_TRUE(contains(m, "moves at an unphysical speed: |v - v_mean| = ")) << m;
  EXPECT_TRUE(contains(m, "is above the bound 1 c_p = " + format_number(wave_speed()))) << m;
}

TEST(StabilityMonitor, TranslationAndRotationBelowTheWaveSpeedPass) {
  TaylorSph<2> solver = block();
  ParticleSet<2>& real = solver.state().real;
  // A translation at 40 c_p with a rigid spin about the centre whose corners move at
  // 0.99 c_p: no particle is stopped, whatever the speed of the body as a whole.
  const double centre = 0.5 * (kNodes - 1) * kDx, corner = centre * std::sqrt(2.0);
  auto spin = [&](double corner_speed) {
    const double omega = corner_speed / corner;
    for (std::size_t i = 0; i < real.size(); ++i) {
      real.velocity[0][i] = 40.0 * wave_speed() - omega * (real.position[1][i] - centre);
      real.velocity[1][i] = omega * (real.position[0][i] - centre);
    }
  };
  spin(0.99 * wave_speed());
  EXPECT_EQ(check(solver), "");
  spin(1.01 * wave_speed());
  const std::string m = check(solver);
  EXPECT_TRUE(contains(m, "moves at an unphysical speed")) << m;
  EXPECT_TRUE(contains(m, "at (0, 0)") || contains(m, "at (0.14, 0)") || contains(m, "at (0, 0.14)") ||
              contains(m, "at (0.14, 0.14)")) << m;  // a corner
}

// A legitimate large deformation: the whole block compressed to J = 0.5 (uniaxial
// strain), the stress of a linear hypoelastic solid there, M ln(J) along x, and
// spinning with its corners at 0.5 c_p. Nothing is stopped.
TEST(StabilityMonitor, LargeDeformationPasses) {
  TaylorSph<2> solver = block(Kinematics::updated_lagrangian);
  ParticleSet<2>& real = solver.state().real;
  const double nu = 0.3, lambda_over_m = nu / (1.0 - nu), strain = std::log(0.5);
  const double omega = 0.5 * wave_speed() / (0.5 * (kNodes - 1) * kDx * std::sqrt(2.0));
  for (std::size_t i = 0; i < real.size(); ++i) {
    set_density(solver, i, 2.0 * kDensity);
    real.stress[0][i] = p_wave_modulus() * strain;
    real.stress[1][i] = p_wave_modulus() * lambda_over_m * strain;
    real.velocity[0][i] = -omega * (real.position[1][i] - 0.07);
    real.velocity[1][i] = omega * (real.position[0][i] - 0.07);
  }
  EXPECT_EQ(check(solver), "");
}

TEST(StabilityMonitor, NonFiniteDensityAndPositionAreStopped) {
  {
    TaylorSph<2> solver = block();
    solver.state().real.density[kInside] = std::numeric_limits<double>::quiet_NaN();
    const std::string m = check(solver);
    expect_names_particle(m, kInside);
    EXPECT_TRUE(contains(m, "has a non-finite density")) << m;
  }
  {
    TaylorSph<2> solver = block();
    solver.state().real.position[0][kInside] = std::numeric_limits<double>::infinity();
    const std::string m = check(solver);
    EXPECT_TRUE(contains(m, "has a non-finite position")) << m;
  }
}

// A real particle with no virtual particle within 2h (it has left the body): stopped in
// a step whose count of empty stencils rose, naming it; a rise without such a particle
// (an empty stencil of the virtual set) passes.
TEST(StabilityMonitor, ParticleThatLeftTheBodyIsStopped) {
  TaylorSph<2> solver = block();
  SolverState<2>& state = solver.state();
  state.counters.empty_stencils += 1;
  EXPECT_EQ(check(solver), "");
  state.real.position[0][kInside] = 1.0;  // 0.86 m beyond the block, the lists unchanged
  EXPECT_EQ(check(solver), "");           // the count did not rise since
  state.counters.empty_stencils += 1;
  const std::string m = check(solver);
  expect_names_particle(m, kInside);
  EXPECT_TRUE(contains(m, "has no virtual particle within its support 2h = 0.024 m (particle disorder: it has "
                          "left the body)")) << m;
}

// End to end, through step(): a particle put 3h outside the block in updated Lagrangian
// (its full-step stencil is searched at the midpoint and is empty) is stopped in the
// first step.
TEST(StabilityMonitor, ParticleThatLeftTheBodyIsStoppedInAStep) {
  TaylorSph<2> solver = block(Kinematics::updated_lagrangian);
  solver.state().real.position[0][kNodes - 1] += 3.6 * kDx;  // the corner (0.14, 0), moved along x
  try {
    solver.step(stable_dt());
    FAIL() << "a particle outside the body went through a step";
  } catch (const SolutionDiverged& e) {
    expect_names_particle(e.what(), kNodes - 1);
    EXPECT_TRUE(contains(e.what(), "particle disorder")) << e.what();
  }
  EXPECT_EQ(solver.counters().steps, 0);
}

// End to end: a block compressed far faster than an elastic solid can take (corner speed
// 2 c_p relative to the mean) in updated Lagrangian is stopped in the first step, naming
// the initial state as the likely cause.
TEST(StabilityMonitor, CompressionFasterThanTheWaveSpeedIsStoppedInTheFirstStep) {
  TaylorSph<2> solver = block(Kinematics::updated_lagrangian);
  ParticleSet<2>& real = solver.state().real;
  const double rate = -2.0 * wave_speed() / (0.5 * (kNodes - 1) * kDx * std::sqrt(2.0));
  for (std::size_t i = 0; i < real.size(); ++i)
    for (int d = 0; d < 2; ++d) real.velocity[d][i] = rate * real.position[d][i];
  try {
    solver.step(stable_dt());
    FAIL() << "the compression went through a step";
  } catch (const SolutionDiverged& e) {
    EXPECT_TRUE(contains(e.what(), "diverged at step 1 ")) << e.what();
    EXPECT_TRUE(contains(e.what(), "unphysical speed")) << e.what();
    EXPECT_TRUE(contains(e.what(), "likely cause: the initial state or the loads")) << e.what();
  }
  EXPECT_EQ(solver.counters().steps, 0);
}

}  // namespace
}  // namespace tsph
