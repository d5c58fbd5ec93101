// Reliability (issue 6): a diverging run is stopped within a few steps with a diagnosis
// (step, time, particle, position, likely cause); a CFL above the stability limit is
// refused unless forced; results are bitwise identical across thread counts and runs in
// 2D and 3D; output files are written whole or not at all.
#include "engine/case/case_run.hpp"
#include "engine/lattice.hpp"
#include "engine/output_file.hpp"
#include "engine/parallel.hpp"
#include "engine/region.hpp"
#include "engine/taylor_sph.hpp"
#include "tests/case_helpers.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>
#include <string>

#include <unistd.h>

namespace tsph {
namespace {

constexpr double kDensity = 2000.0;
constexpr double kYoung = 8e7;
constexpr double kDx = 0.01;

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

/// The step number of a diagnosis "... diverged at step N (t = ...".
long diverged_step(const std::string& message) {
  std::smatch m;
  const std::regex pattern("diverged at step ([0-9]+) \\(t = [0-9.e+-]+ s\\)");
  return std::regex_search(message, m, pattern) ? std::stol(m[1]) : -1;
}

/// The seed's bar (tools/cases/bar.toml) with overrides, run through the case pipeline.
testing_cases::CaseRun seed_bar(const std::vector<std::string>& overrides) {
  return testing_cases::run_case_file(testing_cases::shipped_case("bar.toml"), overrides);
}

/// The first message of loading the bar case with overrides ("" if it is accepted).
std::string bar_error(const std::vector<std::string>& overrides) {
  try {
    load_case(testing_cases::shipped_case("bar.toml"), overrides);
  } catch (const CaseError& e) {
    return e.messages().front();
  }
  return {};
}

TEST(Instability, CflAboveTheLimitIsRefusedUnlessForced) {
  const std::string m = bar_error({"time.cfl=1.5"});
  EXPECT_TRUE(contains(m, "time.cfl = 1.5 is invalid")) << m;
  EXPECT_TRUE(contains(m, "unstable above CFL 1")) << m;
  EXPECT_EQ(bar_error({"time.cfl=1.5", "time.force=true"}), "");
  // forced, but still a number
  EXPECT_TRUE(contains(bar_error({"time.cfl=inf", "time.force=true"}), "time.cfl = inf is invalid"));
  // A fixed time.dt above the limit dx / c_p = 5e-5 s: refused by the builder unless forced.
  std::ifstream in(testing_cases::shipped_case("bar.toml"));
  std::stringstream text;
  text << in.rdbuf();
  std::string bar = text.str();
  const auto cfl = bar.find("cfl = 1.0");
  ASSERT_NE(cfl, std::string::npos);
  bar.replace(cfl, 9, "dt = 6e-5");
  try {
    inspect_case(load_case_text(bar, "bar-dt.toml"));
    ADD_FAILURE() << "dt above the limit accepted";
  } catch (const CaseError& e) {
    EXPECT_TRUE(contains(e.what(), "time.dt = 6e-05 is invalid: exceeds the stability limit")) << e.what();
  }
  EXPECT_NO_THROW(inspect_case(load_case_text(bar, "bar-dt.toml", {"time.force=true"})));
}

// CFL 1.5 amplifies the shortest wave of the bar by |1 - 2 CFL^2| = 3.5 per step (energy
// x12): caught within a few steps of dominating (the speed bound, step 8; the runaway
// criterion at step 11), long before it overflows (about 300 steps), the CFL named as
// the cause.
TEST(Instability, ForcedUnstableCflIsStoppedAsARunawayNamingTheCfl) {
  int frames = 0;
  const CaseFile c = load_case(testing_cases::shipped_case("bar.toml"), {"time.cfl=1.5", "time.force=true"});
  RunOptions options;
  options.out_dir = testing_cases::fresh_output_directory();
  options.quiet = true;
  options.on_frame = [&](const output::VtuFrame&, double t) { frames += t > 0.0; };
  try {
    run_case(c, options);
    FAIL() << "the forced CFL 1.5 run was not stopped";
  } catch (const RunDiverged& e) {
    const std::string m = e.what();
    const long step = diverged_step(m);
    EXPECT_GT(step, 0) << m;
    EXPECT_LE(step, 40) << m;
    EXPECT_TRUE(std::regex_search(m, std::regex("real particle [0-9]+ at \\([0-9.e+-]+\\)"))) << m;
    // Since issue 14 (item 4) the speed bound |v - v_mean| <= c_p stops it first (step 8).
    EXPECT_TRUE(contains(m, "runaway") || contains(m, "unphysical speed")) << m;
    EXPECT_TRUE(contains(m, "likely cause: the time step: CFL = dt c_p / dx = 1.5")) << m;
  }
  EXPECT_EQ(frames, 0);  // diverged before the first output time: nothing but t = 0 written
  std::filesystem::remove_all(options.out_dir);
}

// A slightly unstable CFL (1.05: energy x1.45 per step at the shortest wave) is caught by
// the slower runaway criterion, still before the first output time (step 75).
TEST(Instability, SlightlyUnstableCflIsStoppedBeforeItsFirstOutput) {
  try {
    seed_bar({"time.cfl=1.05", "time.force=true"});
    FAIL() << "the forced CFL 1.05 run was not stopped";
  } catch (const RunDiverged& e) {
    EXPECT_LT(diverged_step(e.what()), 75) << e.what();
    EXPECT_TRUE(contains(e.what(), "CFL = dt c_p / dx = 1.05")) << e.what();
  }
}

// A stable run next to the limit is not stopped: the runaway criterion does not mistake
// the pulse entering the bar (energy growing linearly) for an instability.
TEST(Instability, StableRunsAtTheLimitAreNotStopped) {
  for (double alpha : {0.6, 1.2, 1.6}) {
    EXPECT_NO_THROW(seed_bar({"method.alpha=" + std::to_string(alpha)})) << "alpha " << alpha;
  }
}

// A 2D block (15 x 15, free faces, alpha 1.2, CFL 0.5) with one non-finite stress
// injected at `poisoned`.
TaylorSph<2> poisoned_block(std::size_t poisoned) {
  LatticeBox<2> box;
  box.spacing = kDx;
  box.node_count = {15, 15};
  ParticleSet<2> real = make_real_lattice(box, kDensity);
  auto virtual_particles = make_virtual_lattice(box, kDensity);
  const double tol = 1e-9 * kDx;
  for (int d = 0; d < 2; ++d) {
    assign_boundary(real, Region<2>::half_space("low", Vector<2>::Zero(), Vector<2>(-Vector<2>::Unit(d))), 0, tol);
    assign_boundary(real, Region<2>::half_space("high", Vector<2>::Constant(0.14), Vector<2>::Unit(d)), 0, tol);
  }
  real.stress[2][poisoned] = std::numeric_limits<double>::quiet_NaN();
  SolverSettings<2> settings;
  settings.smoothing_length = 1.2 * kDx;
  return TaylorSph<2>(std::move(real), std::move(virtual_particles),
                      LinearElastic<2>(kYoung, 0.3, kDensity), settings,
                      {BoundaryCondition<2>::free("faces")});
}

double stable_dt() { return 0.5 * kDx / LinearElastic<2>(kYoung, 0.3, kDensity).p_wave_speed(kDensity); }

// NaN inside the body, far from the faces, at a stable CFL: stopped in the first step,
// the particle named with its position, alpha (or the kinematics) as the likely cause,
// and no particle moved.
TEST(Instability, NonFiniteStateInsideTheBodyIsStoppedInTheFirstStep) {
  TaylorSph<2> solver = poisoned_block(7 * 15 + 7);
  try {
    solver.step(stable_dt());
    FAIL() << "a NaN stress went through a step unnoticed";
  } catch (const SolutionDiverged& e) {
    const std::string m = e.what();
    EXPECT_EQ(diverged_step(m), 1) << m;
    EXPECT_TRUE(std::regex_search(m, std::regex("real particle [0-9]+ at \\([0-9.e+-]+, [0-9.e+-]+\\) "
                                                "has a non-finite (velocity|stress)"))) << m;
    EXPECT_TRUE(contains(m, "likely cause: alpha = h / dx = 1.2")) << m;
  }
  EXPECT_EQ(solver.counters().steps, 0);
  EXPECT_EQ(solver.time(), 0.0);
}

// NaN at a corner particle (on the free faces): the boundary condition is named. The
// monitor names the first particle with a non-finite stress (it spreads a stencil a step,
// the velocity further): the corner's own stress is the free corner's zero after the
// step, so it names the corner's neighbour on the face.
TEST(Instability, NonFiniteStateAtABoundaryNamesTheBoundaryCondition) {
  TaylorSph<2> solver = poisoned_block(0);
  try {
    solver.step(stable_dt());
    FAIL() << "a NaN stress went through a step unnoticed";
  } catch (const SolutionDiverged& e) {
    EXPECT_TRUE(contains(e.what(), "real particle 1 at (0.01, 0)")) << e.what();
    EXPECT_TRUE(contains(e.what(), "likely cause: the boundary condition 'faces'")) << e.what();
  }
}

// Determinism: the same 3D case gives bitwise identical results with 1 and 2 threads and
// from run to run (2D and 1D: test_taylor_sph_nd, test_bar). A 7^3 block with free
// faces, a smooth initial velocity, updated-Lagrangian kinematics (particles move, the
// neighbour lists are rebuilt every step), 40 steps.
template <int Dim>
ParticleSet<Dim> run_block(int threads, Kinematics kinematics) {
  const int before = thread_count();
  set_thread_count(threads);
  LatticeBox<Dim> box;
  box.spacing = kDx;
  for (int d = 0; d < Dim; ++d) box.node_count[d] = Dim == 3 ? 7 : 13;
  ParticleSet<Dim> real = make_real_lattice(box, kDensity);
  auto virtual_particles = make_virtual_lattice(box, kDensity);
  const double tol = 1e-9 * kDx;
  const double upper = static_cast<double>(box.node_count[0] - 1) * kDx;
  for (int d = 0; d < Dim; ++d) {
    assign_boundary(real, Region<Dim>::half_space("low", Vector<Dim>::Zero(), Vector<Dim>(-Vector<Dim>::Unit(d))), 0, tol);
    assign_boundary(real, Region<Dim>::half_space("high", Vector<Dim>::Constant(upper), Vector<Dim>::Unit(d)), 0, tol);
  }
  for (std::size_t i = 0; i < real.size(); ++i)
    for (int d = 0; d < Dim; ++d)
      real.velocity[d][i] = 0.01 * std::sin(50.0 * real.position[(d + 1) % Dim][i] + d);
  SolverSettings<Dim> settings;
  settings.smoothing_length = 1.2 * kDx;
  settings.kinematics = kinematics;
  settings.hourglass_coefficient = 0.02;
  const LinearElastic<Dim> material(kYoung, 0.3, kDensity);
  TaylorSph<Dim> solver(std::move(real), std::move(virtual_particles), material, settings,
                        {BoundaryCondition<Dim>::free("faces")});
  const double dt = 0.8 * kDx / material.p_wave_speed(kDensity);
  for (int k = 0; k < 40; ++k) solver.step(dt);
  set_thread_count(before);
  return solver.real();
}

template <int Dim>
void expect_bitwise_equal(const ParticleSet<Dim>& a, const ParticleSet<Dim>& b) {
  for (int d = 0; d < Dim; ++d) {
    EXPECT_EQ(a.position[d], b.position[d]);
    EXPECT_EQ(a.velocity[d], b.velocity[d]);
  }
  for (int m = 0; m < stress_component_count<Dim>; ++m) EXPECT_EQ(a.stress[m], b.stress[m]);
  EXPECT_EQ(a.density, b.density);
}

TEST(Determinism, ThreeDimensionalRunIsBitwiseIdenticalWithOneAndTwoThreads) {
  const auto one = run_block<3>(1, Kinematics::updated_lagrangian);
  const auto two = run_block<3>(2, Kinematics::updated_lagrangian);
  expect_bitwise_equal(one, two);
  double speed = 0.0;  // the run did something
  for (std::size_t i = 0; i < two.size(); ++i) speed = std::max(speed, std::abs(two.velocity[0][i]));
  EXPECT_GT(speed, 1e-3);
}

TEST(Determinism, RunsRepeatBitwiseIn2DAnd3D) {
  expect_bitwise_equal(run_block<2>(2, Kinematics::updated_lagrangian),
                       run_block<2>(2, Kinematics::updated_lagrangian));
  expect_bitwise_equal(run_block<3>(2, Kinematics::small_strain),
                       run_block<3>(2, Kinematics::small_strain));
}

// Output files: written whole, or not at all with the previous content kept.
class OutputFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("tsph_output_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  static std::string read(const std::filesystem::path& p) {
    std::ifstream in(p);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  }
  std::filesystem::path dir_;
};

TEST_F(OutputFileTest, WritesAndReplacesWholeFiles) {
  const auto file = dir_ / "summary.json";
  write_file_atomically(file, "first\n");
  write_file_atomically(file, "second\n");
  EXPECT_EQ(read(file), "second\n");
  EXPECT_FALSE(std::filesystem::exists(dir_ / "summary.json.partial"));
}

// A full disk, injected with /dev/full (every write fails with ENOSPC): the error names
// the file and the reason, the previous file is intact, no partial file is left.
TEST_F(OutputFileTest, FullDiskKeepsThePreviousFileAndNamesTheFile) {
  if (!std::filesystem::exists("/dev/full")) GTEST_SKIP() << "no /dev/full on this system";
  const auto file = dir_ / "profile.csv";
  write_file_atomically(file, "previous run\n");
  std::filesystem::create_symlink("/dev/full", dir_ / "profile.csv.partial");
  try {
    write_file_atomically(file, std::string(100000, 'x'));
    FAIL() << "a write to a full disk was not reported";
  } catch (const OutputError& e) {
    EXPECT_TRUE(contains(e.what(), file.string())) << e.what();
    EXPECT_TRUE(contains(e.what(), "No space left on device")) << e.what();
  }
  EXPECT_EQ(read(file), "previous run\n");
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::symlink_status(dir_ / "profile.csv.partial")));
}

TEST_F(OutputFileTest, MissingDirectoryIsReported) {
  EXPECT_THROW(write_file_atomically(dir_ / "no_such_dir" / "a.csv", "x"), OutputError);
}

}  // namespace
}  // namespace tsph
