// Deficient stencils (issue 14; docs/notes/2026-11-26-deficient-stencils.md):
//  * a nearly singular correction matrix (four virtual neighbours of a 3D face particle,
//    coplanar but for a small motion) is treated as singular: its gradient would
//    amplify the data by the inverse of the tiny eigenvalue (the 3D rotating cube at
//    alpha 0.6 blew up in 3 steps);
//  * in updated Lagrangian with method.deficient_stencils = widen or widen_motion
//    (experimental, off by default) a real particle whose virtual stencil is deficient
//    (the corner of a 2D block at alpha 0.6: one virtual neighbour) takes a widened
//    stencil and so sees the velocity gradient; with keep it sees none.
#include "engine/case/case_build.hpp"
#include "engine/case/case_file.hpp"
#include "kernels/corrected_operators.hpp"

#include <gtest/gtest.h>

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

TEST(DeficientStencils, NearlyCoplanarNeighboursAreSingular) {
  StencilWeights<3> w;
  EXPECT_TRUE(face_stencil(0.0, w).gradient_fallback);  // exactly coplanar: rank 2
  // A lift of 1e-3 dx: rank 3, condition number about 1e6; accepted before (threshold
  // 1e10), when its normal gradient weights were about 1e3 / dx.
  const StencilStatus lifted = face_stencil(1e-3, w);
  EXPECT_TRUE(lifted.gradient_fallback);
  EXPECT_TRUE(lifted.interpolation_fallback);
  double largest = 0.0;
  for (std::size_t k = 0; k < 4; ++k) largest = std::max(largest, w.gradient_of(k).norm());
  EXPECT_LT(largest, 10.0);  // the pseudo-inverse drops the ill-determined direction
  // A lift of 0.3 dx is a regular stencil (no fallback).
  EXPECT_FALSE(face_stencil(0.3, w).gradient_fallback);
}

const std::string kFreeBlock = R"(
dimension = 2
[geometry]
spacing = 0.1
box = { lower = [-0.5, -0.5], upper = [0.5, 0.5] }
[material]
E = 1e6
nu = 0.3
rho = 1000.0
plane = "strain"
[method]
alpha = 0.6
kinematics = "updated_lagrangian"
[time]
end = 0.1
cfl = 0.5
[[boundary]]
name = "free surface"
type = "free"
region = [
  { type = "half_space", point = [0.5, 0.0], normal = [1.0, 0.0] },
  { type = "half_space", point = [-0.5, 0.0], normal = [-1.0, 0.0] },
  { type = "half_space", point = [0.0, 0.5], normal = [0.0, 1.0] },
  { type = "half_space", point = [0.0, -0.5], normal = [0.0, -1.0] },
]
[initial]
velocity_gradient = [0.01, 0.0, 0.0, 0.01]
)";

// One step of a uniformly dilating free block: every particle's density falls by
// exp(-dt tr L) to first order, the corners too when their stencil is widened.
using Deficient = SolverSettings<2>::DeficientStencils;
double worst_corner_density_error(Deficient deficient, std::int64_t& widened) {
  const CaseFile c = load_case_text(kFreeBlock + "", "block.toml");
  BuiltCase<2> b = build_case<2>(c);
  b.settings.deficient_stencils = deficient;
  TaylorSph<2> solver = make_solver(c, b);
  solver.step(b.dt);
  widened = solver.counters().widened_stencils;
  const double expected = std::exp(-b.dt * 0.02);
  double worst = 0.0;
  const auto& r = solver.real();
  for (std::size_t i = 0; i < r.size(); ++i) {
    const double x = r.initial_position[0][i], y = r.initial_position[1][i];
    if (std::abs(std::abs(x) - 0.5) < 1e-9 && std::abs(std::abs(y) - 0.5) < 1e-9)
      worst = std::max(worst, std::abs(r.density[i] / 1000.0 - expected) / (1.0 - expected));
  }
  return worst;
}

TEST(DeficientStencils, CornersSeeTheVelocityGradientInUpdatedLagrangian) {
  std::int64_t widened = 0;
  EXPECT_LT(worst_corner_density_error(Deficient::widen, widened), 0.05);
  // 4 corners and 4 x 9 edge particles (linear interpolation needs 3 neighbours).
  EXPECT_EQ(widened, 40);
  EXPECT_LT(worst_corner_density_error(Deficient::widen_motion, widened), 0.05);
  EXPECT_EQ(widened, 40);  // the corners for both, the edges for the motion
  EXPECT_GT(worst_corner_density_error(Deficient::keep, widened), 0.9);  // no gradient: no change
  EXPECT_EQ(widened, 0);
}

}  // namespace
