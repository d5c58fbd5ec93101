// The cantilever of seed section 4.2 (tools/cases/cantilever_2d.toml and
// cantilever_3d.toml, run through the one case pipeline) against Timoshenko & Goodier
// (seed eq. 5) and the Timoshenko beam: the static deflection reached by dynamic
// relaxation, plane stress and plane strain (docs/validation.md).
#include "engine/case/case_build.hpp"
#include "engine/validation/cantilever.hpp"
#include "tests/case_helpers.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

namespace tsph {
namespace {

using testing_cases::CaseRun;

/// The exact beam of the shipped 2D case (1 m x 0.1 m, P = 1000 N, E 8e7, nu 0.3).
CantileverBeam<2> seed_beam(PlaneMode mode = PlaneMode::plane_stress) {
  CantileverBeam<2> b;
  b.load = 1000.0;
  b.plane_mode = mode;
  return b;
}

/// The tip particle on the axis of a built cantilever case.
template <int Dim>
std::size_t tip_of(const BuiltCase<Dim>& built) {
  const auto* beam = dynamic_cast<const CantileverValidation<Dim>*>(built.exact.get());
  EXPECT_NE(beam, nullptr);
  return beam ? beam->tip() : 0;
}

std::string spacing_for(int nodes_x) {
  char text[64];
  std::snprintf(text, sizeof text, "geometry.spacing=%.17g", 1.0 / (nodes_x - 1));
  return text;
}

/// The cantilever's rest rule by energy: the kinetic energy below this
/// fraction of the load's work on the exact tip deflection, P |u_tip|.
std::string kinetic_rest(double tolerance, PlaneMode mode = PlaneMode::plane_stress) {
  char text[96];
  std::snprintf(text, sizeof text, "damping.rest_kinetic_energy=%.17g",
                tolerance * 1000.0 * std::abs(seed_beam(mode).tip_deflection()));
  return text;
}

bool at_rest(const CaseRun& r) { return r.report.status == RunReport::Status::at_rest; }

// The exact solution reproduces the reference values (seed section 4.2), which are
// given to 6 decimals (plane strain: 0.045849375 is quoted as 0.045850).
TEST(CantileverExact, TipDeflectionMatchesTheReference) {
  EXPECT_NEAR(seed_beam().tip_deflection(), 0.050344, 1e-6);
  EXPECT_NEAR(seed_beam(PlaneMode::plane_strain).tip_deflection(), 0.045850, 1e-6);
  // The parabolic tip shear carries the load P: integrate it over the depth.
  const CantileverBeam<2> exact = seed_beam(PlaneMode::plane_strain);
  double force = 0.0;
  const int n = 2000;
  for (int k = 0; k < n; ++k) {
    const double y = -0.05 + (k + 0.5) * 0.1 / n;
    force += exact.tip_shear(y) * 0.1 / n;
  }
  EXPECT_NEAR(force, exact.load, 1e-3 * exact.load);
}

// The converged options are the method's defaults: the shipped cantilevers leave them
// to it (the wall clamp, the hourglass stiffness 0.05, the surface extrapolation and the
// surface filter 0.02 resolved by the builder and the solver alike; in 3D the free
// edges' uniaxial stress, refused in 2D, and off for a plastic material).
TEST(Cantilever, DefaultsAreTheConvergedOptions) {
  const CaseFile plane = load_case(testing_cases::shipped_case("cantilever_2d.toml"), {"geometry.spacing=0.05"});
  EXPECT_EQ(plane.velocity_wall, CaseFile::VelocityWall::automatic);
  EXPECT_EQ(plane.hourglass_stiffness, kAutomaticOption);
  EXPECT_EQ(plane.surface_extrapolation, Toggle::automatic);
  EXPECT_EQ(plane.free_edge_uniaxial, Toggle::automatic);
  const CaseFile solid = load_case(testing_cases::shipped_case("cantilever_3d.toml"), {"geometry.spacing=0.05"});
  EXPECT_EQ(solid.hourglass_stiffness, kAutomaticOption);
  EXPECT_EQ(solid.free_edge_uniaxial, Toggle::automatic);
  BuiltCase<2> model = build_case<2>(plane);
  BuiltCase<2> copy = build_case<2>(plane);
  for (const SolverSettings<2>& s :
       {resolve_automatic_options(model.settings, false, false), make_solver<2>(plane, copy).settings()}) {
    EXPECT_EQ(s.velocity_wall, SolverSettings<2>::VelocityWall::wall_gradient);
    EXPECT_EQ(s.hourglass_stiffness, 0.05);
    EXPECT_EQ(s.hourglass_coefficient, 0.02);
    EXPECT_EQ(s.surface_extrapolation, Toggle::on);
    EXPECT_EQ(s.free_edge_uniaxial, Toggle::off);
  }
  const SolverSettings<3> solid_settings = resolve_automatic_options(build_case<3>(solid).settings, false, false);
  EXPECT_EQ(solid_settings.free_edge_uniaxial, Toggle::on);
  EXPECT_EQ(resolve_automatic_options(build_case<3>(solid).settings, true, false).free_edge_uniaxial, Toggle::off);
  EXPECT_EQ(resolved_method_options(solid).free_edge_uniaxial, true);
  EXPECT_EQ(solid_settings.velocity_wall, SolverSettings<3>::VelocityWall::wall_gradient);
  EXPECT_EQ(solid_settings.hourglass_stiffness, 0.05);
  EXPECT_EQ(solid_settings.surface_extrapolation, Toggle::on);
  // In 2D there are no edges: refused by the case and by the solver.
  try {
    load_case(testing_cases::shipped_case("cantilever_2d.toml"), {"method.free_edge_uniaxial=true"});
    ADD_FAILURE() << "free_edge_uniaxial accepted in 2D";
  } catch (const CaseError& e) {
    ASSERT_EQ(e.messages().size(), 1u);
    EXPECT_NE(e.messages().front().find("method.free_edge_uniaxial"), std::string::npos) << e.what();
  }
  SolverSettings<2> with_edges = model.settings;
  with_edges.free_edge_uniaxial = Toggle::on;
  EXPECT_THROW(TaylorSph<2>(model.real, model.virtual_particles, *model.material, with_edges, model.conditions),
               std::invalid_argument);
}

// SolverSettings::free_edge_uniaxial acts on the particles of the four long edges between
// the free side faces (not their ends on the clamp and the loaded tip face, nor the
// faces), and their stress stays uniaxial along the edge. The same beam turned about x
// or z (faces no longer coordinate planes) has none: the edge is recognised only where
// its neighbours fill a quarter space between two coordinate planes.
TEST(Cantilever, FreeEdgesOfAnAxisAlignedBoxOnly) {
  const CaseFile c = load_case(testing_cases::shipped_case("cantilever_3d.toml"), {"geometry.spacing=0.05"});
  BuiltCase<3> model = build_case<3>(c);
  const ParticleSet<3> real = model.real, virtual_particles = model.virtual_particles;
  TaylorSph<3> solver = make_solver(c, model);
  const std::vector<std::uint32_t> edge = solver.free_edge_particles();
  ASSERT_EQ(edge.size(), 4u * 19u);
  const auto& r = solver.real();
  for (std::uint32_t i : edge) {
    EXPECT_NEAR(std::abs(r.initial_position[1][i]), 0.05, 1e-12);
    EXPECT_NEAR(std::abs(r.initial_position[2][i]), 0.05, 1e-12);
    EXPECT_GT(r.initial_position[0][i], 0.01);
    EXPECT_LT(r.initial_position[0][i], 0.99);
  }
  for (int k = 0; k < 50; ++k) solver.step(model.dt);
  double largest_axial = 0.0;
  for (std::uint32_t i : edge) {
    largest_axial = std::max(largest_axial, std::abs(solver.real().stress[0][i]));  // xx
    for (int m = 1; m < stress_component_count<3>; ++m) EXPECT_EQ(solver.real().stress[m][i], 0.0) << m;
  }
  EXPECT_GT(largest_axial, 0.0);

  // Turned by 30 degrees about axis `about` (both particle sets, positions and initial
  // positions): no particle is on an axis-parallel edge with both faces free.
  for (int about : {0, 2}) {
    const double cs = std::cos(M_PI / 6.0), sn = std::sin(M_PI / 6.0);
    const int a = (about + 1) % 3, b = (about + 2) % 3;
    auto turn = [&](ParticleSet<3> set) {
      for (std::size_t i = 0; i < set.size(); ++i)
        for (auto* field : {&set.position, &set.initial_position}) {
          const double u = (*field)[a][i], w = (*field)[b][i];
          (*field)[a][i] = cs * u - sn * w;
          (*field)[b][i] = sn * u + cs * w;
        }
      return set;
    };
    const TaylorSph<3> turned(turn(real), turn(virtual_particles), *model.material, model.settings, model.conditions);
    EXPECT_TRUE(turned.free_edge_particles().empty()) << "about axis " << about;
  }
}

// The rotating cube of tools/cases/rotation_3d.toml (6^3, alpha 1.2, omega = 2 rad/s)
// with free_edge_uniaxial, turned 73 degrees (130 steps): its edge particles stay the
// same set (decided on the initial normals; on the current ones the z-edges left the
// treatment at 45 degrees), and their uniaxial stress stays of the order of the
// centripetal stress rho omega^2 R^2 / 2 = 1 kPa. The rate along the edge once left out
// the normal derivative, and the end particles of the edges took (n . e) E omega:
// 81 kPa at this point, and the cube lost 88 % of its spin in a turn (2026-11-29).
TEST(Cantilever, FreeEdgesOfASpinningCubeKeepTheirStressSmall) {
  testing_cases::SteppedCase<3> cube("rotation_3d.toml",
                                     {"geometry.spacing=0.2", "method.alpha=1.2"}, 0);
  TaylorSph<3>& solver = cube.solver;
  const std::vector<std::uint32_t> edge = solver.free_edge_particles();
  ASSERT_EQ(edge.size(), 12u * 4u);
  for (int k = 0; k < 130; ++k) solver.step(cube.model.dt);
  EXPECT_GT(solver.time() * 2.0, 1.2);  // turned more than 69 degrees
  EXPECT_EQ(solver.free_edge_particles(), edge);
  double largest = 0.0;
  for (std::uint32_t i : edge)
    for (int m = 0; m < stress_component_count<3>; ++m)
      largest = std::max(largest, std::abs(solver.real().stress[m][i]));
  EXPECT_LT(largest, 2000.0);
}

// The free vertices of a 3D body (three traction-free faces) carry no stress: the
// rotating cube's eight corners (6^3, alpha 1.2) after 20 steps, while its faces carry
// the centripetal stress; the 3D cantilever's corners on its loaded tip (alpha 1.2: their
// neighbours on the tip face carry the load) do carry stress.
// Before 2026-11-29 a vertex took the characteristic relations on its diagonal normal
// (12.7 kPa at the rotating cube's corners after 0.8 s).
TEST(Cantilever, FreeVerticesCarryNoStress) {
  const testing_cases::SteppedCase<3> cube("rotation_3d.toml", {"geometry.spacing=0.2", "method.alpha=1.2"}, 20);
  const auto& r = cube.solver.real();
  int vertices = 0;
  double largest_face = 0.0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    int extreme = 0;
    for (int d = 0; d < 3; ++d) extreme += std::abs(std::abs(r.initial_position[d][i]) - 0.5) < 1e-9;
    for (int m = 0; m < stress_component_count<3>; ++m) {
      if (extreme == 3) {
        EXPECT_EQ(r.stress[m][i], 0.0) << "vertex " << i << " component " << m;
      }
      if (extreme == 1) largest_face = std::max(largest_face, std::abs(r.stress[m][i]));
    }
    vertices += extreme == 3;
  }
  EXPECT_EQ(vertices, 8);
  EXPECT_GT(largest_face, 10.0);

  const testing_cases::SteppedCase<3> beam("cantilever_3d.toml", {"geometry.spacing=0.05", "method.alpha=1.2"}, 50);
  const auto& b = beam.solver.real();
  int loaded = 0;
  for (std::size_t i = 0; i < b.size(); ++i)
    if (std::abs(b.initial_position[0][i] - 1.0) < 1e-9 && std::abs(std::abs(b.initial_position[1][i]) - 0.05) < 1e-9 &&
        std::abs(std::abs(b.initial_position[2][i]) - 0.05) < 1e-9) {
      ++loaded;
      double largest = 0.0;
      for (int m = 0; m < stress_component_count<3>; ++m) largest = std::max(largest, std::abs(b.stress[m][i]));
      EXPECT_GT(largest, 0.0) << "tip corner " << i;
    }
  EXPECT_EQ(loaded, 4);
}

// 101 x 11 real particles (the seed's discretisation, the shipped case): tip deflection
// within 2 % of the exact value and the L2 error of u_y along the axis below 3 %
// (issue 3). Measured: plane stress 0.38 % and 0.51 %, plane strain 0.32 % and 0.42 %.
void expect_seed_accuracy(PlaneMode mode) {
  const CaseRun r = testing_cases::run_case_file(
      testing_cases::shipped_case("cantilever_2d.toml"),
      {std::string("material.plane=") + (mode == PlaneMode::plane_strain ? "strain" : "stress"), kinetic_rest(1e-5, mode)});
  EXPECT_TRUE(at_rest(r)) << "t = " << r.report.time;
  EXPECT_LT(r.final_error("tip_error_percent"), 2.0) << "tip " << r.final_error("tip_displacement_y");
  EXPECT_LT(r.final_error("axis_displacement_y_l2_percent"), 3.0);
  EXPECT_DOUBLE_EQ(r.final_error("tip_displacement_y_exact"), seed_beam(mode).tip_deflection());
  // At rest within about a second (ramp 0.31 s; measured 0.95 s and 0.82 s), not at the
  // time limit: a creeping beam would not get there.
  EXPECT_LT(r.report.time, 1.5);
  EXPECT_EQ(r.report.real_particles, 1111u);
}
TEST(Cantilever, PlaneStressMatchesTimoshenkoGoodier) { expect_seed_accuracy(PlaneMode::plane_stress); }
TEST(Cantilever, PlaneStrainMatchesTimoshenkoGoodier) { expect_seed_accuracy(PlaneMode::plane_strain); }

// The plane-stress beam of nodes_x x ((nodes_x - 1) / 10 + 1) particles with the
// shipped options (surface extrapolation on or off), run to rest (at most 2 s), with
// the kinetic-energy rest rule at `kinetic_tolerance` of the load's work.
CaseRun run_beam(int nodes_x, bool surface_extrapolation, double kinetic_tolerance = 1e-5,
                 std::vector<std::string> more = {}) {
  std::vector<std::string> overrides = {spacing_for(nodes_x), "time.end=2.0", kinetic_rest(kinetic_tolerance),
                                        std::string("method.surface_extrapolation=") +
                                            (surface_extrapolation ? "true" : "false")};
  overrides.insert(overrides.end(), more.begin(), more.end());
  return testing_cases::run_case_file(testing_cases::shipped_case("cantilever_2d.toml"), overrides,
                                      /*record_energy=*/true);
}

// The rest criterion reads the kinetic energy as well as the tip speed: at 41 x 5 the
// tip is slow at 0.86 s (its turning point) while the beam keeps 2.0e-6 of the load's
// work as kinetic energy, which falls only slowly (1.8e-6 at 2 s; the sections turn
// back slowly: docs/validation.md). The tolerance 1e-5 accepts it (at rest before 1 s),
// 1e-6 does not by 1.2 s.
TEST(Cantilever, RestNeedsTheKineticEnergyToo) {
  const double work = 1000.0 * seed_beam().tip_deflection();
  EXPECT_NEAR(work, 1000.0 * 0.050344, 1e-3);
  const CaseRun loose = run_beam(41, true);
  ASSERT_TRUE(at_rest(loose)) << "t = " << loose.report.time;
  EXPECT_LT(loose.report.time, 1.0);
  ASSERT_FALSE(loose.steps.empty());
  EXPECT_DOUBLE_EQ(loose.steps.back().time, loose.report.time);
  EXPECT_LT(loose.steps.back().kinetic_energy, 1e-5 * work);
  EXPECT_GT(loose.steps.back().kinetic_energy, 1e-6 * work);
  const CaseRun strict = run_beam(41, true, 1e-6, {"time.end=1.2"});
  EXPECT_EQ(strict.report.status, RunReport::Status::not_at_rest);
  EXPECT_GT(strict.steps.back().kinetic_energy, 1e-6 * work);
}

// With the shipped options the error falls at second order with dx: measured 2.33 % at
// 41 x 5 and 1.04 % at 61 x 7 (rate 1.98), 0.59 % at 81 x 9, 0.38 % at 101 x 11
// (docs/validation.md). The creeping characteristic clamp had no rate.
TEST(Cantilever, DefaultsConvergeAtSecondOrder) {
  const CaseRun coarse = run_beam(41, true), fine = run_beam(61, true);
  ASSERT_TRUE(at_rest(coarse)) << "t = " << coarse.report.time;
  ASSERT_TRUE(at_rest(fine)) << "t = " << fine.report.time;
  const double coarse_tip = coarse.final_error("tip_error_percent"), fine_tip = fine.final_error("tip_error_percent");
  const double coarse_axis = coarse.final_error("axis_displacement_y_l2_percent");
  const double fine_axis = fine.final_error("axis_displacement_y_l2_percent");
  EXPECT_LT(std::abs(coarse_tip), 4.0) << "tip " << coarse.final_error("tip_displacement_y");
  EXPECT_LT(coarse_axis, 4.0);
  const double rate = std::log(coarse_tip / fine_tip) / std::log(1.5);
  EXPECT_NEAR(rate, 2.0, 0.3) << coarse_tip << " % -> " << fine_tip << " %";
  const double axis_rate = std::log(coarse_axis / fine_axis) / std::log(1.5);
  EXPECT_NEAR(axis_rate, 2.0, 0.4) << coarse_axis << " % -> " << fine_axis << " %";
}

// SolverSettings::surface_extrapolation: the free-surface particles' tangential strain
// rate moved from the virtual row half a cell inside to the surface. Without it the
// outer fibres are softer by (dx / 2) / (D / 2) and the beam too flexible by about that
// share of its bending stiffness: predicted 20.0 % at 41 x 5, measured 19.15 % (with
// it 2.33 %).
TEST(Cantilever, WithoutSurfaceExtrapolationTheOuterFibresAreSoft) {
  const CaseRun r = run_beam(41, false);
  ASSERT_TRUE(at_rest(r)) << "t = " << r.report.time;
  EXPECT_GT(r.final_error("tip_displacement_y"), r.final_error("tip_displacement_y_exact"));  // too flexible
  EXPECT_NEAR(r.final_error("tip_error_percent"), 19.15, 1.0);
}

// Updated Lagrangian (issue 3). The virtual particles are kept at their material
// points (SolverSettings::VirtualMotion::material_point): 41 x 5, +0.72 % at the tip
// (small strain +2.33 %; the large-displacement effect at this load is about -0.2 %),
// measured at 0.74 s. That "rest" was the former tsph-cantilever's rule, |v_y| of the tip
// alone, met at a zero crossing: the tip keeps an oscillation of about 1e-4 m/s in v_y
// and a drift of -5e-5 m/s in v_x to 3 s (main's `tsph run` of the same case says "not at
// rest" too; docs/known-problems.md). So the deflection is checked at t = 1 s, past the
// ramp and the first-mode decay, with the same bounds.
TEST(Cantilever, UpdatedLagrangianMatchesTheBeam) {
  const CaseRun r = run_beam(41, true, 1e-5, {"method.kinematics=updated_lagrangian", "time.end=1.0",
                                              "damping.rest_velocity=0"});
  ASSERT_EQ(r.report.status, RunReport::Status::finished);
  ASSERT_EQ(r.report.time, 1.0);
  // +2.04 % since the surface particles move with their sections (method.surface_motion,
  // 2026-11-28; before +0.7 %, their lag stiffening the beam): small strain reads +2.33 %
  // at 41 x 5, the geometry takes about 0.2 % off.
  EXPECT_LT(r.final_error("tip_error_percent"), 2.5) << "tip " << r.final_error("tip_displacement_y");
  EXPECT_GT(r.final_error("tip_error_percent"), 1.5) << "tip " << r.final_error("tip_displacement_y");
  EXPECT_LT(r.final_error("axis_displacement_y_l2_percent"), 3.0);
  EXPECT_GT(r.final_error("tip_displacement_y"), r.final_error("tip_displacement_y_exact"));  // not stiff
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
template <int Dim>
void expect_same_up_to_permutation(const ParticleSet<Dim>& a, const ParticleSet<Dim>& b, const std::string& what) {
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
  for (int d = 0; d < Dim; ++d) {
    check(a.position[d], b.position[d], "position");
    check(a.velocity[d], b.velocity[d], "velocity");
    EXPECT_GT(check(a.displacement[d], b.displacement[d], "displacement"), 0.0) << what;
  }
  for (int m = 0; m < stress_component_count<Dim>; ++m) check(a.stress[m], b.stress[m], "stress");
  check(a.density, b.density, "density");
}

TEST_P(CantileverPermutation, RenumberedParticlesRunAsTheLattice) {
  const auto [kinematics, conservative] = GetParam();
  const bool moving = kinematics == Kinematics::updated_lagrangian;
  // The shipped case's options: wall clamp, stiffness 0.05, extrapolation.
  const CaseFile c = load_case(testing_cases::shipped_case("cantilever_2d.toml"),
                               {"geometry.spacing=0.025", "method.kinematics=" + std::string(to_string(kinematics))});
  BuiltCase<2> built = build_case<2>(c);
  const std::size_t tip = tip_of(built);
  const ParticleSet<2> real = built.real;
  const ParticleSet<2> virtual_particles = built.virtual_particles;
  SolverSettings<2> settings = built.settings;
  settings.conservative_momentum = conservative;
  const double dt = built.dt;
  const int steps = 300;
  auto solver_on = [&](ParticleSet<2> r, ParticleSet<2> v, SpatialOrder order) {
    SolverSettings<2> with_order = settings;
    with_order.spatial_order = order;
    return TaylorSph<2>(std::move(r), std::move(v), *built.material, with_order, built.conditions);
  };

  TaylorSph<2> lattice = solver_on(real, virtual_particles, SpatialOrder::none);
  for (int k = 0; k < steps; ++k) lattice.step(dt);
  ASSERT_GT(std::abs(lattice.real().displacement[1][tip]), 0.0);

  ParticleSet<2> shuffled_real = real, shuffled_virtual = virtual_particles;
  shuffled_real.permute(random_order(real.size(), 3));
  shuffled_virtual.permute(random_order(virtual_particles.size(), 4));
  TaylorSph<2> sorted = solver_on(shuffled_real, shuffled_virtual, SpatialOrder::cells);
  EXPECT_EQ(sorted.counters().reorders, 1);
  for (int k = 0; k < steps; ++k) sorted.step(dt);
  expect_same_up_to_permutation(sorted.real(), lattice.real(), "shuffled, sorted at construction");

  TaylorSph<2> renumbered = solver_on(real, virtual_particles, SpatialOrder::cells);
  for (int k = 0; k < steps / 2; ++k) renumbered.step(dt);
  renumbered.permute_particles(random_order(real.size(), 5), random_order(virtual_particles.size(), 6));
  bool permuted = false;
  for (std::size_t k = 0; k < real.size(); ++k) permuted = permuted || renumbered.real().id[k] != k;
  EXPECT_TRUE(permuted);
  for (int k = steps / 2; k < steps; ++k) renumbered.step(dt);
  // Updated Lagrangian: the random order has decayed, so the next rebuild sorts it;
  // with the reference kernel (the default) the lists are never searched again, and with
  // the current kernel's Verlet skin the order is checked only when the lists run out at
  // x^n (rebuild_neighbors), which does not happen in the remaining steps here (measured:
  // no sort); the run still equals the lattice's.
  const bool rebuilds = moving && settings.kernel_configuration == SolverSettings<2>::KernelConfiguration::current &&
                        settings.neighbor_skin == 0.0;
  EXPECT_EQ(renumbered.counters().reorders, rebuilds ? 1 : 0);
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

// The free vertices' and edges' geometry (BoundaryParticles::box_corner, edge_axis),
// decided once at the first build, moves with the particles when they are renumbered:
// the rotating cube (6^3, alpha 1.2, its edges uniaxial and its vertices stress-free by
// default) renumbered at random after 10 steps runs as the lattice-ordered one to
// round-off, with the same edge particles (by id).
TEST(Cantilever, FreeEdgesAndVerticesFollowARenumbering) {
  const CaseFile c = load_case(testing_cases::shipped_case("rotation_3d.toml"), {"geometry.spacing=0.2", "method.alpha=1.2"});
  BuiltCase<3> built = build_case<3>(c);
  auto solver_of = [&]() {
    return TaylorSph<3>(built.real, built.virtual_particles, *built.material, built.settings, built.conditions);
  };
  TaylorSph<3> lattice = solver_of(), renumbered = solver_of();
  for (int k = 0; k < 10; ++k) lattice.step(built.dt), renumbered.step(built.dt);
  renumbered.permute_particles(random_order(built.real.size(), 8), random_order(built.virtual_particles.size(), 9));
  for (int k = 0; k < 30; ++k) lattice.step(built.dt), renumbered.step(built.dt);
  auto edge_ids = [](const TaylorSph<3>& solver) {
    std::vector<std::uint32_t> ids;
    for (std::uint32_t i : solver.free_edge_particles()) ids.push_back(solver.real().id[i]);
    std::sort(ids.begin(), ids.end());
    return ids;
  };
  EXPECT_EQ(edge_ids(lattice).size(), 12u * 4u);
  EXPECT_EQ(edge_ids(renumbered), edge_ids(lattice));
  expect_same_up_to_permutation(renumbered.real(), lattice.real(), "rotating cube renumbered after 10 steps");
}

// The 3D beam (1 x 0.1 x 0.1 m, P = 100 N; the shipped case) against the Timoshenko
// beam (CantileverBeam<3>): 41 x 5 x 5, measured -1.77 % at the tip and 1.35 % on the
// axis, at rest at 0.83 s with 3.3e-6 of the load's work as kinetic energy. Without
// free_edge_uniaxial the tip was 86 % low ("at rest" by the tip speed alone with 3e-3 of
// the work as kinetic energy: hence the kinetic-energy rule); the 5 % bound also
// catches a +-10 % error.
TEST(Cantilever, ThreeDimensionalBeamMatchesTimoshenko) {
  CantileverBeam<3> beam;
  beam.load = 100.0;
  char kinetic[96];
  std::snprintf(kinetic, sizeof kinetic, "damping.rest_kinetic_energy=%.17g", 1e-5 * 100.0 * beam.tip_deflection());
  const CaseRun r =
      testing_cases::run_case_file(testing_cases::shipped_case("cantilever_3d.toml"), {"time.end=1.5", kinetic});
  EXPECT_TRUE(at_rest(r)) << "t = " << r.report.time;
  EXPECT_LT(r.report.time, 1.2);
  EXPECT_NEAR(r.final_error("tip_displacement_y_exact"), 0.050390, 1e-6);
  EXPECT_LT(r.final_error("tip_error_percent"), 5.0) << "tip " << r.final_error("tip_displacement_y");
  EXPECT_LT(r.final_error("axis_displacement_y_l2_percent"), 5.0);
  EXPECT_EQ(r.report.real_particles, 41u * 5u * 5u);
}

// Bad input: the parameter is named (the one check of every range, in the case reader),
// and a depth without a row of particles on the axis is refused by the builder.
TEST(Cantilever, ValidationNamesTheParameter) {
  try {
    load_case(testing_cases::shipped_case("cantilever_2d.toml"), {"material.nu=0.5"});
    ADD_FAILURE() << "nu = 0.5 accepted";
  } catch (const CaseError& e) {
    EXPECT_NE(e.messages().front().find("material.nu = 0.5 is invalid: must lie in (-1, 0.5)"), std::string::npos)
        << e.what();
  }
  // 111 x 12: no particle on the axis y = 0.
  const CaseFile even = load_case(testing_cases::shipped_case("cantilever_2d.toml"), {spacing_for(111)});
  try {
    build_case<2>(even);
    ADD_FAILURE() << "a beam without an axis row accepted";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("needs a real particle on the beam axis"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace tsph
