// The cantilever of seed section 4.2 against Timoshenko & Goodier (seed eq. 5): the
// static deflection reached by dynamic relaxation, plane stress and plane strain.
#include "engine/cantilever_case.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

namespace tsph {
namespace {

// The exact solution reproduces the reference values (reference README section 2),
// which are given to 6 decimals (plane strain: 0.045849375 is quoted as 0.045850).
TEST(CantileverExact, TipDeflectionMatchesTheReference) {
  CantileverSettings<2> s;
  EXPECT_NEAR(CantileverExact<2>(s).tip_deflection(), 0.050344, 1e-6);
  s.plane_mode = PlaneMode::plane_strain;
  EXPECT_NEAR(CantileverExact<2>(s).tip_deflection(), 0.045850, 1e-6);
  // The parabolic tip shear carries the load P: integrate it over the depth.
  const CantileverExact<2> exact(s);
  double force = 0.0;
  const int n = 2000;
  for (int k = 0; k < n; ++k) {
    const double y = -0.05 + (k + 0.5) * 0.1 / n;
    force += exact.tip_shear(y) * 0.1 / n;
  }
  EXPECT_NEAR(force, s.load, 1e-3 * s.load);
}

// The defaults are the wall clamp, the hourglass stiffness 0.05 and the surface
// extrapolation, in 3D also the free edges' uniaxial stress (refused in 2D).
TEST(Cantilever, DefaultsAreTheConvergedOptions) {
  const CantileverSettings<2> plane;
  EXPECT_EQ(plane.clamp, SolverSettings<2>::VelocityWall::wall_gradient);
  EXPECT_EQ(plane.hourglass_stiffness, 0.05);
  EXPECT_TRUE(plane.surface_extrapolation);
  EXPECT_FALSE(plane.free_edge_uniaxial);
  const CantileverSettings<3> solid;
  EXPECT_EQ(solid.clamp, SolverSettings<3>::VelocityWall::wall_gradient);
  EXPECT_EQ(solid.hourglass_stiffness, 0.05);
  EXPECT_TRUE(solid.surface_extrapolation);
  EXPECT_TRUE(solid.free_edge_uniaxial);
  // make_cantilever hands them to the solver.
  CantileverSettings<2> small = plane;
  small.nodes_x = 21;
  small.nodes_y = 3;
  const CantileverModel<2> model = make_cantilever(small);
  EXPECT_EQ(model.solver->settings().velocity_wall, SolverSettings<2>::VelocityWall::wall_gradient);
  EXPECT_EQ(model.solver->settings().hourglass_stiffness, 0.05);
  EXPECT_TRUE(model.solver->settings().surface_extrapolation);
  CantileverSettings<3> small_solid = solid;
  small_solid.nodes_x = 21;
  small_solid.nodes_y = small_solid.nodes_z = 3;
  EXPECT_TRUE(make_cantilever(small_solid).solver->settings().free_edge_uniaxial);
  // In 2D there are no edges: refused by the case and by the solver.
  small.free_edge_uniaxial = true;
  const auto errors = validate(small);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors.front().parameter, "free_edge_uniaxial");
  SolverSettings<2> with_edges = model.solver->settings();
  with_edges.free_edge_uniaxial = true;
  EXPECT_THROW(TaylorSph<2>(model.solver->real(), model.solver->virtual_particles(), model.solver->material(),
                            with_edges, model.conditions),
               std::invalid_argument);
}

// SolverSettings::free_edge_uniaxial acts on the particles of the four long edges between
// the free side faces (not their ends on the clamp and the loaded tip face, nor the
// faces), and their stress stays uniaxial along the edge. The same beam turned about x
// or z (faces no longer coordinate planes) has none: the edge is recognised only where
// its neighbours fill a quarter space between two coordinate planes.
TEST(Cantilever, FreeEdgesOfAnAxisAlignedBoxOnly) {
  CantileverSettings<3> s;
  s.nodes_x = 21;
  s.nodes_y = s.nodes_z = 3;
  const CantileverModel<3> model = make_cantilever(s);
  const std::vector<std::uint32_t> edge = model.solver->free_edge_particles();
  ASSERT_EQ(edge.size(), 4u * 19u);
  const auto& r = model.solver->real();
  for (std::uint32_t i : edge) {
    EXPECT_NEAR(std::abs(r.initial_position[1][i]), 0.05, 1e-12);
    EXPECT_NEAR(std::abs(r.initial_position[2][i]), 0.05, 1e-12);
    EXPECT_GT(r.initial_position[0][i], 0.01);
    EXPECT_LT(r.initial_position[0][i], 0.99);
  }
  TaylorSph<3>& solver = *model.solver;
  for (int k = 0; k < 50; ++k) solver.step(model.time_step);
  double largest_axial = 0.0;
  for (std::uint32_t i : edge) {
    largest_axial = std::max(largest_axial, std::abs(solver.real().stress[0][i]));  // xx
    for (int m = 1; m < stress_component_count<3>; ++m) EXPECT_EQ(solver.real().stress[m][i], 0.0) << m;
  }
  EXPECT_GT(largest_axial, 0.0);

  // Turned by 30 degrees about axis `about` (both particle sets, positions and initial
  // positions): no particle is on an axis-parallel edge with both faces free.
  for (int about : {0, 2}) {
    const double c = std::cos(M_PI / 6.0), sn = std::sin(M_PI / 6.0);
    const int a = (about + 1) % 3, b = (about + 2) % 3;
    auto turn = [&](ParticleSet<3> set) {
      for (std::size_t i = 0; i < set.size(); ++i)
        for (auto* field : {&set.position, &set.initial_position}) {
          const double u = (*field)[a][i], w = (*field)[b][i];
          (*field)[a][i] = c * u - sn * w;
          (*field)[b][i] = sn * u + c * w;
        }
      return set;
    };
    const TaylorSph<3> turned(turn(model.solver->real()), turn(model.solver->virtual_particles()),
                              model.solver->material(), model.solver->settings(), model.conditions);
    EXPECT_TRUE(turned.free_edge_particles().empty()) << "about axis " << about;
  }
}

// 101 x 11 real particles (the seed's discretisation), the defaults: tip deflection
// within 2 % of the exact value and the L2 error of u_y along the axis below 3 %
// (issue 3). Measured: plane stress 0.38 % and 0.51 %, plane strain 0.32 % and 0.42 %.
void expect_seed_accuracy(PlaneMode mode) {
  CantileverSettings<2> s;  // defaults: 101 x 11, alpha 0.6, CFL 0.9, small strain
  s.plane_mode = mode;
  const CantileverResult r = run_cantilever(s);
  EXPECT_TRUE(r.converged) << "t = " << r.time;
  EXPECT_LT(r.tip_error_percent, 2.0) << "tip " << r.tip_deflection << " exact " << r.tip_exact;
  EXPECT_LT(r.axis_l2_error_percent, 3.0);
  // At rest within about a second (ramp 0.31 s; measured 0.95 s and 0.82 s), not at the
  // time limit: a creeping beam would not get there.
  EXPECT_LT(r.time, 1.5);
  EXPECT_EQ(r.real_particles, 1111u);
}
TEST(Cantilever, PlaneStressMatchesTimoshenkoGoodier) { expect_seed_accuracy(PlaneMode::plane_stress); }
TEST(Cantilever, PlaneStrainMatchesTimoshenkoGoodier) { expect_seed_accuracy(PlaneMode::plane_strain); }

// The plane-stress beam of nodes_x x ((nodes_x - 1) / 10 + 1) particles with the
// defaults (surface extrapolation on or off), run to rest (at most 2 s).
CantileverResult run_beam(int nodes_x, bool surface_extrapolation, double kinetic_tolerance = 1e-5) {
  CantileverSettings<2> s;
  s.nodes_x = nodes_x;
  s.nodes_y = (nodes_x - 1) / 10 + 1;
  s.surface_extrapolation = surface_extrapolation;
  s.kinetic_tolerance = kinetic_tolerance;
  s.end_time = 2.0;
  return run_cantilever(s);
}

// The rest criterion reads the kinetic energy as well as the tip speed: at 41 x 5 the
// tip is slow at 0.86 s (its turning point) while the beam keeps 2.0e-6 of the load's
// work as kinetic energy, which falls only slowly (1.8e-6 at 2 s; the sections turn
// back slowly: README, The cantilever). The default 1e-5 accepts it (at rest at
// 0.86 s), 1e-6 does not by 1.2 s.
TEST(Cantilever, RestNeedsTheKineticEnergyToo) {
  const CantileverResult loose = run_beam(41, true);
  ASSERT_TRUE(loose.converged) << "t = " << loose.time;
  EXPECT_LT(loose.time, 1.0);
  EXPECT_LT(loose.kinetic_energy, 1e-5 * loose.load_work);
  EXPECT_GT(loose.kinetic_energy, 1e-6 * loose.load_work);
  EXPECT_NEAR(loose.load_work, 1000.0 * 0.050344, 1e-3);
  ASSERT_FALSE(loose.history.empty());
  EXPECT_DOUBLE_EQ(loose.history.back()[0], loose.time);
  CantileverSettings<2> s;
  s.nodes_x = 41;
  s.nodes_y = 5;
  s.kinetic_tolerance = 1e-6;
  s.end_time = 1.2;
  const CantileverResult strict = run_cantilever(s);
  EXPECT_FALSE(strict.converged);
  EXPECT_GT(strict.kinetic_energy, 1e-6 * strict.load_work);
}

// With the defaults the error falls at second order with dx: measured 2.33 % at 41 x 5
// and 1.04 % at 61 x 7 (rate 1.98), 0.59 % at 81 x 9, 0.38 % at 101 x 11 (README, The
// cantilever). The creeping characteristic clamp had no rate.
TEST(Cantilever, DefaultsConvergeAtSecondOrder) {
  const CantileverResult coarse = run_beam(41, true), fine = run_beam(61, true);
  ASSERT_TRUE(coarse.converged) << "t = " << coarse.time;
  ASSERT_TRUE(fine.converged) << "t = " << fine.time;
  EXPECT_LT(std::abs(coarse.tip_error_percent), 4.0) << "tip " << coarse.tip_deflection;
  EXPECT_LT(coarse.axis_l2_error_percent, 4.0);
  const double rate = std::log(coarse.tip_error_percent / fine.tip_error_percent) / std::log(1.5);
  EXPECT_NEAR(rate, 2.0, 0.3) << coarse.tip_error_percent << " % -> " << fine.tip_error_percent << " %";
  const double axis_rate =
      std::log(coarse.axis_l2_error_percent / fine.axis_l2_error_percent) / std::log(1.5);
  EXPECT_NEAR(axis_rate, 2.0, 0.4) << coarse.axis_l2_error_percent << " % -> " << fine.axis_l2_error_percent << " %";
}

// SolverSettings::surface_extrapolation: the free-surface particles' tangential strain
// rate moved from the virtual row half a cell inside to the surface. Without it the
// outer fibres are softer by (dx / 2) / (D / 2) and the beam too flexible by about that
// share of its bending stiffness: predicted 20.0 % at 41 x 5, measured 19.15 % (with
// it 2.33 %).
TEST(Cantilever, WithoutSurfaceExtrapolationTheOuterFibresAreSoft) {
  const CantileverResult r = run_beam(41, false);
  ASSERT_TRUE(r.converged) << "t = " << r.time;
  EXPECT_GT(r.tip_deflection, r.tip_exact);  // too flexible
  EXPECT_NEAR(r.tip_error_percent, 19.15, 1.0);
}

// Updated Lagrangian (issue 3). The virtual particles are kept at their material
// points (TaylorSph::place_at_material_point): 41 x 5 at rest at 0.74 s, +0.72 % at the tip (small strain
// +2.33 %; the large-displacement effect at this load is about -0.2 %). Moved by their
// own half-step velocity (the former scheme) they drift from their cells after the
// beam has come to rest, and the beam is too stiff: -12.9 %.
TEST(Cantilever, UpdatedLagrangianMatchesTheBeam) {
  CantileverSettings<2> s;
  s.nodes_x = 41;
  s.nodes_y = 5;
  s.kinematics = Kinematics::updated_lagrangian;
  s.end_time = 2.0;
  const CantileverResult r = run_cantilever(s);
  ASSERT_TRUE(r.converged) << "t = " << r.time;
  EXPECT_LT(r.tip_error_percent, 2.0) << "tip " << r.tip_deflection << " exact " << r.tip_exact;
  EXPECT_LT(r.axis_l2_error_percent, 3.0);
  EXPECT_LT(r.time, 1.0);
}

// Renumbering the particles carries every per-particle state of the stepper with them
// (TaylorSph::permute_particles and the sort of SolverSettings::spatial_order, both
// through permute_state): the boundary slots' surface flags, profiles and normals, the
// wall gradient's and the surface extrapolation's data, v^n, the hourglass stiffness's
// lists, the conservative momentum's weights. The 41 x 5 beam with the defaults (and
// the conservative momentum, and updated Lagrangian kinematics, as parameters), 300
// steps of the load ramp: (1) given in random order with spatial_order = cells, it is
// sorted once at construction; (2) permuted at random after 150 steps (with
// spatial_order = cells the updated-Lagrangian run sorts it back at the next rebuild).
// Both runs equal the lattice-ordered one particle by particle (by id) to round-off.
class CantileverPermutation : public ::testing::TestWithParam<std::tuple<Kinematics, bool>> {};

std::vector<std::uint32_t> random_order(std::size_t count, std::uint64_t seed) {
  std::vector<std::uint32_t> order(count);
  for (std::size_t k = 0; k < count; ++k) order[k] = static_cast<std::uint32_t>(k);
  std::mt19937_64 rng(seed);
  std::shuffle(order.begin(), order.end(), rng);
  return order;
}

/// |a - b| particle by particle, matched by id, relative to the largest |b| of each field.
void expect_same_up_to_permutation(const ParticleSet<2>& a, const ParticleSet<2>& b, const std::string& what) {
  ASSERT_EQ(a.size(), b.size());
  std::vector<std::size_t> at(a.size());
  for (std::size_t k = 0; k < a.size(); ++k) at[a.id[k]] = k;
  auto check = [&](const std::vector<double>& field_a, const std::vector<double>& field_b, const char* name) {
    double scale = 0.0, worst = 0.0;
    for (double v : field_b) scale = std::max(scale, std::abs(v));
    for (std::size_t i = 0; i < b.size(); ++i)
      worst = std::max(worst, std::abs(field_a[at[b.id[i]]] - field_b[i]));
    EXPECT_LE(worst, 1e-9 * scale) << what << ": " << name << " (scale " << scale << ")";
    return scale;
  };
  for (int d = 0; d < 2; ++d) {
    check(a.position[d], b.position[d], "position");
    check(a.velocity[d], b.velocity[d], "velocity");
    EXPECT_GT(check(a.displacement[d], b.displacement[d], "displacement"), 0.0) << what;
  }
  for (int m = 0; m < stress_component_count<2>; ++m) check(a.stress[m], b.stress[m], "stress");
  check(a.density, b.density, "density");
}

TEST_P(CantileverPermutation, RenumberedParticlesRunAsTheLattice) {
  const auto [kinematics, conservative] = GetParam();
  const bool moving = kinematics == Kinematics::updated_lagrangian;
  CantileverSettings<2> s;  // the defaults: wall clamp, stiffness 0.05, extrapolation
  s.nodes_x = 41;
  s.nodes_y = 5;
  s.kinematics = kinematics;
  const CantileverModel<2> model = make_cantilever(s);
  const ParticleSet<2> real = model.solver->real();
  const ParticleSet<2> virtual_particles = model.solver->virtual_particles();
  SolverSettings<2> settings = model.solver->settings();
  settings.conservative_momentum = conservative;
  const int steps = 300;
  auto solver_on = [&](ParticleSet<2> r, ParticleSet<2> v, SpatialOrder order) {
    SolverSettings<2> with_order = settings;
    with_order.spatial_order = order;
    return TaylorSph<2>(std::move(r), std::move(v), model.solver->material(), with_order, model.conditions);
  };

  TaylorSph<2> lattice = solver_on(real, virtual_particles, SpatialOrder::none);
  for (int k = 0; k < steps; ++k) lattice.step(model.time_step);
  ASSERT_GT(std::abs(lattice.real().displacement[1][model.tip]), 0.0);

  ParticleSet<2> shuffled_real = real, shuffled_virtual = virtual_particles;
  shuffled_real.permute(random_order(real.size(), 3));
  shuffled_virtual.permute(random_order(virtual_particles.size(), 4));
  TaylorSph<2> sorted = solver_on(shuffled_real, shuffled_virtual, SpatialOrder::cells);
  EXPECT_EQ(sorted.counters().reorders, 1);
  for (int k = 0; k < steps; ++k) sorted.step(model.time_step);
  expect_same_up_to_permutation(sorted.real(), lattice.real(), "shuffled, sorted at construction");

  TaylorSph<2> renumbered = solver_on(real, virtual_particles, SpatialOrder::cells);
  for (int k = 0; k < steps / 2; ++k) renumbered.step(model.time_step);
  renumbered.permute_particles(random_order(real.size(), 5), random_order(virtual_particles.size(), 6));
  bool permuted = false;
  for (std::size_t k = 0; k < real.size(); ++k) permuted = permuted || renumbered.real().id[k] != k;
  EXPECT_TRUE(permuted);
  for (int k = steps / 2; k < steps; ++k) renumbered.step(model.time_step);
  // Updated Lagrangian: the random order has decayed, so the next rebuild sorts it;
  // with the default Verlet skin the order is checked only when the lists run out at x^n
  // (rebuild_neighbors), which does not happen in the remaining steps here (measured:
  // no sort), and the run still equals the lattice's.
  EXPECT_EQ(renumbered.counters().reorders, moving && settings.neighbor_skin == 0.0 ? 1 : 0);
  expect_same_up_to_permutation(renumbered.real(), lattice.real(), "permuted at random mid-run");

  // Not a permutation: refused, with the set named.
  std::vector<std::uint32_t> twice = random_order(real.size(), 7);
  twice[0] = twice[1];
  EXPECT_THROW(renumbered.permute_particles(twice, random_order(virtual_particles.size(), 8)),
               std::invalid_argument);
}
INSTANTIATE_TEST_SUITE_P(
    Options, CantileverPermutation,
    ::testing::Combine(::testing::Values(Kinematics::small_strain, Kinematics::updated_lagrangian),
                       ::testing::Bool()),
    [](const ::testing::TestParamInfo<std::tuple<Kinematics, bool>>& p) {
      return std::string(std::get<0>(p.param) == Kinematics::small_strain ? "SmallStrain" : "UpdatedLagrangian") +
             (std::get<1>(p.param) ? "ConservativeMomentum" : "");
    });

// The 3D beam (1 x 0.1 x 0.1 m, P = 100 N) with the defaults against the Timoshenko
// beam (CantileverExact<3>): 41 x 5 x 5, measured -1.77 % at the tip and 1.35 % on the
// axis, at rest at 0.83 s with 3.3e-6 of the load's work as kinetic energy (18 s of CPU
// on the shared machine). Without free_edge_uniaxial the tip was 86 % low ("at rest"
// by the tip speed alone with 3e-3 of the work as kinetic energy); the 5 % bound also
// catches a +-10 % error.
TEST(Cantilever, ThreeDimensionalBeamMatchesTimoshenko) {
  CantileverSettings<3> s;
  s.nodes_x = 41;
  s.nodes_y = s.nodes_z = 5;
  s.end_time = 1.5;
  const CantileverResult r = run_cantilever(s);
  EXPECT_TRUE(r.converged) << "t = " << r.time << ", kinetic energy " << r.kinetic_energy;
  EXPECT_LT(r.time, 1.2);
  EXPECT_NEAR(r.tip_exact, 0.050390, 1e-6);
  EXPECT_LT(r.tip_error_percent, 5.0) << "tip " << r.tip_deflection << " exact " << r.tip_exact;
  EXPECT_LT(r.axis_l2_error_percent, 5.0);
  EXPECT_EQ(r.real_particles, 41u * 5u * 5u);
}

TEST(Cantilever, ValidationNamesTheParameter) {
  CantileverSettings<2> s;
  s.poisson_ratio = 0.5;
  auto errors = validate(s);
  ASSERT_FALSE(errors.empty());
  EXPECT_EQ(errors.front().parameter, "poisson_ratio");
  s = {};
  s.nodes_y = 12;
  errors = validate(s);
  ASSERT_FALSE(errors.empty());
  EXPECT_EQ(errors.front().parameter, "nodes_y");
  EXPECT_THROW(run_cantilever(s), std::invalid_argument);
}

}  // namespace
}  // namespace tsph
