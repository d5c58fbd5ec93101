// SolverSettings::volumetric_average (engine/solver/stabilisation/volumetric_average.hpp):
// the yielding interior particles' pressure follows R A tr L, the volumetric rate
// averaged over each cell's corners and back over each particle's cells (B-bar). The operator
// on a plane-strain J2 block: a uniform and a linear rate are kept (the correction is
// zero to round-off), the odd-even mode is removed (its average is zero by the lattice's
// symmetry), and the boundary and non-yielding particles are left alone. Then the case
// keys: on by default where it applies, refused with the key where it does not.
#include "engine/case/case_build.hpp"
#include "engine/case/case_file.hpp"
#include "engine/input_error.hpp"
#include "engine/solver/stabilisation/volumetric_average.hpp"
#include "kernels/smoothing_kernels.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace {

using namespace tsph;

// A 2 x 1 m plane-strain block at rest, J2; alpha 1.2 (a 5 x 5 virtual stencil).
const std::string kBlockTemplate = R"(
dimension = 2
[geometry]
spacing = 0.05
box = { lower = [0.0, 0.0], upper = [2.0, 1.0] }
[material]
E = 1e7
nu = 0.3
rho = 2000.0
plane = "strain"
MODEL
[method]
alpha = 1.2
kinematics = "updated_lagrangian"
[time]
end = 1e-3
cfl = 0.5
[output]
every = 0
[[boundary]]
name = "faces"
type = "free"
region = [
  { type = "half_space", point = [0.0, 0.0], normal = [-1.0, 0.0] },
  { type = "half_space", point = [2.0, 0.0], normal = [1.0, 0.0] },
  { type = "half_space", point = [0.0, 0.0], normal = [0.0, -1.0] },
  { type = "half_space", point = [0.0, 1.0], normal = [0.0, 1.0] },
]
)";

// The block with the material model's lines in place of MODEL.
std::string block_text(const std::string& model = "model = \"j2\"\nyield_stress = 1e4") {
  std::string text = kBlockTemplate;
  return text.replace(text.find("MODEL"), 5, model);
}

struct Block {
  CaseFile file;
  BuiltCase<2> model;
  TaylorSph<2> solver;
  explicit Block(const std::vector<std::string>& overrides = {})
      : file(load_case_text(block_text(), "block.toml", overrides)),
        model(build_case<2>(file)),
        solver(make_solver(file, model)) {
    solver.step(model.dt);  // the lists built, a step taken
  }
};

// Sets every real particle's stress to zero and its rate to `rate(x, y)`, marks the
// particles yielding where `yielding(i)`, applies the average over dt and returns the
// correction of sigma_xx per unit dt K_D, which is theta - tr L.
std::vector<double> excess_after_average(Block& b,
                                         const std::function<double(double, double)>& rate,
                                         const std::function<bool(std::size_t)>& yielding) {
  SolverState<2>& s = b.solver.state();
  const std::size_t n = s.real.size();
  s.volumetric_rate.assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    for (int m = 0; m < stress_component_count<2>; ++m) s.real.stress[m][i] = 0.0;
    s.volumetric_rate[i] = rate(s.real.position[0][i], s.real.position[1][i]);
    s.real.yielding[i] = yielding(i) ? 1 : 0;
  }
  const double dt = 1e-4;
  const std::vector<double> density = s.real.density, volume = s.real.volume;  // restored below
  VolumetricAverage<2>::apply(s, dt);
  const auto& elastic = s.material.elastic();
  const double bulk = elastic.model_lame() + 2.0 * elastic.shear_modulus() / 3.0;
  std::vector<double> excess(n);
  for (std::size_t i = 0; i < n; ++i) {
    excess[i] = s.real.stress[0][i] / (dt * bulk);
    // A pressure alone: sigma_yy and sigma_zz the same (the deviator kept), no shear.
    EXPECT_NEAR(s.real.stress[1][i], s.real.stress[0][i], 1e-12 * bulk * dt);
    EXPECT_NEAR(s.real.stress[3][i], s.real.stress[0][i], 1e-12 * bulk * dt);
    EXPECT_EQ(s.real.stress[2][i], 0.0);
  }
  s.real.density = density;  // the next call starts from the same volumes
  s.real.volume = volume;
  return excess;
}

// Interior particles at least `depth` from every face of the block.
bool deep(const SolverState<2>& s, std::size_t i, double depth) {
  const double x = s.real.initial_position[0][i], y = s.real.initial_position[1][i];
  return x > depth && x < 2.0 - depth && y > depth && y < 1.0 - depth;
}

TEST(VolumetricAverage, OnByDefaultForAPressureIndependentYield) {
  Block b;
  EXPECT_EQ(b.solver.state().settings.volumetric_average, Toggle::on);
  EXPECT_TRUE(resolved_method_options(b.file).volumetric_average);
  Block off({"method.volumetric_average=false"});
  EXPECT_EQ(off.solver.state().settings.volumetric_average, Toggle::off);
  EXPECT_FALSE(resolved_method_options(off.file).volumetric_average);
}

TEST(VolumetricAverage, KeepsAUniformAndALinearRate) {
  Block b;
  const SolverState<2>& s = b.solver.state();
  const auto all = [](std::size_t) { return true; };
  const std::vector<double> uniform = excess_after_average(
      b, [](double, double) { return -3.0; }, all);
  const std::vector<double> linear = excess_after_average(
      b, [](double x, double y) { return 1.0 + 2.0 * x - 3.0 * y; }, all);
  const double h = s.settings.smoothing_length;
  int interior = 0;
  for (std::size_t i = 0; i < s.real.size(); ++i) {
    if (s.boundary.slot[i] >= 0) continue;
    EXPECT_NEAR(uniform[i], 0.0, 1e-12) << i;  // Shepard's weights sum to one
    // A linear rate is kept where both passes see a symmetric neighbourhood (away from
    // the faces: the data leave out the surface row).
    if (deep(s, i, 4.0 * h + s.initial_spacing)) {
      EXPECT_NEAR(linear[i], 0.0, 1e-10) << i;
      ++interior;
    }
  }
  EXPECT_GT(interior, 100);
}

TEST(VolumetricAverage, RemovesTheOddEvenMode) {
  Block b;
  const SolverState<2>& s = b.solver.state();
  const double dx = s.initial_spacing;
  const auto checkerboard = [dx](double x, double y) {
    return (std::lround(x / dx) + std::lround(y / dx)) % 2 == 0 ? 1.0 : -1.0;
  };
  // Every other particle yielding (by id: one sign of the mode, then the other): the
  // others are left alone.
  int removed = 0;
  for (const std::int64_t parity : {0, 1}) {
    const auto odd_id = [&s, parity](std::size_t i) { return s.real.id[i] % 2 == parity; };
    const std::vector<double> excess = excess_after_average(b, checkerboard, odd_id);
    for (std::size_t i = 0; i < s.real.size(); ++i) {
      const double x = s.real.position[0][i], y = s.real.position[1][i];
      if (s.boundary.slot[i] >= 0 || !odd_id(i)) {
        EXPECT_EQ(excess[i], 0.0) << i;  // untouched
      } else if (deep(s, i, 4.0 * s.settings.smoothing_length + dx)) {
        EXPECT_NEAR(excess[i], -checkerboard(x, y), 1e-12) << i;  // theta = 0: the mode is gone
        ++removed;
      } else {
        EXPECT_LT(std::abs(excess[i] + checkerboard(x, y)), 1.0) << i;  // damped near the faces
      }
    }
  }
  EXPECT_GT(removed, 100);
}

TEST(VolumetricAverage, RefusedWhereTheYieldReadsThePressure) {
  const auto refused = [](const std::string& text, const std::vector<std::string>& overrides,
                          const std::string& expected) {
    try {
      load_case_text(text, "block.toml", overrides);
      ADD_FAILURE() << "accepted";
    } catch (const CaseError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("method.volumetric_average"), std::string::npos) << what;
      EXPECT_NE(what.find(expected), std::string::npos) << what;
    }
  };
  const std::vector<std::string> on = {"method.volumetric_average=true"};
  refused(block_text(""), on, "leave the key out");  // elastic
  refused(block_text(), {"method.volumetric_average=true", "material.plane=\"stress\""},
          "plane strain");
  // Drucker-Prager with friction: automatic is off, true refused; without, on.
  const std::string friction =
      block_text("model = \"drucker_prager\"\ncohesion = 1e4\nfriction_angle = 20.0");
  EXPECT_FALSE(resolved_method_options(load_case_text(friction, "block.toml")).volumetric_average);
  refused(friction, on, "friction_angle = 0");
  const std::string tresca = block_text("model = \"drucker_prager\"\ncohesion = 1e4");
  EXPECT_TRUE(resolved_method_options(load_case_text(tresca, "block.toml")).volumetric_average);
  const std::string cutoff =
      block_text("model = \"drucker_prager\"\ncohesion = 1e4\ntension_cutoff = 1e3");
  EXPECT_FALSE(resolved_method_options(load_case_text(cutoff, "block.toml")).volumetric_average);
}

TEST(VolumetricAverage, AutomaticRuleAndTheListsItNeeds) {
  using S2 = SolverSettings<2>;
  EXPECT_EQ(resolve_automatic_options(S2{}, true, true).volumetric_average, Toggle::on);
  EXPECT_EQ(resolve_automatic_options(SolverSettings<3>{}, true, true).volumetric_average,
            Toggle::on);
  EXPECT_EQ(resolve_automatic_options(S2{}, true, false).volumetric_average,
            Toggle::off);  // Drucker-Prager, phi > 0
  EXPECT_EQ(resolve_automatic_options(S2{}, false, false).volumetric_average,
            Toggle::off);  // elastic
  EXPECT_EQ(resolve_automatic_options(SolverSettings<1>{}, true, true).volumetric_average,
            Toggle::off);
  EXPECT_EQ(S2::bare_scheme().volumetric_average, Toggle::off);
  // The current kernel without a skin releases the lists within the step: off, and true refused.
  S2 once;
  once.kinematics = Kinematics::updated_lagrangian;
  once.kernel_configuration = S2::KernelConfiguration::current;
  once.neighbor_skin = 0.0;
  EXPECT_EQ(resolve_automatic_options(once, true, true).volumetric_average, Toggle::off);
  once.neighbor_skin = 0.05;
  EXPECT_EQ(resolve_automatic_options(once, true, true).volumetric_average, Toggle::on);
  const std::vector<std::string> current = {"method.kernel_configuration=\"current\"",
                                            "solver.neighbor_skin=0"};
  EXPECT_FALSE(resolved_method_options(load_case_text(block_text(), "block.toml", current))
                   .volumetric_average);
  std::vector<std::string> forced = current;
  forced.push_back("method.volumetric_average=true");
  try {
    Block refused(forced);
    ADD_FAILURE() << "accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("method.volumetric_average"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("neighbor_skin"), std::string::npos) << e.what();
  }
}

}  // namespace
