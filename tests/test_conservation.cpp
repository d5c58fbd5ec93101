// Solver-level invariants in 2D: energy of a free vibrating block (it never rises; the
// measured loss is bounded), linear momentum without loads (measured bound: the
// corrected-gradient scheme is not pairwise antisymmetric; exact with the
// conservative-momentum option), velocity fields as boundary conditions, objectivity
// in a rigid rotation, and the hourglass stiffness (no force on linear fields, a
// restoring force on the invisible modes, momentum conserved to round-off).
#include "engine/lattice.hpp"
#include "engine/region.hpp"
#include "engine/taylor_sph.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <vector>

namespace tsph {
namespace {

constexpr double kDensity = 2000.0;
constexpr double kYoung = 8e7;
constexpr double kDx = 0.01;

LatticeBox<2> square(std::int64_t nodes) {
  LatticeBox<2> box;
  box.spacing = kDx;
  box.node_count[0] = box.node_count[1] = nodes;
  return box;
}

void assign_faces(ParticleSet<2>& set, const LatticeBox<2>& box, std::int32_t condition) {
  const double tol = 1e-9 * kDx;
  for (int d = 0; d < 2; ++d) {
    Vector<2> upper = box.lower;
    upper[d] += static_cast<double>(box.node_count[d] - 1) * kDx;
    assign_boundary(set, Region<2>::half_space("low", box.lower, Vector<2>(-Vector<2>::Unit(d))),
                    condition, tol);
    assign_boundary(set, Region<2>::half_space("high", upper, Vector<2>::Unit(d)), condition, tol);
  }
}

double momentum_scale(const ParticleSet<2>& r) {
  double sum = 0.0;
  for (std::size_t i = 0; i < r.size(); ++i)
    sum += r.mass[i] * std::hypot(r.velocity[0][i], r.velocity[1][i]);
  return sum;
}

// A free 21 x 21 block (all faces traction-free, alpha 0.6, CFL 0.9, plane strain)
// started in the shape of its first longitudinal mode, v_x = V cos(pi x / L), zero
// stress. Over 440 steps (10 periods of that mode) the total energy never rises and
// keeps more than 65 % of its initial value (measured 70.8 %: the scheme's numerical
// dissipation; docs/known-problems.md).
TEST(Conservation, FreeBlockKeepsItsEnergy) {
  const auto box = square(21);
  ParticleSet<2> real = make_real_lattice(box, kDensity);
  auto virtual_particles = make_virtual_lattice(box, kDensity);
  assign_faces(real, box, 0);
  const double length = 20 * kDx;
  for (std::size_t i = 0; i < real.size(); ++i)
    real.velocity[0][i] = 0.01 * std::cos(M_PI * real.position[0][i] / length);
  SolverSettings<2> settings = SolverSettings<2>::bare_scheme();
  settings.smoothing_length = 0.6 * kDx;
  const LinearElastic<2> material(kYoung, 0.3, kDensity, PlaneMode::plane_strain);
  TaylorSph<2> solver(std::move(real), std::move(virtual_particles), material, settings,
                      {BoundaryCondition<2>::free("faces")});
  const double dt = 0.9 * kDx / material.p_wave_speed(kDensity);
  const double initial = solver.kinetic_energy() + solver.strain_energy();
  double lowest = initial, highest = initial;
  for (int k = 0; k < 440; ++k) {
    solver.step(dt);
    const double e = solver.kinetic_energy() + solver.strain_energy();
    lowest = std::min(lowest, e);
    highest = std::max(highest, e);
  }
  std::printf("free block: energy min %.6f max %.6f of the initial\n", lowest / initial,
              highest / initial);
  EXPECT_LE(highest, initial * (1.0 + 1e-9));
  EXPECT_GT(lowest, 0.65 * initial);
}

// Linear momentum of a free block without external loads, with a smooth velocity field
// of zero total momentum: the corrected gradient is not pairwise antisymmetric, so the
// momentum is not conserved to round-off. We test the measured bound: over 1000 steps
// |P(t)| stays below 1e-2 of sum m |v| at t = 0 (measured 5.6e-3; docs/known-problems.md).
TEST(Conservation, FreeBlockMomentumDriftIsBounded) {
  const auto box = square(21);
  ParticleSet<2> real = make_real_lattice(box, kDensity);
  auto virtual_particles = make_virtual_lattice(box, kDensity);
  assign_faces(real, box, 0);
  const double length = 20 * kDx;
  for (std::size_t i = 0; i < real.size(); ++i) {
    const double x = real.position[0][i] / length, y = real.position[1][i] / length;
    real.velocity[0][i] = 0.01 * (std::cos(M_PI * x) + 0.5 * std::cos(2 * M_PI * y) * std::cos(M_PI * x));
    real.velocity[1][i] = 0.01 * (std::cos(M_PI * y) * std::cos(3 * M_PI * x) + 0.3 * std::cos(2 * M_PI * x));
  }
  SolverSettings<2> settings = SolverSettings<2>::bare_scheme();
  settings.smoothing_length = 0.6 * kDx;
  const LinearElastic<2> material(kYoung, 0.3, kDensity, PlaneMode::plane_strain);
  TaylorSph<2> solver(std::move(real), std::move(virtual_particles), material, settings,
                      {BoundaryCondition<2>::free("faces")});
  const double scale = momentum_scale(solver.real());
  const Vector<2> p0 = solver.linear_momentum();
  ASSERT_LT(p0.norm(), 1e-12 * scale);  // the cosines sum to zero on the lattice
  const double dt = 0.9 * kDx / material.p_wave_speed(kDensity);
  double drift = 0.0;
  for (int k = 0; k < 1000; ++k) {
    solver.step(dt);
    drift = std::max(drift, (solver.linear_momentum() - p0).norm() / scale);
  }
  std::printf("free block: momentum drift %.3e of sum m|v|\n", drift);
  EXPECT_LT(drift, 1e-2);
}

// The same block with SolverSettings::conservative_momentum (the weak form
// m_I dv_I/dt = -sum_v V_v sigma_v . D_vI): linear momentum is conserved to round-off
// over 1000 steps (measured 5e-16 of sum m|v|), and the total energy never rises.
TEST(Conservation, ConservativeMomentumOptionConservesMomentumExactly) {
  const auto box = square(21);
  ParticleSet<2> real = make_real_lattice(box, kDensity);
  auto virtual_particles = make_virtual_lattice(box, kDensity);
  assign_faces(real, box, 0);
  const double length = 20 * kDx;
  for (std::size_t i = 0; i < real.size(); ++i) {
    const double x = real.position[0][i] / length, y = real.position[1][i] / length;
    real.velocity[0][i] = 0.01 * (std::cos(M_PI * x) + 0.5 * std::cos(2 * M_PI * y) * std::cos(M_PI * x));
    real.velocity[1][i] = 0.01 * (std::cos(M_PI * y) * std::cos(3 * M_PI * x) + 0.3 * std::cos(2 * M_PI * x));
  }
  SolverSettings<2> settings = SolverSettings<2>::bare_scheme();
  settings.smoothing_length = 0.6 * kDx;
  settings.conservative_momentum = true;
  const LinearElastic<2> material(kYoung, 0.3, kDensity, PlaneMode::plane_strain);
  TaylorSph<2> solver(std::move(real), std::move(virtual_particles), material, settings,
                      {BoundaryCondition<2>::free("faces")});
  const double scale = momentum_scale(solver.real());
  const Vector<2> p0 = solver.linear_momentum();
  const double dt = 0.9 * kDx / material.p_wave_speed(kDensity);
  const double initial = solver.kinetic_energy() + solver.strain_energy();
  double drift = 0.0, highest = initial;
  for (int k = 0; k < 1000; ++k) {
    solver.step(dt);
    drift = std::max(drift, (solver.linear_momentum() - p0).norm() / scale);
    highest = std::max(highest, solver.kinetic_energy() + solver.strain_energy());
  }
  std::printf("free block, conservative momentum: drift %.3e of sum m|v|, energy max %.6f\n", drift,
              highest / initial);
  EXPECT_LT(drift, 1e-13);
  EXPECT_LE(highest, initial * (1.0 + 1e-9));
}

// ... and its force is the divergence of a linear stress field deeper than one spacing
// from the free faces (alpha 0.6): one tiny step from rest gives rho dv/dt = div sigma
// there to round-off. Next to the faces it is not (measured 8-17 % in the first
// interior row at alpha 0.6, several hundred percent three rows deep at alpha 1.2: the
// weak form's integration constraint fails at the surface; docs/known-problems.md).
TEST(Conservation, ConservativeMomentumIsConsistentInTheBulk) {
  const auto box = square(15);
  ParticleSet<2> real = make_real_lattice(box, kDensity);
  auto virtual_particles = make_virtual_lattice(box, kDensity);
  assign_faces(real, box, 0);
  for (std::size_t i = 0; i < real.size(); ++i) {
    const double x = real.position[0][i], y = real.position[1][i];
    real.stress[0][i] = 1e6 * (1 + 3 * x + 2 * y);
    real.stress[1][i] = 1e6 * (1 - x + 5 * y);
    real.stress[2][i] = 1e6 * (2 * x - 4 * y);
  }
  const Vector<2> divergence(1e6 * (3 - 4), 1e6 * (2 + 5));
  SolverSettings<2> settings = SolverSettings<2>::bare_scheme();
  settings.smoothing_length = 0.6 * kDx;
  settings.conservative_momentum = true;
  const LinearElastic<2> material(kYoung, 0.3, kDensity, PlaneMode::plane_strain);
  TaylorSph<2> solver(std::move(real), std::move(virtual_particles), material, settings,
                      {BoundaryCondition<2>::free("faces")});
  const double dt = 1e-9;
  solver.step(dt);
  const auto& r = solver.real();
  int checked = 0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    const double x = r.position[0][i] / kDx, y = r.position[1][i] / kDx;
    if (std::min({x, y, 14 - x, 14 - y}) < 1.5) continue;
    for (int d = 0; d < 2; ++d)
      ASSERT_NEAR(kDensity * r.velocity[d][i] / dt, divergence[d], 1e-8 * divergence.norm()) << i;
    ++checked;
  }
  EXPECT_EQ(checked, 11 * 11);
}

// A velocity condition given as a field v(x0, t) (not a time function times a profile,
// e.g. a rigid rotation) is imposed as such: a block whose particles all carry it (the
// interior ones directly, the face ones through the characteristic relations) moves
// with it, at every particle, after 50 steps. The left column carries a second condition
// with the same field, so that the body is not a driven one (SolverState::driven_condition,
// where the faces take no characteristic relations).
TEST(VelocityField, IsImposedAtEveryParticle) {
  const auto box = square(7);
  ParticleSet<2> real = make_real_lattice(box, kDensity);
  auto virtual_particles = make_virtual_lattice(box, kDensity);
  for (std::size_t i = 0; i < real.size(); ++i) real.boundary[i] = real.position[0][i] < 0.5 * kDx ? 1 : 0;
  const double omega = 3.0;
  auto rotation = [omega](const Vector<2>& x0, double t) {
    const double c = std::cos(omega * t), s = std::sin(omega * t);
    return Vector<2>(omega * (-s * x0[0] - c * x0[1]), omega * (c * x0[0] - s * x0[1]));
  };
  SolverSettings<2> settings = SolverSettings<2>::bare_scheme();
  settings.smoothing_length = 1.2 * kDx;
  const LinearElastic<2> material(kYoung, 0.3, kDensity, PlaneMode::plane_strain);
  TaylorSph<2> solver(std::move(real), std::move(virtual_particles), material, settings,
                      {BoundaryCondition<2>::velocity_field(rotation, "rigid rotation"),
                       BoundaryCondition<2>::velocity_field(rotation, "rigid rotation, left column")});
  ASSERT_FALSE(solver.state().driven());
  const double dt = 0.5 * kDx / material.p_wave_speed(kDensity);
  for (int k = 0; k < 50; ++k) solver.step(dt);
  const auto& r = solver.real();
  for (std::size_t i = 0; i < r.size(); ++i) {
    Vector<2> x0;
    for (int d = 0; d < 2; ++d) x0[d] = r.initial_position[d][i];
    const Vector<2> v = rotation(x0, solver.time());
    for (int d = 0; d < 2; ++d) ASSERT_NEAR(r.velocity[d][i], v[d], 1e-12 * omega * kDx) << i;
  }
}

// Turns `real` (the 11 x 11 block of square(11), its stress set) a quarter turn about
// its centre in `steps` steps of dt = cfl dx / c_p: updated Lagrangian, alpha 1.2, every
// particle on a rigid-rotation velocity condition (condition 0, or 1 where
// real.boundary says so: the same field).
TaylorSph<2> quarter_turn(ParticleSet<2> real, int steps, double cfl) {
  auto virtual_particles = make_virtual_lattice(square(11), kDensity);
  const Vector<2> centre(5 * kDx, 5 * kDx);
  const LinearElastic<2> material(kYoung, 0.3, kDensity, PlaneMode::plane_strain);
  const double dt = cfl * kDx / material.p_wave_speed(kDensity);
  const double omega = 0.5 * M_PI / (steps * dt);
  auto rotation = [omega, centre](const Vector<2>& x0, double t) {
    const double c = std::cos(omega * t), s = std::sin(omega * t);
    const Vector<2> r = x0 - centre;
    return Vector<2>(omega * (-s * r[0] - c * r[1]), omega * (c * r[0] - s * r[1]));
  };
  for (std::size_t i = 0; i < real.size(); ++i) {
    const Vector<2> v = rotation(real.position_of(i), 0.0);
    real.velocity[0][i] = v[0];
    real.velocity[1][i] = v[1];
  }
  SolverSettings<2> settings = SolverSettings<2>::bare_scheme();
  settings.smoothing_length = 1.2 * kDx;
  settings.kinematics = Kinematics::updated_lagrangian;
  TaylorSph<2> solver(std::move(real), std::move(virtual_particles), material, settings,
                      {BoundaryCondition<2>::velocity_field(rotation, "rigid rotation"),
                       BoundaryCondition<2>::velocity_field(rotation, "rigid rotation, second condition")});
  for (int k = 0; k < steps; ++k) solver.step(dt);
  return solver;
}

// Objectivity at solver level: a block pre-stressed uniformly (sigma_xx = 3e7,
// sigma_yy = -1e7 Pa; the rate form is linear, the size of the pre-stress is only a
// scale) turned rigidly about its centre by a quarter turn in 0.0431 s (omega = 36.5
// rad/s), every particle held to the rigid-rotation velocity (interior particles
// directly, face particles through the characteristic relations), updated Lagrangian,
// alpha 1.2, 2000 steps at CFL 0.5 (dt = 2.155e-5 s). The axes turn with the body
// (sigma_yy is now 3e7) and every real particle keeps its stress within 1e-3 of the
// pre-stress (the bound): measured 3.0e-4 (2.3e-4 away from the faces), of the
// order of the centripetal stress rho omega^2 r^2 ~ 1.3e4 Pa = 4e-4 of it. Two things
// make it so (docs/known-problems.md): the full step takes the velocity gradient in the
// midpoint configuration (move_to_midpoint; without it 3.3e-3, a spurious compression
// growing linearly in time), and the face particles rotate their stress by the
// Hughes-Winget rotation (objective_rotation_rate; with forward Euler on
// W sigma - sigma W, 3.1e-3).
// Returns the worst relative change over every real particle (and prints it with the
// worst away from the faces); checks that the particles went round with the body.
// `driven`: every particle on the one condition (a driven body: the faces' stress from the
// full step); otherwise the left column carries a second condition with the same field,
// so the faces go through the characteristic relations as described above.
double quarter_turn_stress_change(double cfl, bool driven = false) {
  const auto box = square(11);
  ParticleSet<2> real = make_real_lattice(box, kDensity);
  const double high = 3e7, low = -1e7;
  for (std::size_t i = 0; i < real.size(); ++i) {
    real.boundary[i] = !driven && real.position[0][i] < 0.5 * kDx ? 1 : 0;
    real.stress[0][i] = high;
    real.stress[1][i] = low;
    real.stress[3][i] = 0.3 * (high + low);  // plane strain sigma_zz = nu (sxx + syy)
  }
  const Vector<2> centre(5 * kDx, 5 * kDx);
  const int steps = static_cast<int>(std::lround(1000 / cfl));
  const TaylorSph<2> solver = quarter_turn(std::move(real), steps, cfl);
  EXPECT_EQ(solver.state().driven(), driven);
  const double dt = solver.time() / steps;
  const auto& r = solver.real();
  double worst = 0.0, worst_interior = 0.0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    Eigen::Matrix2d s;
    s << r.stress[0][i], r.stress[2][i], r.stress[2][i], r.stress[1][i];
    const Eigen::Vector2d values = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(s).eigenvalues();
    const double change = std::max({std::abs(values[0] - low), std::abs(values[1] - high),
                                    std::abs(r.stress[1][i] - high), std::abs(r.stress[0][i] - low)}) / high;
    worst = std::max(worst, change);
    const double x0 = r.initial_position[0][i] / kDx, y0 = r.initial_position[1][i] / kDx;
    if (x0 > 0.5 && x0 < 9.5 && y0 > 0.5 && y0 < 9.5) worst_interior = std::max(worst_interior, change);
  }
  std::printf("rigid rotation, CFL %g (%d steps, dt = %.4g s): worst relative principal-stress change "
              "%.3e (interior %.3e)\n", cfl, steps, dt, worst, worst_interior);
  // The particles went round with the body: the corner (0, 0) is now at (2 c_x, 0).
  for (std::size_t i = 0; i < r.size(); ++i)
    if (r.id[i] == 0) {
      EXPECT_NEAR(r.position[0][i], 2 * centre[0], 1e-2 * kDx);
      EXPECT_NEAR(r.position[1][i], 0.0, 1e-2 * kDx);
    }
  return worst;
}

TEST(Objectivity, PreStressedBlockInRigidRotationKeepsPrincipalStresses) {
  EXPECT_LT(quarter_turn_stress_change(0.5), 1e-3);  // measured 3.0e-4 (2026-11-27; 2.7e-4 before)
}

// ... also at CFL 1 (1000 steps, dt = 4.31e-5 s): measured 4.6e-4 (4.1e-4 before the left
// column became a second condition, 2026-11-27; before the fix 1.1e-2;
// midpoint configuration alone 8.5e-3, Hughes-Winget alone 6.2e-3).
TEST(Objectivity, RigidRotationAtCflOne) { EXPECT_LT(quarter_turn_stress_change(1.0), 1e-3); }

// ... and as a driven body (every face's stress from the full step's Jaumann update in
// the midpoint configuration): measured 2.6e-7 (2026-11-27).
TEST(Objectivity, DrivenBlockInRigidRotation) { EXPECT_LT(quarter_turn_stress_change(0.5, true), 1e-3); }

// The full step's Jaumann terms rotate each particle's own stress (full_step.hpp): a
// driven block (every particle held to a rigid rotation, so D = 0 and the stress only
// turns) with a pre-stress graded across it (sigma_xx from 1e7 to 4e7 Pa, quadratic in
// x; sigma_xy linear in y) turned a quarter turn (1000 steps at CFL 1, updated
// Lagrangian, alpha 1.2): every particle keeps its own principal stresses. Measured
// 7.9e-7 of 4e7 Pa (the uniform pre-stress above: 2.6e-7); with the terms on the
// interpolated virtual stress (before 2026-11-29) 7.1e-3: the difference between the
// smoothed graded field and the particle's own stress, turned with the body.
TEST(Objectivity, GradedPreStressTurnsWithEachParticle) {
  const auto box = square(11);
  ParticleSet<2> real = make_real_lattice(box, kDensity);
  const double length = 10 * kDx, scale = 4e7;
  std::vector<Eigen::Vector2d> initial_principal(real.size());
  std::vector<Eigen::Matrix2d> initial_stress(real.size());
  for (std::size_t i = 0; i < real.size(); ++i) {
    const double x = real.position[0][i] / length, y = real.position[1][i] / length;
    real.boundary[i] = 0;  // every particle on the rigid rotation: a driven body
    real.stress[0][i] = 1e7 * (1.0 + 3.0 * x * x);
    real.stress[1][i] = -1e7 * (1.0 + x);
    real.stress[2][i] = 5e6 * (2.0 * y - 1.0);
    real.stress[3][i] = 0.3 * (real.stress[0][i] + real.stress[1][i]);
    Eigen::Matrix2d s;
    s << real.stress[0][i], real.stress[2][i], real.stress[2][i], real.stress[1][i];
    initial_principal[i] = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(s).eigenvalues();
    initial_stress[i] = s;
  }
  const TaylorSph<2> solver = quarter_turn(std::move(real), 1000, 1.0);
  ASSERT_TRUE(solver.state().driven());
  const auto& r = solver.real();
  double worst = 0.0, worst_turned = 0.0;
  Eigen::Matrix2d quarter;  // the body's rotation by pi/2
  quarter << 0.0, -1.0, 1.0, 0.0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    Eigen::Matrix2d s;
    s << r.stress[0][i], r.stress[2][i], r.stress[2][i], r.stress[1][i];
    const Eigen::Vector2d values = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(s).eigenvalues();
    worst = std::max(worst, (values - initial_principal[r.id[i]]).cwiseAbs().maxCoeff() / scale);
    // ... and its stress turned with it: sigma = R sigma_0 R^T.
    const Eigen::Matrix2d turned = quarter * initial_stress[r.id[i]] * quarter.transpose();
    worst_turned = std::max(worst_turned, (s - turned).cwiseAbs().maxCoeff() / scale);
  }
  std::printf("graded pre-stress, quarter turn: worst principal-stress change %.3e, worst component against "
              "the turned stress %.3e of %.0e Pa\n", worst, worst_turned, scale);
  EXPECT_LT(worst, 1e-5);
  EXPECT_LT(worst_turned, 1e-4);
}

// The characteristic boundary holds a face's traction on the normal at the step's end
// (CharacteristicBoundary::condition_normal: the normal at n carried by the step's deformation,
// updated Lagrangian). A free 21 x 11 block carrying sigma_xx = 1e7 Pa along its top and
// bottom faces turns rigidly at omega dt = 0.02 (alpha 1.2, CFL 0.5). After one step the
// traction sigma n on the top face's middle particles, with n the normal recomputed from
// the positions at n+1, is 2.0e-6 of sigma_xx; held on the normal at n (before
// 2026-11-29) it was 2.0e-2 = omega dt: the lag that made energy in the twisting column.
TEST(Objectivity, FreeFaceTractionHoldsOnTheTurnedNormal) {
  LatticeBox<2> box = square(21);
  box.node_count[1] = 11;
  ParticleSet<2> real = make_real_lattice(box, kDensity);
  auto virtual_particles = make_virtual_lattice(box, kDensity);
  assign_faces(real, box, 0);
  const double tension = 1e7;
  const LinearElastic<2> material(kYoung, 0.3, kDensity, PlaneMode::plane_strain);
  const double dt = 0.5 * kDx / material.p_wave_speed(kDensity);
  const double omega = 0.02 / dt;
  const Vector<2> centre(10 * kDx, 5 * kDx);
  for (std::size_t i = 0; i < real.size(); ++i) {
    real.stress[0][i] = tension;
    real.stress[3][i] = 0.3 * tension;  // plane strain sigma_zz = nu sigma_xx
    real.velocity[0][i] = -omega * (real.position[1][i] - centre[1]);
    real.velocity[1][i] = omega * (real.position[0][i] - centre[0]);
  }
  SolverSettings<2> settings = SolverSettings<2>::bare_scheme();
  settings.smoothing_length = 1.2 * kDx;
  settings.kinematics = Kinematics::updated_lagrangian;
  TaylorSph<2> solver(std::move(real), std::move(virtual_particles), material, settings,
                      {BoundaryCondition<2>::free("faces")});
  solver.step(dt);
  const auto& r = solver.real();
  const auto& particles = solver.boundary_particles();
  double worst = 0.0;
  int checked = 0;
  for (std::size_t b = 0; b < particles.size(); ++b) {
    const std::uint32_t i = particles[b];
    const double x0 = r.initial_position[0][i] / kDx, y0 = r.initial_position[1][i] / kDx;
    if (y0 < 9.5 || x0 < 7.5 || x0 > 12.5) continue;  // the top face's middle, away from the corners
    Eigen::Matrix2d s;
    s << r.stress[0][i], r.stress[2][i], r.stress[2][i], r.stress[1][i];
    const Eigen::Vector2d n = solver.boundary_normals()[b];
    EXPECT_NEAR(n[0], -std::sin(omega * dt), 1e-3) << "the face turned with the body";
    worst = std::max(worst, (s * n).norm() / tension);
    ++checked;
  }
  ASSERT_EQ(checked, 5);
  std::printf("turned face: largest traction |sigma n| / sigma_xx %.3e (omega dt = %.3g)\n", worst, omega * dt);
  EXPECT_LT(worst, 1e-4);
}

// The incremental objective rotation (Hughes-Winget) used by the face particles'
// characteristic relations: a random 3D stress turned by a random spin keeps its
// eigenvalues to round-off even at a large step (W dt ~ 1), where the forward-Euler
// update sigma + dt (W sigma - sigma W) changes them by tens of percent; at a small step
// the rate equals the Jaumann terms W sigma - sigma W to O(dt).
TEST(Objectivity, HughesWingetRotationKeepsEigenvalues) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  Eigen::Matrix3d a, w;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a(i, j) = unit(rng), w(i, j) = unit(rng);
  const Eigen::Matrix3d stress = 1e7 * (a + a.transpose());
  const Eigen::Matrix3d spin = 0.5 * (w - w.transpose());
  const Eigen::Vector3d before = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(stress).eigenvalues();
  auto eigenvalue_change = [&](const Eigen::Matrix3d& s) {
    const Eigen::Matrix3d symmetric = 0.5 * (s + s.transpose());
    return (Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(symmetric).eigenvalues() - before).norm() /
           before.norm();
  };
  const double large = 1.0 / spin.norm();
  const Eigen::Matrix3d rotated = stress + large * objective_rotation_rate<3>(spin, stress, large);
  EXPECT_LT(eigenvalue_change(rotated), 1e-13);
  EXPECT_GT(eigenvalue_change(stress + large * (spin * stress - stress * spin)), 0.1);
  const double small = 1e-6 * large;
  const Eigen::Matrix3d jaumann = spin * stress - stress * spin;
  EXPECT_LT((objective_rotation_rate<3>(spin, stress, small) - jaumann).norm(), 1e-5 * jaumann.norm());
}

// The hourglass stiffness (SolverSettings::hourglass_stiffness) exerts no force on a
// linear displacement field (a random affine u = A X + c, rigid rotation included):
// one step from rest with zero stress leaves every velocity zero to round-off.
TEST(HourglassStiffness, NoForceOnLinearDisplacement) {
  const auto box = square(9);
  ParticleSet<2> real = make_real_lattice(box, kDensity);
  auto virtual_particles = make_virtual_lattice(box, kDensity);
  assign_faces(real, box, 0);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  Eigen::Matrix2d a;
  a << unit(rng), unit(rng), unit(rng), unit(rng);
  const Vector<2> c(unit(rng), unit(rng));
  for (std::size_t i = 0; i < real.size(); ++i) {
    const Vector<2> u = 1e-3 * (a * real.position_of(i) + 0.01 * c);
    real.displacement[0][i] = u[0];
    real.displacement[1][i] = u[1];
  }
  SolverSettings<2> settings = SolverSettings<2>::bare_scheme();
  settings.smoothing_length = 0.6 * kDx;
  settings.hourglass_stiffness = 0.1;
  const LinearElastic<2> material(kYoung, 0.3, kDensity, PlaneMode::plane_strain);
  TaylorSph<2> solver(std::move(real), std::move(virtual_particles), material, settings,
                      {BoundaryCondition<2>::free("faces")});
  const double dt = 0.9 * kDx / material.p_wave_speed(kDensity);
  // The velocity a displacement of 1e-5 m in the invisible mode would receive.
  const double scale = dt * 0.1 * material.p_wave_modulus() / std::pow(0.6 * kDx, 2) / kDensity * 1e-5;
  solver.step(dt);
  const auto& r = solver.real();
  for (std::size_t i = 0; i < r.size(); ++i)
    for (int d = 0; d < 2; ++d) ASSERT_NEAR(r.velocity[d][i], 0.0, 1e-9 * scale) << i;
}

// ... and a restoring force on the modes the virtual particles cannot see: the
// checkerboard (-1)^(i+j) in u_x and the odd-even columns (-1)^i in u_y (the
// cantilever's creeping mode). One step from rest: every particle's velocity change
// opposes its displacement, and the total momentum stays zero to round-off.
void check_hourglass_restores(Kinematics kinematics) {
  const auto box = square(9);
  ParticleSet<2> real = make_real_lattice(box, kDensity);
  auto virtual_particles = make_virtual_lattice(box, kDensity);
  assign_faces(real, box, 0);
  for (std::size_t i = 0; i < real.size(); ++i) {
    const auto ix = std::lround(real.position[0][i] / kDx), iy = std::lround(real.position[1][i] / kDx);
    real.displacement[0][i] = 1e-5 * ((ix + iy) % 2 == 0 ? 1.0 : -1.0);
    real.displacement[1][i] = 1e-5 * (ix % 2 == 0 ? 1.0 : -1.0);
  }
  SolverSettings<2> settings = SolverSettings<2>::bare_scheme();
  settings.smoothing_length = 0.6 * kDx;
  settings.hourglass_stiffness = 0.1;
  settings.kinematics = kinematics;
  const LinearElastic<2> material(kYoung, 0.3, kDensity, PlaneMode::plane_strain);
  TaylorSph<2> solver(std::move(real), std::move(virtual_particles), material, settings,
                      {BoundaryCondition<2>::free("faces")});
  const double dt = 0.9 * kDx / material.p_wave_speed(kDensity);
  solver.step(dt);
  const auto& r = solver.real();
  for (std::size_t i = 0; i < r.size(); ++i)
    for (int d = 0; d < 2; ++d)
      EXPECT_LT(r.velocity[d][i] * r.displacement[d][i], 0.0) << "particle " << i << " component " << d;
  EXPECT_LT(solver.linear_momentum().norm(), 1e-12 * momentum_scale(r));
}
TEST(HourglassStiffness, RestoresInvisibleModesAndConservesMomentum) {
  check_hourglass_restores(Kinematics::small_strain);
}
// ... also with moving particles (the stiffness reads both half-step lists after the
// full step; until 2026-11-23 the updated-Lagrangian stepper had released one: a crash).
TEST(HourglassStiffness, RestoresInvisibleModesWithUpdatedLagrangian) {
  check_hourglass_restores(Kinematics::updated_lagrangian);
}

// SolverSettings::hourglass_reference in a plastic material: one step of a free J2 block
// (bare scheme, alpha 0.6) from a uniform shear stress ten times the yield stress, so that
// every particle inside yields in the step (the free faces' stress is the boundary
// stage's), with the displacement field `u(ix, iy)`. Returns the hourglass stiffness's
// kick, the velocity of the step less that of the same step without the stiffness (the
// full step does not read it), and whether every particle off the faces yielded.
struct YieldingKicks {
  std::vector<Vector<2>> kick;
  std::vector<Vector<2>> position;
  bool inside_yielded = true;
};
YieldingKicks yielding_block_kicks(std::int64_t nodes, const std::function<Vector<2>(std::int64_t, std::int64_t)>& u,
                                   SolverSettings<2>::HourglassReference reference) {
  auto run = [&](double stiffness) {
    const auto box = square(nodes);
    ParticleSet<2> real = make_real_lattice(box, kDensity);
    auto virtual_particles = make_virtual_lattice(box, kDensity);
    assign_faces(real, box, 0);
    for (std::size_t i = 0; i < real.size(); ++i) {
      const Vector<2> ui = u(std::lround(real.position[0][i] / kDx), std::lround(real.position[1][i] / kDx));
      for (int d = 0; d < 2; ++d) real.displacement[d][i] = ui[d];
      real.stress[2][i] = 100.0;  // sigma_xy, yield stress 10 Pa
    }
    SolverSettings<2> settings = SolverSettings<2>::bare_scheme();
    settings.smoothing_length = 0.6 * kDx;
    settings.hourglass_stiffness = stiffness;
    settings.hourglass_reference = reference;
    const J2Plasticity<2> material(LinearElastic<2>(kYoung, 0.3, kDensity, PlaneMode::plane_strain),
                                   J2Plasticity<2>::Linear{10.0, 0.0, 0.0});
    TaylorSph<2> solver(std::move(real), std::move(virtual_particles), material, settings,
                        {BoundaryCondition<2>::free("faces")});
    solver.step(0.5 * kDx / LinearElastic<2>(kYoung, 0.3, kDensity, PlaneMode::plane_strain).p_wave_speed(kDensity));
    return solver.real();
  };
  const ParticleSet<2> with = run(0.1), without = run(0.0);
  YieldingKicks out;
  for (std::size_t i = 0; i < with.size(); ++i) {
    out.kick.emplace_back(with.velocity[0][i] - without.velocity[0][i], with.velocity[1][i] - without.velocity[1][i]);
    out.position.push_back(with.position_of(i));
    const double top = static_cast<double>(nodes - 1) * kDx - 1e-9 * kDx;
    const bool on_face = with.initial_position[0][i] < 1e-9 * kDx || with.initial_position[1][i] < 1e-9 * kDx ||
                         with.initial_position[0][i] > top || with.initial_position[1][i] > top;
    out.inside_yielded = out.inside_yielded && (on_face || with.yielding[i] != 0);
  }
  return out;
}

// The invisible modes (the checkerboard in u_x, odd-even columns in u_y) are restored as
// with the initial reference, at the full stiffness, while every particle yields: their
// round trip is zero, so the reference that follows the flow takes none of them in.
TEST(HourglassStiffness, ReferenceFollowingTheFlowKeepsRestoringInvisibleModes) {
  using Reference = SolverSettings<2>::HourglassReference;
  const auto modes = [](std::int64_t ix, std::int64_t iy) {
    return Vector<2>(1e-5 * ((ix + iy) % 2 == 0 ? 1.0 : -1.0), 1e-5 * (ix % 2 == 0 ? 1.0 : -1.0));
  };
  const YieldingKicks flow = yielding_block_kicks(9, modes, Reference::flow);
  const YieldingKicks initial = yielding_block_kicks(9, modes, Reference::initial);
  ASSERT_TRUE(flow.inside_yielded);
  double largest = 0.0, difference = 0.0;
  for (std::size_t i = 0; i < flow.kick.size(); ++i) {
    largest = std::max(largest, initial.kick[i].norm());
    difference = std::max(difference, (flow.kick[i] - initial.kick[i]).norm());
  }
  // Not to round-off: the faces' stress (the boundary stage's) moves them by about 1e-9 m
  // in the step, a smooth field next to the 1e-5 m modes, which the reference does take in.
  EXPECT_GT(largest, 0.0);
  EXPECT_LT(difference, 1e-3 * largest);
}

// ... while on a smooth field (u_x = U sin(2 pi x / 8 dx): its residual r = u - R A u is
// smooth, O(dx^2 u'')) the yielding particles take it into their reference, and the
// kick, which with the initial reference pulls the flow back, is reduced inside the block
// to the order of the residual's own round-trip error.
TEST(HourglassStiffness, ReferenceFollowingTheFlowReleasesASmoothField) {
  using Reference = SolverSettings<2>::HourglassReference;
  const double pi = 3.14159265358979323846;
  const auto smooth = [pi](std::int64_t ix, std::int64_t) {
    return Vector<2>(1e-5 * std::sin(2.0 * pi * static_cast<double>(ix) / 8.0), 0.0);
  };
  const YieldingKicks flow = yielding_block_kicks(25, smooth, Reference::flow);
  const YieldingKicks initial = yielding_block_kicks(25, smooth, Reference::initial);
  ASSERT_TRUE(flow.inside_yielded);
  double flow_sum = 0.0, initial_sum = 0.0;
  for (std::size_t i = 0; i < flow.kick.size(); ++i) {
    const Vector<2>& x = flow.position[i];
    if (x.minCoeff() < 4.5 * kDx || x.maxCoeff() > 19.5 * kDx) continue;  // 4 spacings inside
    flow_sum += flow.kick[i].squaredNorm();
    initial_sum += initial.kick[i].squaredNorm();
  }
  EXPECT_GT(initial_sum, 0.0);
  EXPECT_LT(std::sqrt(flow_sum / initial_sum), 0.2);  // 0.149 (2026-12-07); 1 with the initial reference
}

}  // namespace
}  // namespace tsph
