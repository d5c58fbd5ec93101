// Homogeneous large strain (issue 14): the closed-form Jaumann stresses of
// engine/validation/homogeneous.hpp against a fine RK4 integration of the same ODE, the
// exact affine motion of engine/affine_motion.hpp, and the `velocity_gradient` key of a
// velocity boundary (docs/cases.md): read, refused where it does not apply, and imposed
// as v = value + G x at the particles' current positions.
#include "engine/affine_motion.hpp"
#include "engine/case/case_build.hpp"
#include "engine/case/case_file.hpp"
#include "engine/time_function.hpp"
#include "engine/validation/homogeneous.hpp"
#include "tests/case_helpers.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace {

using namespace tsph;

constexpr double kYoung = 1e6, kNu = 0.3;
const double kShear = kYoung / (2 * (1 + kNu)), kLame = kYoung * kNu / ((1 + kNu) * (1 - 2 * kNu));

TEST(MatrixExponential, MatchesClosedForms) {
  Eigen::Matrix2d spin;
  const double angle = 7.3;  // more than a turn: scaling and squaring
  spin << 0, -angle, angle, 0;
  Eigen::Matrix2d rotation;
  rotation << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  EXPECT_LT((matrix_exponential<2>(spin) - rotation).norm(), 1e-13);
  Eigen::Matrix3d diagonal = Eigen::Vector3d(0.4, -2.0, 3.5).asDiagonal();
  const Eigen::Matrix3d expected = Eigen::Vector3d(std::exp(0.4), std::exp(-2.0), std::exp(3.5)).asDiagonal();
  EXPECT_LT((matrix_exponential<3>(diagonal) - expected).norm(), 1e-13 * expected.norm());
  Eigen::Matrix2d shear;  // nilpotent: exp = I + G
  shear << 0, 5, 0, 0;
  EXPECT_LT((matrix_exponential<2>(shear) - (Eigen::Matrix2d::Identity() + shear)).norm(), 1e-14);
}

TEST(AffineMotion, FollowsTheVelocityField) {
  Eigen::Matrix2d g;
  g << 0.3, 0.7, -0.2, -0.1;
  const AffineMotion<2> motion(g, Eigen::Vector2d(0.5, -1.0));
  const Eigen::Vector2d x0(0.3, -0.4);
  EXPECT_LT((motion.position(x0, 0.0) - x0).norm(), 1e-15);
  for (double t : {0.5, 2.0, 6.0}) {  // dx/dt = a + G x along the motion
    const double h = 1e-5;
    const Eigen::Vector2d rate = (motion.position(x0, t + h) - motion.position(x0, t - h)) / (2 * h);
    EXPECT_LT((rate - motion.velocity(x0, t)).norm(), 1e-8) << t;
  }
  Eigen::Matrix2d simple_shear;  // x(t) = x0 + gamma_dot t y0
  simple_shear << 0, 0.1, 0, 0;
  const AffineMotion<2> shear(simple_shear, Eigen::Vector2d::Zero());
  EXPECT_LT((shear.position(x0, 50.0) - Eigen::Vector2d(0.3 - 5 * 0.4, -0.4)).norm(), 1e-13);
}

// The closed forms equal a fine RK4 integration of the Jaumann ODE (to 1e-9 of mu).
TEST(HomogeneousClosedForms, MatchRk4OfTheJaumannOde) {
  const double rate = 0.05, t = std::log(1.5) / rate;
  Eigen::Matrix3d stretch = Eigen::Vector3d(rate, -kNu * rate, -kNu * rate).asDiagonal();
  EXPECT_LT((homogeneous::uniaxial_stress(kYoung, std::log(1.5)) - homogeneous::jaumann_rk4(kLame, kShear, stretch, t, 200))
                .norm(), 1e-9 * kShear);
  Eigen::Matrix3d compress = Eigen::Vector3d(-rate, kNu * rate, kNu * rate).asDiagonal();
  const double tc = std::log(0.7) / -rate;
  EXPECT_LT((homogeneous::uniaxial_stress(kYoung, std::log(0.7)) - homogeneous::jaumann_rk4(kLame, kShear, compress, tc, 200))
                .norm(), 1e-9 * kShear);
  Eigen::Matrix3d strain = Eigen::Matrix3d::Zero();
  strain(0, 0) = rate;
  EXPECT_LT((homogeneous::uniaxial_strain(kLame, kShear, std::log(1.5)) - homogeneous::jaumann_rk4(kLame, kShear, strain, t, 200))
                .norm(), 1e-9 * kShear);
  for (double gamma : {0.5, M_PI / 2, 3.0, 5.0}) {
    Eigen::Matrix3d shear = Eigen::Matrix3d::Zero();
    shear(0, 1) = 0.1;
    const Eigen::Matrix3d rk4 = homogeneous::jaumann_rk4(kLame, kShear, shear, gamma / 0.1, 4000);
    EXPECT_LT((homogeneous::simple_shear(kShear, gamma) - rk4).norm(), 1e-9 * kShear) << gamma;
  }
  // ... and the RK4 is itself checked: a coarse one misses by its own O(dt^4) error.
  Eigen::Matrix3d shear = Eigen::Matrix3d::Zero();
  shear(0, 1) = 0.1;
  EXPECT_GT((homogeneous::simple_shear(kShear, 5.0) - homogeneous::jaumann_rk4(kLame, kShear, shear, 50.0, 4)).norm(),
            1e-3 * kShear);
}

const std::string kBlock = R"(
dimension = 2
[geometry]
spacing = 0.1
box = { lower = [-0.5, -0.5], upper = [0.5, 0.5] }
[material]
E = 1e6
nu = 0.3
rho = 1000.0
[method]
alpha = 0.6
kinematics = "updated_lagrangian"
[time]
end = 0.1
cfl = 0.9
[[boundary]]
name = "affine"
type = "velocity"
region = { type = "all" }
)";

std::string error_of(const std::string& text) {
  try {
    load_case_text(text, "block.toml");
  } catch (const CaseError& e) {
    return e.what();
  }
  return "";
}

TEST(VelocityGradientKey, IsReadAndRefusedWhereItDoesNotApply) {
  const CaseFile c = load_case_text(kBlock + "value = [0.0, 0.0]\nvelocity_gradient = [0.0, 0.1, 0.0, 0.0]\n", "block.toml");
  ASSERT_EQ(c.boundaries.size(), 1u);
  EXPECT_EQ(c.boundaries[0].velocity_gradient, (std::vector<double>{0.0, 0.1, 0.0, 0.0}));
  // Not on a traction or fixed condition.
  std::string e = error_of(R"(
dimension = 2
[geometry]
spacing = 0.1
box = { lower = [0.0, 0.0], upper = [1.0, 1.0] }
[material]
E = 1e6
nu = 0.3
rho = 1000.0
[method]
alpha = 0.6
[time]
end = 0.1
cfl = 0.9
[[boundary]]
name = "load"
type = "traction"
region = { type = "half_space", point = [1.0, 0.0], normal = [1.0, 0.0] }
value = [1.0, 0.0]
velocity_gradient = [0.0, 0.1, 0.0, 0.0]
)");
  EXPECT_NE(e.find("velocity_gradient"), std::string::npos) << e;
  EXPECT_NE(e.find("applies to type = \"velocity\" only"), std::string::npos) << e;
  // Dimension^2 numbers.
  e = error_of(kBlock + "value = [0.0, 0.0]\nvelocity_gradient = [0.0, 0.1, 0.0]\n");
  EXPECT_NE(e.find("velocity_gradient"), std::string::npos) << e;
  // A time function with a non-zero value.
  e = error_of(kBlock + "value = [1.0, 0.0]\nvelocity_gradient = [0.0, 0.1, 0.0, 0.0]\ntime = { type = \"ramp\", end = 1.0 }\n");
  EXPECT_NE(e.find("time.type = \"constant\""), std::string::npos) << e;
}

// Imposed at every particle: after 40 steps of a block whose particles all carry
// v = a + G x (stretch and spin), each real particle moves at a + G x at its current
// position (to the trapezoidal rule's error in the positions) and the condition's
// velocity is exact along the motion.
TEST(VelocityGradientKey, ImposesTheAffineFieldAtTheCurrentPositions) {
  const std::string text = kBlock + "value = [0.2, -0.1]\nvelocity_gradient = [0.5, -1.0, 2.0, -0.3]\n"
                                    "[initial]\nvelocity = [0.2, -0.1]\nvelocity_gradient = [0.5, -1.0, 2.0, -0.3]\n";
  const CaseFile c = load_case_text(text, "block.toml");
  BuiltCase<2> b = build_case<2>(c);
  Eigen::Matrix2d g;
  g << 0.5, -1.0, 2.0, -0.3;
  const Eigen::Vector2d a(0.2, -0.1);
  const AffineMotion<2> motion(g, a);
  ASSERT_EQ(b.conditions.size(), 1u);
  const Eigen::Vector2d x0(0.3, 0.5);
  EXPECT_LT((b.conditions[0].prescribed(x0, Eigen::Vector2d::Ones(), 0.7) - motion.velocity(x0, 0.7)).norm(), 1e-14);
  const double dt = b.dt;
  TaylorSph<2> solver = make_solver(c, b);
  for (int k = 0; k < 40; ++k) solver.step(dt);
  const auto& r = solver.real();
  double worst = 0.0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    const Eigen::Vector2d x = r.position_of(i);
    const Eigen::Vector2d v(r.velocity[0][i], r.velocity[1][i]);
    worst = std::max(worst, (v - (a + g * x)).norm());
  }
  EXPECT_LT(worst, 1e-5 * (a.norm() + g.norm()));
}

// With value = 0 a time function scales G: v = f(t) G x, imposed along the exact motion
// x = exp(G int_0^t f) x0 (f G at different times commute). A rigid spin reversed by a
// table: the condition's velocity is f(t) G x(t) and the material point has turned by
// omega int_0^t f, the closed form of a rotation.
TEST(VelocityGradientKey, ATimeFunctionScalesTheGradientAlongTheExactMotion) {
  const std::string text = kBlock + "value = [0.0, 0.0]\nvelocity_gradient = [0.0, -2.0, 2.0, 0.0]\n"
                                    "time = { type = \"table\", times = [0.5, 1.0], values = [1.0, -1.0] }\n";
  const CaseFile c = load_case_text(text, "block.toml");
  BuiltCase<2> b = build_case<2>(c);
  ASSERT_EQ(b.conditions.size(), 1u);
  const Eigen::Vector2d x0(0.3, 0.5);
  // int_0^t f by hand (f = 1 - 4 (t - 0.5) between 0.5 and 1): t until 0.5, then
  // t - 2 (t - 0.5)^2 until 1.0 (0.625 at the turn t = 0.75, 0.5 at 1.0), then 0.5 - (t - 1).
  const auto integral = [](double t) {
    if (t <= 0.5) return t;
    if (t <= 1.0) return t - 2.0 * (t - 0.5) * (t - 0.5);
    return 0.5 - (t - 1.0);
  };
  for (double t : {0.25, 0.5, 0.6, 0.75, 0.9, 1.0, 1.7}) {
    const TimeFunction f = TimeFunction::table({0.5, 1.0}, {1.0, -1.0});
    EXPECT_NEAR(f.integral(t), integral(t), 1e-15) << "t = " << t;
    const double angle = 2.0 * integral(t);  // omega = 2 rad/s
    const Eigen::Vector2d x = Eigen::Rotation2Dd(angle).toRotationMatrix() * x0;
    const Eigen::Vector2d expected = f(t) * 2.0 * Eigen::Vector2d(-x.y(), x.x());
    EXPECT_LT((b.conditions[0].prescribed(x0, Eigen::Vector2d::Ones(), t) - expected).norm(), 1e-14) << "t = " << t;
  }
  // A moving value with a non-constant time function stays refused (its motion is not exact).
  const std::string e = error_of(kBlock + "value = [0.1, 0.0]\nvelocity_gradient = [0.0, -2.0, 2.0, 0.0]\n"
                                          "time = { type = \"table\", times = [0.5, 1.0], values = [1.0, -1.0] }\n");
  EXPECT_NE(e.find("value = zeros the time function scales G"), std::string::npos) << e;
}

// A driven body (SolverState::driven_condition: one velocity condition on every
// particle): the virtual particles take the prescribed field at n+1/2 as well, so every
// velocity the full step reads is the affine field's and the stress follows the closed
// form at every particle, the surface included (the validation suite's homogeneous_*
// cases; without it a sheared block diverged from its acute corners). A second condition
// makes the body free again.
TEST(DrivenBody, VirtualParticlesFollowTheField) {
  const std::string drive = "value = [0.2, -0.1]\nvelocity_gradient = [0.5, -1.0, 2.0, -0.3]\n"
                            "[initial]\nvelocity = [0.2, -0.1]\nvelocity_gradient = [0.5, -1.0, 2.0, -0.3]\n";
  const CaseFile c = load_case_text(kBlock + drive, "block.toml", {"method.alpha=1.2"});
  BuiltCase<2> b = build_case<2>(c);
  Eigen::Matrix2d g;
  g << 0.5, -1.0, 2.0, -0.3;
  const AffineMotion<2> motion(g, Eigen::Vector2d(0.2, -0.1));
  TaylorSph<2> solver = make_solver(c, b);
  EXPECT_TRUE(solver.state().driven());
  const double dt = b.dt;
  for (int k = 0; k < 40; ++k) solver.step(dt);
  const auto& v = solver.virtual_particles();
  const double half_time = solver.time() - 0.5 * dt;  // the last step's n+1/2
  double worst = 0.0;
  for (std::size_t q = 0; q < v.size(); ++q) {
    const Eigen::Vector2d x0(v.initial_position[0][q], v.initial_position[1][q]);
    worst = std::max(worst, (Eigen::Vector2d(v.velocity[0][q], v.velocity[1][q]) - motion.velocity(x0, half_time)).norm());
  }
  EXPECT_LT(worst, 1e-12);
  // Every real particle's velocity gradient is G: its stress rate is the closed form's.
  // After 40 steps the stress of every particle (surface included) is one value.
  const auto& r = solver.real();
  double spread = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < r.size(); ++i)
    for (int m = 0; m < 3; ++m) {
      spread = std::max(spread, std::abs(r.stress[m][i] - r.stress[m][0]));
      scale = std::max(scale, std::abs(r.stress[m][0]));
    }
  EXPECT_LT(spread, 1e-9 * scale);

  // A second condition (a free face) on part of the body: not driven.
  const CaseFile free_face = load_case_text(kBlock + drive + R"(
[[boundary]]
name = "free face"
type = "free"
region = { type = "half_space", point = [0.5, 0.0], normal = [1.0, 0.0] }
)", "block.toml");
  BuiltCase<2> b2 = build_case<2>(free_face);
  EXPECT_FALSE(make_solver(free_face, b2).state().driven());
}

// time.adaptive (engine/solver/time_step.hpp): on a lattice moved by an affine map x = F X
// the limit is dx lambda_min(F) / c_p(rho0 / det F), exact, at every virtual particle.
TEST(AdaptiveTimeStep, IsTheWaveCrossingOfTheSmallestStretch) {
  const CaseFile c = load_case(testing_cases::shipped_case("homogeneous_3d.toml"), {"time.adaptive=true"});
  EXPECT_TRUE(c.adaptive_time_step);
  BuiltCase<3> b = build_case<3>(c);
  TaylorSph<3> solver = make_solver(c, b);
  const double dx = c.spacing, modulus = solver.material().elastic().p_wave_modulus();
  const auto at_rest = solver.stable_time_step();
  EXPECT_NEAR(at_rest.time_step, dx / std::sqrt(modulus / c.density), 1e-12 * at_rest.time_step);
  EXPECT_NEAR(at_rest.stretch, 1.0, 1e-12);
  Eigen::Matrix3d f;  // a flattening with shear and a turn: lambda_min well below 1
  f << 1.3, 0.4, 0.1, -0.2, 0.25, 0.05, 0.3, 0.1, 1.1;
  auto& state = solver.state();
  for (auto* set : {&state.real, &state.virtual_})
    for (std::size_t i = 0; i < set->size(); ++i) {
      Eigen::Vector3d x0;
      for (int d = 0; d < 3; ++d) x0[d] = set->initial_position[d][i];
      const Eigen::Vector3d x = f * x0 + Eigen::Vector3d(0.7, -0.2, 0.1);
      for (int d = 0; d < 3; ++d) set->position[d][i] = x[d];
    }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(f.transpose() * f);
  const double stretch = std::sqrt(eigen.eigenvalues()[0]), jacobian = f.determinant();
  const auto limit = solver.stable_time_step();
  EXPECT_NEAR(limit.stretch, stretch, 1e-12);
  EXPECT_NEAR(limit.jacobian, jacobian, 1e-12);
  EXPECT_NEAR(limit.time_step, dx * stretch / std::sqrt(modulus * jacobian / c.density), 1e-12 * limit.time_step);
  EXPECT_LT(limit.particle, solver.virtual_particles().size());
}

TEST(AdaptiveTimeStep, KeyIsRefusedWhereItDoesNotApply) {
  auto error = [](const std::vector<std::string>& overrides) {
    try {
      load_case(testing_cases::shipped_case("homogeneous_3d.toml"), overrides);
    } catch (const CaseError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error({"time.adaptive=true", "method.kinematics=small_strain"}).find("time.adaptive"), std::string::npos);
  EXPECT_NE(error({"time.adaptive=true", "method.kinematics=small_strain"}).find("updated_lagrangian"), std::string::npos);
  EXPECT_NE(error({"time.adaptive=1"}).find("time.adaptive"), std::string::npos);
  EXPECT_EQ(error({"time.adaptive=false"}), "");
}

}  // namespace
