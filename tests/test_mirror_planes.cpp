// Mirror planes (engine/solver/boundary/mirror_planes.hpp; issue 16, the Taylor bar's
// quarter model): a body symmetric about its mirror planes, modelled in part with ghost
// particles, is the whole body's run particle by particle, to round-off. The lattices
// are symmetric about the planes (nodes on them), so every stencil near a plane is the
// whole body's with its sources in another order: the runs differ by the order of sums
// only. The checks would fail for a ghost with one field not reflected (a stress sign,
// a velocity component), a missing diagonal image where two planes meet, or a ghost
// read stale after a stage.
#include "engine/case/case_build.hpp"
#include "engine/case/case_file.hpp"
#include "engine/case/case_run.hpp"
#include "engine/output/vtu_writer.hpp"
#include "tests/case_helpers.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace {

using namespace tsph;

std::filesystem::path fresh_directory_path(const std::string& name) {
  return std::filesystem::path(::testing::TempDir()) / ("tsph_mirror_" + name);
}
std::filesystem::path fresh_directory(const std::string& name) { return testing_cases::fresh_named_directory("mirror", name); }

using testing_cases::LastFrame;

LastFrame run_text(const std::string& text, const std::string& name, const std::vector<std::string>& overrides = {},
                   RunReport* report = nullptr) {
  return testing_cases::run_case_text(text, name, fresh_directory(name).string(), overrides, report);
}

void replace_all(std::string& text, const std::string& from, const std::string& to) {
  for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
}

// A rod 0.12 x 0.1 x 0.1 m (dx 0.01) hits a smooth wall at x = 0 at 20 m/s, J2
// plasticity, updated Lagrangian, alpha 1.2 (the Taylor bar's method in small). The
// quarter y, z >= 0 has mirror planes at y = 0 and z = 0.
std::string rod_text(bool mirror_y, bool mirror_z) {
  std::string text = R"(
dimension = 3
[geometry]
spacing = 0.01
box = { lower = [0.0, LOWER_Y, LOWER_Z], upper = [0.12, 0.05, 0.05] }
[material]
E = 8e7
nu = 0.3
rho = 2000.0
model = "j2"
yield_stress = 1e5
isotropic_hardening = 1e6
[method]
alpha = 1.2
kinematics = "updated_lagrangian"
[time]
end = 1.0e-3
cfl = 0.5
[initial]
velocity = [-20.0, 0.0, 0.0]
[[boundary]]
name = "far end"
type = "free"
region = { type = "half_space", point = [0.12, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }
[[boundary]]
name = "wall"
type = "symmetry"
region = { type = "half_space", point = [0.0, 0.0, 0.0], normal = [-1.0, 0.0, 0.0] }
[[boundary]]
name = "sides"
type = "free"
region = [{ type = "half_space", point = [0.0, 0.05, 0.0], normal = [0.0, 1.0, 0.0] },
          { type = "half_space", point = [0.0, 0.0, 0.05], normal = [0.0, 0.0, 1.0] })";
  replace_all(text, "LOWER_Y", mirror_y ? "0.0" : "-0.05");
  replace_all(text, "LOWER_Z", mirror_z ? "0.0" : "-0.05");
  if (!mirror_y) text += R"(,
          { type = "half_space", point = [0.0, -0.05, 0.0], normal = [0.0, -1.0, 0.0] })";
  if (!mirror_z) text += R"(,
          { type = "half_space", point = [0.0, 0.0, -0.05], normal = [0.0, 0.0, -1.0] })";
  text += "]\n";
  if (mirror_y) text += R"([[boundary]]
name = "mirror y"
type = "mirror"
region = { type = "half_space", point = [0.0, 0.0, 0.0], normal = [0.0, -1.0, 0.0] }
)";
  if (mirror_z) text += R"([[boundary]]
name = "mirror z"
type = "mirror"
region = { type = "half_space", point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, -1.0] }
)";
  return text + R"([output]
times = [1.0e-3]
fields = ["velocity", "stress", "displacement", "plastic"]
)";
}
std::string rod_text(bool quarter) { return rod_text(quarter, quarter); }

/// The last row of a run's energy.csv, by column.
std::map<std::string, double> last_energy_row(const std::string& name) {
  std::ifstream in(fresh_directory_path(name) / "energy.csv");
  std::string header, line, last;
  std::getline(in, header);
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  std::map<std::string, double> row;
  std::stringstream h(header), v(last);
  std::string key, value;
  while (std::getline(h, key, ',') && std::getline(v, value, ',')) row[key] = std::stod(value);
  return row;
}

/// The energies of the modelled part are the whole body's divided by 2 per plane
/// (a particle on a plane counts for its share: energy_ledger.hpp).
void expect_energy_share(const std::string& whole, const std::string& part, double parts) {
  const auto w = last_energy_row(whole), p = last_energy_row(part);
  for (const char* column : {"kinetic", "elastic", "plastic_work", "energy_change", "balance_error"}) {
    SCOPED_TRACE(column);
    ASSERT_TRUE(w.count(column) && p.count(column));
    EXPECT_NEAR(parts * p.at(column), w.at(column), 1e-10 * std::abs(w.at("kinetic")));
  }
  EXPECT_GT(w.at("plastic_work"), 0.01 * w.at("kinetic"));
}

struct Agreement {
  double velocity = 0.0, stress = 0.0, position = 0.0, plastic_strain = 0.0;  // worst, relative to the largest
  double largest_speed = 0.0, largest_stress = 0.0, largest_plastic_strain = 0.0;
};

/// The quarter's particles against the whole body's at the same initial position.
Agreement compare(const LastFrame& whole, const LastFrame& part, double dx) {
  const auto key = [dx](const double* x) {
    return std::array<long, 3>{std::lround(x[0] / dx), std::lround(x[1] / dx), std::lround(x[2] / dx)};
  };
  std::map<std::array<long, 3>, std::size_t> whole_index;
  const auto& whole_x0 = whole.arrays.at("initial_position");
  for (std::size_t i = 0; i < whole.count; ++i) whole_index[key(&whole_x0[3 * i])] = i;
  Agreement a;
  for (double c : whole.arrays.at("velocity")) a.largest_speed = std::max(a.largest_speed, std::abs(c));
  for (double c : whole.arrays.at("stress")) a.largest_stress = std::max(a.largest_stress, std::abs(c));
  for (double c : whole.arrays.at("plastic_strain")) a.largest_plastic_strain = std::max(a.largest_plastic_strain, c);
  const auto& x0 = part.arrays.at("initial_position");
  for (std::size_t i = 0; i < part.count; ++i) {
    const std::size_t j = whole_index.at(key(&x0[3 * i]));
    for (int d = 0; d < 3; ++d) {
      a.velocity = std::max(a.velocity, std::abs(part.arrays.at("velocity")[3 * i + d] - whole.arrays.at("velocity")[3 * j + d]));
      a.position = std::max(a.position, std::abs(part.points[3 * i + d] - whole.points[3 * j + d]));
    }
    for (int c = 0; c < 6; ++c)
      a.stress = std::max(a.stress, std::abs(part.arrays.at("stress")[6 * i + c] - whole.arrays.at("stress")[6 * j + c]));
    a.plastic_strain = std::max(a.plastic_strain, std::abs(part.arrays.at("plastic_strain")[i] -
                                                           whole.arrays.at("plastic_strain")[j]));
  }
  a.velocity /= a.largest_speed;
  a.stress /= a.largest_stress;
  a.position /= dx;
  a.plastic_strain /= a.largest_plastic_strain;
  return a;
}

void expect_round_off(const Agreement& a) {
  std::printf("worst difference: velocity %.2e of %.3g m/s, stress %.2e of %.3g Pa, position %.2e dx, plastic strain %.2e of %.3g\n",
              a.velocity, a.largest_speed, a.stress, a.largest_stress, a.position, a.plastic_strain, a.largest_plastic_strain);
  EXPECT_GT(a.largest_speed, 1.0);
  EXPECT_GT(a.largest_plastic_strain, 1e-3);  // the impact yields
  EXPECT_LT(a.velocity, 1e-10);
  EXPECT_LT(a.stress, 1e-10);
  EXPECT_LT(a.position, 1e-10);
  EXPECT_LT(a.plastic_strain, 1e-10);
}

// The kernel in the current configuration with a Verlet skin (the ghosts made again
// at each search, at the current positions).
// The whole rod moves its Shepard surface rows as the model with planes does
// (SolverSettings::surface_motion: shepard with mirror planes).
const std::vector<std::string> kCurrentKernel{"method.kernel_configuration=\"current\""};
const std::vector<std::string> kShepardSurfaceMotion{"method.surface_motion=\"shepard\"",
                                                     "method.kernel_configuration=\"current\""};

TEST(MirrorPlanes, QuarterRodIsTheWholeRod) {
  const LastFrame whole = run_text(rod_text(false), "rod_whole", kShepardSurfaceMotion);
  const LastFrame quarter = run_text(rod_text(true), "rod_quarter", kCurrentKernel);
  ASSERT_EQ(whole.count, 13u * 11u * 11u);
  ASSERT_EQ(quarter.count, 13u * 6u * 6u);
  const Agreement a = compare(whole, quarter, 0.01);
  expect_round_off(a);
  expect_energy_share("rod_whole", "rod_quarter", 4.0);
}

// The Taylor bar's options: the kernel in the reference configuration, the hourglass
// stiffness (whose fits and values the ghosts take reflected), the adaptive step.
TEST(MirrorPlanes, QuarterRodIsTheWholeRodWithTheTaylorBarsMethod) {
  const std::vector<std::string> method{"method.kernel_configuration=\"reference\"", "method.hourglass_stiffness=0.01",
                                        "time.adaptive=true"};
  const LastFrame whole = run_text(rod_text(false), "rod_whole_reference", method);
  const LastFrame quarter = run_text(rod_text(true), "rod_quarter_reference", method);
  const Agreement a = compare(whole, quarter, 0.01);
  expect_round_off(a);
  expect_energy_share("rod_whole_reference", "rod_quarter_reference", 4.0);
}

// One plane (a half model), the kernel in the current configuration.
TEST(MirrorPlanes, HalfRodIsTheWholeRod) {
  const LastFrame whole = run_text(rod_text(false), "rod_whole_half", kShepardSurfaceMotion);
  const LastFrame half = run_text(rod_text(false, true), "rod_half", kCurrentKernel);
  ASSERT_EQ(half.count, 13u * 11u * 6u);
  expect_round_off(compare(whole, half, 0.01));
  expect_energy_share("rod_whole_half", "rod_half", 2.0);
}

// The quarter with the Taylor bar's method, continued from a checkpoint: the same final
// frame, bit for bit (the ghosts are made again from the owned particles). The whole rod
// too: its restart refused to start before the surface decision was made in the initial
// configuration (boundary/normals.hpp: the flattened impact face was "inside").
void expect_restart_bit_for_bit(bool quarter) {
  SCOPED_TRACE(quarter ? "quarter" : "whole");
  const std::vector<std::string> method{"method.kernel_configuration=\"reference\"", "method.hourglass_stiffness=0.01",
                                        "time.adaptive=true"};
  const std::string tag = quarter ? "_quarter" : "_whole";
  const LastFrame straight = run_text(rod_text(quarter), "restart_straight" + tag, method);
  const LastFrame resumed = testing_cases::resume_from_first_checkpoint(
      rod_text(quarter), method, 25, fresh_directory("restart_checkpoints" + tag),
      fresh_directory("restart_continued" + tag).string());
  ASSERT_FALSE(resumed.points.empty());
  EXPECT_EQ(resumed.points, straight.points);
  for (const char* name : {"velocity", "stress", "plastic_strain", "plastic_work"})
    EXPECT_EQ(resumed.arrays.at(name), straight.arrays.at(name)) << name;
}

TEST(MirrorPlanes, RestartBitForBit) { expect_restart_bit_for_bit(true); }
TEST(MirrorPlanes, WholeRodRestartBitForBit) { expect_restart_bit_for_bit(false); }

void expect_refused(const std::string& text, const std::vector<std::string>& overrides, const std::string& message) {
  try {
    run_text(text, "refused", overrides);
    ADD_FAILURE() << "accepted; expected: " << message;
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
  }
}

TEST(MirrorPlanes, ParticleBeyondThePlaneRefused) {
  std::string text = rod_text(true);
  replace_all(text, "point = [0.0, 0.0, 0.0], normal = [0.0, -1.0, 0.0] }",
              "point = [0.0, 0.025, 0.0], normal = [0.0, -1.0, 0.0] }");
  expect_refused(text, {}, "mirror plane 'mirror y': real particle");
  expect_refused(text, {}, "beyond the plane");
}

TEST(MirrorPlanes, WhatTheGhostsCannotModelRefused) {
  // Half-way between two lattice planes (no particle on it, the face nodes' halved volumes
  // not restored).
  std::string off_lattice = rod_text(true);
  replace_all(off_lattice, "point = [0.0, 0.0, 0.0], normal = [0.0, -1.0, 0.0] }",
              "point = [0.0, -0.005, 0.0], normal = [0.0, -1.0, 0.0] }");
  expect_refused(off_lattice, {}, "holds no real particle");
  // An initial state that is not mirror-symmetric.
  expect_refused(rod_text(true), {"initial.velocity=[-20.0, 1.0, 0.0]"}, "a velocity across it");
  expect_refused(rod_text(true), {"initial.stress=[0, 0, 0, 1e4, 0, 0]"}, "a shear traction on it");
  // Options whose per-boundary-particle state the ghosts do not carry.
  expect_refused(rod_text(true), {"method.deficient_stencils=\"widen\""}, "not available with mirror planes");
  // An elastic rod takes the surface treatments by default: refused with the keys to set,
  // and runs with them set; an option the caller set gets no such hint.
  std::string elastic = rod_text(true);
  replace_all(elastic, "model = \"j2\"\nyield_stress = 1e5\nisotropic_hardening = 1e6\n", "");
  replace_all(elastic, ", \"plastic\"]", "]");
  replace_all(elastic, "times = [1.0e-3]", "times = [1.0e-4]");
  ASSERT_EQ(elastic.find("j2"), std::string::npos);
  expect_refused(elastic, {}, "takes the surface treatments by default: set method.hourglass = 0");
  EXPECT_NO_THROW(run_text(elastic, "elastic_quarter",
                           {"method.hourglass=0", "method.velocity_wall=\"characteristics\"",
                            "method.surface_extrapolation=false", "method.free_edge_uniaxial=false",
                            "time.end=1e-4"}));
  expect_refused(elastic,
                 {"method.hourglass=0", "method.velocity_wall=\"characteristics\"", "method.surface_extrapolation=false"},
                 "by default: set method.hourglass = 0, method.velocity_wall = \"characteristics\" and "
                 "method.surface_extrapolation = false, and in 3D method.free_edge_uniaxial = false");
  try {
    run_text(elastic, "refused",
             {"method.hourglass=0.02", "method.velocity_wall=\"characteristics\"", "method.surface_extrapolation=false"});
    ADD_FAILURE() << "accepted";
  } catch (const std::exception& e) {
    EXPECT_EQ(std::string(e.what()).find("by default"), std::string::npos) << e.what();
  }
}

TEST(MirrorPlanes, PlaneThatIsNotAHalfSpaceRefused) {
  std::string text = rod_text(true);
  replace_all(text, "region = { type = \"half_space\", point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, -1.0] }",
              "region = { type = \"box\", lower = [0.0, 0.0, 0.0], upper = [0.12, 0.05, 0.0] }");
  expect_refused(text, {}, "one half_space region");
}

}  // namespace
