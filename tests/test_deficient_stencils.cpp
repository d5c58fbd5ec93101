// Deficient stencils (issue 14; docs/notes/2026-11-25-deficient-stencils.md):
//  * the four virtual neighbours of a 3D face particle at alpha 0.6 lie in one plane:
//    a regular gradient, no linear interpolation (Shepard);
//  * in updated Lagrangian with method.deficient_stencils = widen or widen_motion
//    (experimental, off by default) a real particle whose virtual stencil is deficient
//    (the corner of a 2D block at alpha 0.6: one virtual neighbour) takes a widened
//    stencil and so sees the velocity gradient; with keep it sees none;
//  * with deficient_stencils = complete a spinning block's corners at alpha 0.6 keep
//    their speed (the characteristic relations see the tangential derivatives their one
//    virtual neighbour cannot give) and the block turns (docs/notes/2026-11-28-deficient-surface-rows.md);
//  * the surface filter is exact for a linear velocity field at a corner too.
#include "engine/case/case_build.hpp"
#include "engine/case/case_file.hpp"
#include "engine/solver/full_step.hpp"
#include "kernels/corrected_operators.hpp"
#include "tests/case_helpers.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace {

using namespace tsph;

// The four virtual neighbours of a 3D face particle at h / dx = 0.6, dx = 1: the
// corners of a square at depth 0.5, one of them moved by `lift` out of the plane.
StencilStatus face_stencil(double lift, StencilWeights<3>& w) {
  std::vector<double> x = {-0.5, 0.5, -0.5, 0.5}, y = {-0.5, -0.5, 0.5, 0.5}, z = {0.5, 0.5, 0.5, 0.5 + lift};
  const std::vector<double> volume(4, 1.0);
  const PointsView<3> points{{x.data(), y.data(), z.data()}, 4};
  const std::vector<std::uint32_t> row = {0, 1, 2, 3};
  return compute_stencil<3>(CubicSpline<3>{}, 0.6, Eigen::Vector3d::Zero(), points, volume.data(), row,
                            InterpolationKind::linear, w);
}

TEST(DeficientStencils, CoplanarNeighboursHaveNoLinearInterpolation) {
  // The offsets span 3D (the correction matrix is regular), but the points lie in one
  // plane: the linear interpolation's moment matrix [1; o][1; o]^T is singular.
  StencilWeights<3> w;
  const StencilStatus flat = face_stencil(0.0, w);
  EXPECT_FALSE(flat.gradient_fallback);
  EXPECT_TRUE(flat.interpolation_fallback);
  // A lift of 0.3 dx: a regular stencil, no fallback. (In between, a nearly coplanar
  // stencil passes the moment matrix's bounds while its linear weights grow as
  // 1 / lift: the open problem of docs/notes/2026-11-25-deficient-stencils.md.)
  EXPECT_FALSE(face_stencil(0.3, w).interpolation_fallback);
}

// The full step's guard in updated Lagrangian (engine/solver/full_step.hpp): a nearly
// coplanar face row's linear weights grow as 1 / lift, far beyond
// kMaxInterpolationWeightSquares, while a regular lift (0.3 dx) and Shepard stay below.
TEST(DeficientStencils, NearlyCoplanarRowsExceedTheInterpolationBound) {
  StencilWeights<3> w;
  const StencilStatus nearly = face_stencil(1e-4, w);
  EXPECT_FALSE(nearly.interpolation_fallback);  // checked_inverse's bounds pass it
  EXPECT_GT(nearly.weight_squares, 1e3 * kMaxInterpolationWeightSquares);
  double squares = 0.0;  // the status's figure is the weights' own
  for (std::size_t k = 0; k < 4; ++k) squares += w.value[k] * w.value[k];
  EXPECT_NEAR(nearly.weight_squares, squares, 1e-12 * squares);
  const StencilStatus lifted = face_stencil(0.3, w);
  EXPECT_FALSE(lifted.interpolation_fallback);
  EXPECT_LT(lifted.weight_squares, kMaxInterpolationWeightSquares);
  const StencilStatus flat = face_stencil(0.0, w);
  EXPECT_TRUE(flat.interpolation_fallback);  // Shepard: positive weights summing to 1
  EXPECT_LE(flat.weight_squares, 1.0);
}

// The shipped rotating cube (tools/cases/rotation_3d.toml) at 6^3, alpha 0.6: the face
// rows' four virtual neighbours leave their plane in the first step, and without the
// guard the cube blew up in 3 steps (2.9 km/s at a face particle next to an edge). With
// it the face rows keep Shepard's weights and 40 steps (a quarter turn) stay below twice
// the corner speed omega R = 1.41 m/s.
TEST(DeficientStencils, RotatingCubeAtAlpha06KeepsShepardOnItsFaces) {
  const testing_cases::SteppedCase<3> cube("rotation_3d.toml", {"geometry.spacing=0.2", "output.every=0"}, 40);
  const auto& r = cube.solver.real();
  double fastest = 0.0;
  for (std::size_t i = 0; i < r.size(); ++i)
    fastest = std::max(fastest, std::hypot(r.velocity[0][i], r.velocity[1][i], r.velocity[2][i]));
  EXPECT_LT(fastest, 2.0 * 2.0 * std::sqrt(0.5));
}

// The shipped free block of tools/cases/rotation_2d.toml at 11 x 11, alpha 0.6,
// given a uniform dilation instead of the spin.
CaseFile dilating_block(const char* deficient) {
  return load_case(std::string(TSPH_SOURCE_DIR) + "/tools/cases/rotation_2d.toml",
                   {"geometry.spacing=0.1", "method.alpha=0.6", "time.cfl=0.5",
                    "initial.velocity_gradient=[0.01, 0.0, 0.0, 0.01]",
                    std::string("method.deficient_stencils=") + deficient});
}

// One step of a uniformly dilating free block: the corners' density changes as that of
// their neighbours on the edges (the free surface's characteristics make both differ
// from the bulk's exp(-dt tr L) in this first step) when their stencil is widened, and
// not at all (zero velocity gradient) when it is kept.
double worst_corner_density_change(const char* deficient, std::int64_t& widened) {
  const CaseFile c = dilating_block(deficient);
  BuiltCase<2> b = build_case<2>(c);
  TaylorSph<2> solver = make_solver(c, b);
  solver.step(b.dt);
  widened = solver.counters().widened_stencils;
  const auto& r = solver.real();
  double edge = 0.0, worst = 0.0;  // an edge particle's change, and the corners' worst
  for (std::size_t i = 0; i < r.size(); ++i) {
    const double x = r.initial_position[0][i], y = r.initial_position[1][i];
    if (std::abs(x) < 1e-9 && std::abs(y + 0.5) < 1e-9) edge = 1.0 - r.density[i] / 1000.0;
  }
  EXPECT_GT(edge, 0.0);
  for (std::size_t i = 0; i < r.size(); ++i) {
    const double x = r.initial_position[0][i], y = r.initial_position[1][i];
    if (std::abs(std::abs(x) - 0.5) < 1e-9 && std::abs(std::abs(y) - 0.5) < 1e-9)
      worst = std::max(worst, std::abs(1.0 - r.density[i] / 1000.0 - edge) / edge);
  }
  return worst;
}

TEST(DeficientStencils, CornersSeeTheVelocityGradientInUpdatedLagrangian) {
  std::int64_t widened = 0;
  EXPECT_LT(worst_corner_density_change("widen", widened), 1e-6);
  EXPECT_EQ(widened, 40);  // 4 corners and 4 x 9 edge particles (linear interpolation needs 3)
  EXPECT_LT(worst_corner_density_change("widen_motion", widened), 1e-6);
  EXPECT_EQ(widened, 40);  // the corners for both, the edges for the motion
  EXPECT_GT(worst_corner_density_change("keep", widened), 0.99);  // no gradient: no change
  EXPECT_EQ(widened, 40);  // the motion alone (SolverSettings::surface_motion = linear)
}

// The spinning block of tools/cases/rotation_2d.toml at 11 x 11, alpha 0.6.
CaseFile spinning_block(const char* deficient, const char* filter = "0.02") {
  return load_case(std::string(TSPH_SOURCE_DIR) + "/tools/cases/rotation_2d.toml",
                   {"geometry.spacing=0.1", "output.every=0", std::string("method.deficient_stencils=") + deficient,
                    std::string("method.hourglass=") + filter});
}

// The largest speed a corner of the spinning block loses in its first step along its
// rigid velocity omega x x. In that step the corner flies straight on (no stress yet),
// so against the rigid velocity at its new place it only gains the outward omega^2 R dt
// (6.9e-3 m/s), with no component along the spin.
double corner_braking(const char* deficient, const char* filter = "0.02") {
  const CaseFile c = spinning_block(deficient, filter);
  BuiltCase<2> b = build_case<2>(c);
  TaylorSph<2> solver = make_solver(c, b);
  solver.step(b.dt);
  const auto& r = solver.real();
  const double omega = 2.0;
  double worst = 0.0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    const double x0 = r.initial_position[0][i], y0 = r.initial_position[1][i];
    if (std::abs(std::abs(x0) - 0.5) > 1e-9 || std::abs(std::abs(y0) - 0.5) > 1e-9) continue;
    const double x = r.position[0][i], y = r.position[1][i];
    const double rigid_x = -omega * y, rigid_y = omega * x, speed = std::hypot(rigid_x, rigid_y);
    const double along = (r.velocity[0][i] * rigid_x + r.velocity[1][i] * rigid_y) / speed;
    worst = std::max(worst, speed - along);
  }
  return worst;
}

TEST(DeficientStencils, CompleteKeepsTheSpinningCornersSpeed) {
  // keep: the corner's S characteristic reads d v_n / d t as zero, and c_s dt omega =
  // 0.096 m/s of its 1.41 m/s is lost in one step (measured 0.097).
  EXPECT_GT(corner_braking("keep"), 0.05);
  // complete: d v_n / d t from the widened stencil (measured 2.8e-3, the second order
  // of the corner's straight flight).
  EXPECT_LT(corner_braking("complete"), 0.01);
}

// One turn of the spinning block (1 281 steps): with complete it turns at alpha 0.6
// and keeps its shape; the angular momentum changes by 2.2e-2 (the issue asks 1e-3: the
// collocation torque of docs/notes/2026-11-26-rotation-drift.md, as at alpha 1.2).
// With keep it diverges within a quarter of the turn.
TEST(DeficientStencils, CompleteTurnsTheBlockAtAlpha06) {
  const CaseFile c = spinning_block("complete");
  BuiltCase<2> b = build_case<2>(c);
  TaylorSph<2> solver = make_solver(c, b);
  auto angular_momentum = [&] {
    const auto& r = solver.real();
    double cx = 0.0, cy = 0.0, mass = 0.0, l = 0.0;
    for (std::size_t i = 0; i < r.size(); ++i) {
      cx += r.mass[i] * r.position[0][i];
      cy += r.mass[i] * r.position[1][i];
      mass += r.mass[i];
    }
    cx /= mass;
    cy /= mass;
    for (std::size_t i = 0; i < r.size(); ++i)
      l += r.mass[i] * ((r.position[0][i] - cx) * r.velocity[1][i] - (r.position[1][i] - cy) * r.velocity[0][i]);
    return l;
  };
  const double l0 = angular_momentum();
  const int steps = static_cast<int>(std::ceil(M_PI / b.dt));
  double worst = 0.0;
  for (int step = 0; step < steps; ++step) {
    solver.step(b.dt);
    if (step % 64 == 0) worst = std::max(worst, std::abs(angular_momentum() / l0 - 1.0));
  }
  worst = std::max(worst, std::abs(angular_momentum() / l0 - 1.0));
  EXPECT_LT(worst, 3e-2);
  EXPECT_GT(worst, 1e-4);  // not conserved by construction
  // The shape: each particle's distance from the centre within 0.05 dx of its start.
  const auto& r = solver.real();
  for (std::size_t i = 0; i < r.size(); ++i) {
    const double start = std::hypot(r.initial_position[0][i], r.initial_position[1][i]);
    EXPECT_NEAR(std::hypot(r.position[0][i], r.position[1][i]), start, 0.05 * 0.1) << "particle " << r.id[i];
  }
}

// The surface filter (method.hourglass) relaxes a surface velocity towards the linear
// average of its real neighbours. At a corner at alpha 0.6 (two real neighbours: no
// linear fit) that average was the Shepard one, the velocity at their centroid 0.07 dx
// inside: on the spinning block it took eps omega dx / sqrt(2) = 2.8e-3 m/s a step off the
// corner's speed. Carried back to the corner with its gradient it is exact for the
// rigid spin: the filter changes the corner's first step by round-off only.
TEST(DeficientStencils, SurfaceFilterIsExactForASpinAtTheCorners) {
  EXPECT_NEAR(corner_braking("complete", "0.02"), corner_braking("complete", "0"), 1e-4);
}

}  // namespace
