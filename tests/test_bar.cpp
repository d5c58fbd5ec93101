// The 1D elastic bar of seed section 4.1 against d'Alembert's exact solution
// (reference README section 1), and the invariants of the 1D stepper.
#include "engine/bar_case.hpp"
#include "engine/parallel.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace tsph {
namespace {

BarCaseSettings seed_bar(double alpha, double cfl = 1.0) {
  BarCaseSettings s;  // defaults: the seed's bar, 101 particles, rho 2000, E 8e7, v0 1, t0 2.5 ms
  s.alpha = alpha;
  s.cfl = cfl;
  return s;
}

// Seed Table 1, first row: alpha = 0.6 at CFL 1 reproduces the exact solution. The
// issue asks for at most 1e-3 %; the scheme is exact (Richtmyer's two-step
// Lax-Wendroff at CFL 1 with characteristic boundaries), so anything above round-off
// would be a bug: the tolerance is 1e-8 %.
TEST(Bar, Alpha06Cfl1IsExactBeforeAndAfterReflection) {
  for (KernelKind kernel : kAllKernelKinds) {
    BarCaseSettings s = seed_bar(0.6);
    s.kernel = kernel;
    const BarResult r = run_bar(s);
    ASSERT_EQ(r.profiles.size(), 2u);
    EXPECT_DOUBLE_EQ(r.profiles[0].time, 3.75e-3);
    EXPECT_DOUBLE_EQ(r.profiles[1].time, 7.5e-3);
    for (const auto& p : r.profiles) {
      EXPECT_LT(p.velocity_error_percent, 1e-8) << to_string(kernel) << " t=" << p.time;
      EXPECT_LT(p.stress_error_percent, 1e-8) << to_string(kernel) << " t=" << p.time;
    }
    EXPECT_EQ(r.steps, 150);
  }
}

// The exact solution itself: the pulse occupies [L - c t, L - c (t - t0)] at 3.75 ms,
// has sigma = rho c v there, and is reflected with inversion at the fixed end.
TEST(Bar, ExactSolutionHasTheExpectedShape) {
  const BarCaseSettings s = seed_bar(0.6);
  const BarExactSolution exact(s);
  EXPECT_EQ(exact.velocity(0.5, 3.75e-3), 1.0);
  EXPECT_EQ(exact.velocity(0.2, 3.75e-3), 0.0);
  EXPECT_EQ(exact.velocity(0.8, 3.75e-3), 0.0);
  EXPECT_DOUBLE_EQ(exact.stress(0.5, 3.75e-3), 2000.0 * 200.0);
  // After the reflection (7.5 ms): the pulse travels right with v = -v0, sigma = rho c v0.
  EXPECT_EQ(exact.velocity(0.25, 7.5e-3), -1.0);
  EXPECT_DOUBLE_EQ(exact.stress(0.25, 7.5e-3), 2000.0 * 200.0);
  // During the reflection the fixed end has v = 0 and doubled stress.
  EXPECT_EQ(exact.velocity(0.0, 6e-3), 0.0);
  EXPECT_DOUBLE_EQ(exact.stress(0.0, 6e-3), 2.0 * 2000.0 * 200.0);
}

// Table 1's trend: the error grows from alpha = 0.6 to 1.2 to 1.6, at both times.
TEST(Bar, ErrorGrowsWithAlpha) {
  std::vector<BarResult> results;
  for (double alpha : {0.6, 1.2, 1.6}) results.push_back(run_bar(seed_bar(alpha)));
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_LT(results[0].profiles[k].velocity_error_percent,
              results[1].profiles[k].velocity_error_percent);
    EXPECT_LT(results[1].profiles[k].velocity_error_percent,
              results[2].profiles[k].velocity_error_percent);
  }
}

// Once the pulse has entered (t >= t0, both ends then held at v = 0) the energy is the
// work done by the boundary, Z v0^2 t0 = 1000 J per unit section, and it stays so
// through the reflection at the fixed end (tolerance 1e-9 relative).
TEST(Bar, EnergyIsConservedAfterThePulseHasEntered) {
  BarCaseSettings s = seed_bar(0.6);
  s.output_times = {9.0e-3};
  s.record_energy = true;
  const BarResult r = run_bar(s);
  const double impedance = s.density * s.wave_speed();
  const double input = impedance * s.amplitude * s.amplitude * s.pulse_duration;
  int checked = 0;
  for (std::size_t k = 0; k < r.energy_time.size(); ++k) {
    // At t0 itself the loaded end still moves (the pulse is on for 0 < t <= t0).
    if (r.energy_time[k] <= s.pulse_duration * (1.0 + 1e-9)) continue;
    const double total = r.kinetic_energy[k] + r.strain_energy[k];
    EXPECT_NEAR(total / input, 1.0, 1e-9) << "t = " << r.energy_time[k];
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

// A wider stencil is dissipative but must never create energy (stability).
TEST(Bar, WideStencilNeverCreatesEnergy) {
  BarCaseSettings s = seed_bar(1.2, 0.8);
  s.output_times = {9.0e-3};
  s.record_energy = true;
  const BarResult r = run_bar(s);
  const double input =
      s.density * s.wave_speed() * s.amplitude * s.amplitude * s.pulse_duration;
  for (std::size_t k = 0; k < r.energy_time.size(); ++k)
    if (r.energy_time[k] >= s.pulse_duration) {
      EXPECT_LT(r.kinetic_energy[k] + r.strain_energy[k], input * (1.0 + 1e-6));
    }
}

// A travelling pulse moves at c = sqrt(E / rho) within one particle spacing: the
// centroid of v^2 between 3.75 ms and 4.5 ms (pulse inside the bar) moves c * 0.75 ms.
TEST(Bar, PulseTravelsAtTheWaveSpeed) {
  for (double alpha : {0.6, 1.2, 1.6}) {
    for (double cfl : {1.0, 0.7}) {
      BarCaseSettings s = seed_bar(alpha, cfl);
      s.output_times = {3.75e-3, 4.5e-3};
      const BarResult r = run_bar(s);
      auto centroid = [](const BarProfile& p) {
        double weighted = 0.0, total = 0.0;
        for (std::size_t i = 0; i < p.position.size(); ++i) {
          weighted += p.position[i] * p.velocity[i] * p.velocity[i];
          total += p.velocity[i] * p.velocity[i];
        }
        return weighted / total;
      };
      const double travelled = centroid(r.profiles[0]) - centroid(r.profiles[1]);
      EXPECT_NEAR(travelled, s.wave_speed() * 0.75e-3, s.spacing())
          << "alpha " << alpha << " cfl " << cfl;
    }
  }
}

// A free end reflects the pulse without inversion: exact at alpha 0.6 / CFL 1, and the
// free end moves at 2 v0 while the pulse reflects.
TEST(Bar, FreeEndIsExactAndDoublesTheVelocity) {
  BarCaseSettings s = seed_bar(0.6);
  s.left_end = BarEnd::free;
  s.output_times = {3.75e-3, 6.0e-3, 7.5e-3};
  const BarResult r = run_bar(s);
  for (const auto& p : r.profiles) EXPECT_LT(p.velocity_error_percent, 1e-8) << p.time;
  EXPECT_NEAR(r.profiles[1].velocity.front(), 2.0 * s.amplitude, 1e-10);
  EXPECT_NEAR(r.profiles[1].stress.front(), 0.0, 1e-6);
}

// A traction pulse rho c v0 at x = L launches the same wave as the velocity pulse v0.
TEST(Bar, TractionLoadIsExact) {
  BarCaseSettings s = seed_bar(0.6);
  s.right_load = BarLoad::traction;
  const BarResult r = run_bar(s);
  for (const auto& p : r.profiles) EXPECT_LT(p.velocity_error_percent, 1e-8) << p.time;
}

// A uniform body force on a free-free bar accelerates it rigidly, v = b t, sigma = 0,
// whatever the stencil (uniform fields have zero corrected gradient).
TEST(Bar, BodyForceAcceleratesAFreeBarUniformly) {
  for (double alpha : {0.6, 1.2}) {
    BarCaseSettings s = seed_bar(alpha, 0.7);
    s.left_end = BarEnd::free;
    s.right_load = BarLoad::traction;
    s.amplitude = 0.0;
    s.body_force = 9.81;
    s.output_times = {2e-3};
    const BarResult r = run_bar(s);
    for (std::size_t i = 0; i < r.profiles[0].velocity.size(); ++i) {
      EXPECT_NEAR(r.profiles[0].velocity[i], 9.81 * 2e-3, 1e-12) << "particle " << i;
      EXPECT_NEAR(r.profiles[0].stress[i], 0.0, 1e-6) << "particle " << i;
    }
  }
}

// Results do not depend on the thread count: bitwise identical with 1 and 2 threads.
TEST(Bar, ResultsAreIdenticalWithOneAndTwoThreads) {
  const int before = thread_count();
  BarCaseSettings s = seed_bar(1.2, 0.9);
  set_thread_count(1);
  const BarResult one = run_bar(s);
  set_thread_count(2);
  const BarResult two = run_bar(s);
  set_thread_count(before);
  for (std::size_t k = 0; k < one.profiles.size(); ++k) {
    EXPECT_EQ(one.profiles[k].velocity, two.profiles[k].velocity);
    EXPECT_EQ(one.profiles[k].stress, two.profiles[k].stress);
  }
}

// The updated-Lagrangian path (moving particles, density update, neighbour rebuilds)
// reduces to the linear solution for a small amplitude: the geometric nonlinearity
// is of the order of the strain v0 / c = 5e-7 here.
TEST(Bar, UpdatedLagrangianMatchesSmallStrainAtSmallAmplitude) {
  BarCaseSettings s = seed_bar(0.6);
  s.amplitude = 1e-4;
  const BarResult linear = run_bar(s);
  s.kinematics = Kinematics::updated_lagrangian;
  s.neighbor_skin = 0.0;  // without skin: a search at every step
  const BarResult moving = run_bar(s);
  EXPECT_EQ(moving.counters.neighbor_builds, moving.steps + 1);
  for (std::size_t k = 0; k < linear.profiles.size(); ++k)
    EXPECT_LT(relative_l2_percent(moving.profiles[k].velocity, linear.profiles[k].velocity),
              1e-2);
  // With the default skin (0.05 of 2h) the particles (speeds of order v0 = 1e-4 m/s)
  // never cross it: the lists of the construction serve the whole run; the same
  // profiles to round-off (the skin's zero-weight pairs).
  s.neighbor_skin = BarCaseSettings{}.neighbor_skin;
  const BarResult skin = run_bar(s);
  EXPECT_EQ(skin.counters.neighbor_builds, 1);
  for (std::size_t k = 0; k < linear.profiles.size(); ++k)
    EXPECT_LT(relative_l2_percent(skin.profiles[k].velocity, moving.profiles[k].velocity), 1e-9);
}

// Bad input: each invalid parameter is named with its value and allowed range.
TEST(Bar, ValidationNamesTheParameterValueAndRange) {
  auto first_error = [](const BarCaseSettings& s) {
    const auto errors = validate(s);
    return errors.empty() ? std::string() : errors.front().message();
  };
  BarCaseSettings s;
  EXPECT_TRUE(validate(s).empty());
  s = {}; s.length = -1.0;
  EXPECT_NE(first_error(s).find("length = -1"), std::string::npos);
  s = {}; s.alpha = 0.0;
  EXPECT_NE(first_error(s).find("alpha = 0 is invalid"), std::string::npos);
  s = {}; s.young_modulus = 0.0;
  EXPECT_NE(first_error(s).find("young_modulus = 0"), std::string::npos);
  s = {}; s.density = -2.0;
  EXPECT_NE(first_error(s).find("density = -2"), std::string::npos);
  s = {}; s.cfl = 1.5;
  EXPECT_NE(first_error(s).find("cfl = 1.5 is invalid: must lie in (0, 1]"), std::string::npos);
  s = {}; s.output_times = {1e-3, 9e-3}; s.end_time = 5e-3;
  EXPECT_NE(first_error(s).find("output_times = 0.009"), std::string::npos);
  s = {}; s.particle_count = 1;
  EXPECT_NE(first_error(s).find("particles = 1"), std::string::npos);
  s = {}; s.alpha = 0.3;
  EXPECT_THROW(run_bar(s), std::invalid_argument);
}

}  // namespace
}  // namespace tsph
