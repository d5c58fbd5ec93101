// Case files: every shipped case is accepted; each class of bad input is refused with
// a message naming the file, line, key, value and the fix; overrides work; the bar and
// cantilever cases through the one builder equal solvers built by hand (the same
// physics through the generic path).
#include "engine/boundary_condition.hpp"
#include "engine/region.hpp"
#include "engine/validation/bar.hpp"
#include "engine/validation/cantilever.hpp"
#include "engine/case/case_file.hpp"
#include "engine/case/case_run.hpp"
#include "engine/case/restart_check.hpp"
#include "engine/case/case_build.hpp"
#include "engine/lattice.hpp"
#include "engine/output/checkpoint.hpp"
#include "engine/output/progress.hpp"
#include "engine/parallel.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <type_traits>

namespace {

namespace fs = std::filesystem;
using namespace tsph;

const fs::path kCases = fs::path(TSPH_SOURCE_DIR) / "tools" / "cases";

class CaseFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    directory_ = fs::temp_directory_path() /
                 ("tsph_case_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
                  ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(directory_);
    fs::create_directories(directory_);
  }
  void TearDown() override { fs::remove_all(directory_); }

  std::string write(const std::string& name, const std::string& text) {
    const fs::path p = directory_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  /// The message of the CaseError that loading `text` throws ("" if none).
  std::string error_of(const std::string& text, const std::vector<std::string>& overrides = {}) {
    const std::string path = write("case.toml", text);
    try {
      load_case(path, overrides);
    } catch (const CaseError& e) {
      return e.what();
    }
    return "";
  }
  fs::path directory_;
};

const std::string kValid2d = R"(dimension = 2
[geometry]
spacing = 0.1
box = { lower = [0.0, 0.0], upper = [1.0, 0.4] }
[material]
E = 1e6
nu = 0.25
rho = 1000.0
[method]
alpha = 0.6
[time]
end = 1e-3
cfl = 0.5
[[boundary]]
name = "left"
type = "fixed"
region = { type = "half_space", point = [0.0, 0.0], normal = [-1.0, 0.0] }
)";

TEST_F(CaseFileTest, EveryShippedCaseIsAcceptedAndBuilds) {
  int count = 0;
  for (const auto& entry : fs::directory_iterator(kCases)) {
    if (entry.path().extension() != ".toml") continue;
    ++count;
    SCOPED_TRACE(entry.path().string());
    const CaseFile c = load_case(entry.path().string());
    const CaseOverview o = inspect_case(c);
    EXPECT_GT(o.real_particles, 0u);
    EXPECT_GT(o.virtual_particles, 0u);
    EXPECT_GT(o.steps, 0);
    for (const auto& [name, n] : o.boundary_particles) EXPECT_GT(n, 0u) << name;
  }
  EXPECT_GE(count, 3);
}

TEST_F(CaseFileTest, ShippedCasesResolveToTheSeedSettings) {
  const CaseFile bar = load_case((kCases / "bar.toml").string());
  const CaseOverview b = inspect_case(bar);
  EXPECT_EQ(b.real_particles, 101u);
  EXPECT_EQ(b.virtual_particles, 100u);
  EXPECT_DOUBLE_EQ(b.wave_speed, 200.0);
  EXPECT_DOUBLE_EQ(b.dt, 5e-5);
  EXPECT_EQ(b.steps, 150);
  const CaseFile beam = load_case((kCases / "cantilever_2d.toml").string());
  const CaseOverview c = inspect_case(beam);
  EXPECT_EQ(c.real_particles, 101u * 11u);
  EXPECT_EQ(c.virtual_particles, 100u * 10u);
  ASSERT_EQ(c.boundary_particles.size(), 3u);
  EXPECT_EQ(c.boundary_particles[2].second, 11u);  // the clamp: the whole face x = 0
  EXPECT_EQ(c.boundary_particles[1].second, 11u);  // the tip face, corners included
  EXPECT_EQ(c.boundary_particles[0].second, 198u); // top and bottom, less the four corners
  // The 3D case leaves the converged options, the free edges among them, to the defaults.
  const CaseFile solid = load_case((kCases / "cantilever_3d.toml").string());
  EXPECT_EQ(solid.velocity_wall, CaseFile::VelocityWall::automatic);
  EXPECT_EQ(solid.hourglass_stiffness, kAutomaticOption);
  EXPECT_EQ(solid.surface_extrapolation, Toggle::automatic);
  EXPECT_EQ(solid.free_edge_uniaxial, Toggle::automatic);
}

// [solver]: neighbor_search "auto" by default, the two searches by name, anything else
// refused with the key, the value and the choices; transpose_lists off by default.
TEST_F(CaseFileTest, SolverKeysAreReadAndValidated) {
  EXPECT_EQ(load_case(write("default.toml", kValid2d)).neighbor_search, NeighborSearch::automatic);
  for (const char* name : {"auto", "cell_list", "kd_tree"}) {
    const CaseFile c = load_case(write("search.toml", kValid2d + "[solver]\nneighbor_search = \"" + name + "\"\n"));
    EXPECT_EQ(c.neighbor_search, parse_neighbor_search(name));
    EXPECT_EQ(to_string(c.neighbor_search), name);
  }
  EXPECT_FALSE(load_case(write("default.toml", kValid2d)).transpose_lists);
  EXPECT_TRUE(load_case(write("t.toml", kValid2d + "[solver]\ntranspose_lists = true\n")).transpose_lists);
  EXPECT_EQ(load_case(write("default.toml", kValid2d)).neighbor_skin, 0.05);  // SolverSettings' default
  EXPECT_EQ(load_case(write("s0.toml", kValid2d + "[solver]\nneighbor_skin = 0\n")).neighbor_skin, 0.0);
  EXPECT_EQ(load_case(write("s.toml", kValid2d + "[solver]\nneighbor_skin = 0.1\n")).neighbor_skin, 0.1);
  const std::string bad_skin = error_of(kValid2d + "[solver]\nneighbor_skin = 1.5\n");
  EXPECT_NE(bad_skin.find("solver.neighbor_skin = 1.5 is invalid: must lie in [0, 1]"), std::string::npos)
      << bad_skin;
  const std::string bad = error_of(kValid2d + "[solver]\nneighbor_search = \"octree\"\n");
  EXPECT_NE(bad.find("solver.neighbor_search = 'octree' is invalid: must be one of: auto, cell_list, kd_tree"),
            std::string::npos)
      << bad;
}

TEST_F(CaseFileTest, OverridesReplaceScalarsAndAreValidated) {
  const std::string path = (kCases / "cantilever_2d.toml").string();
  const CaseFile c = load_case(path, {"material.E=2e8", "material.plane=strain", "method.kernel=\"wendland_c2\""});
  EXPECT_DOUBLE_EQ(c.young_modulus, 2e8);
  EXPECT_EQ(c.plane_mode, PlaneMode::plane_strain);
  EXPECT_EQ(c.kernel, KernelKind::wendland_c2);
  const CaseFile d = load_case(path, {"boundary.1.value=[0.0, 500.0]"});
  EXPECT_DOUBLE_EQ(d.boundaries[1].value[1], 500.0);
  auto message = [&](const std::string& o) {
    try {
      load_case(path, {o});
    } catch (const CaseError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message("material.E=-1").find("material.E = -1 is invalid: must be positive"), std::string::npos)
      << message("material.E=-1");
  EXPECT_NE(message("material.Young=1").find("unknown key material.Young: did you mean material.E?"),
            std::string::npos)
      << message("material.Young=1");
  EXPECT_NE(message("material=3").find("names a table"), std::string::npos);
  EXPECT_NE(message("nokey").find("write --set key=value"), std::string::npos);
  EXPECT_NE(message("boundary.9.value=[0.0, 1.0]").find("not an index"), std::string::npos);
}

TEST_F(CaseFileTest, SyntaxErrorNamesFileLineAndColumn) {
  const std::string e = error_of("dimension = 2\n[geometry\nspacing = 0.1\n");
  EXPECT_TRUE(std::regex_search(e, std::regex("case\\.toml:2:[0-9]+: TOML syntax error"))) << e;
}

TEST_F(CaseFileTest, UnknownKeySuggestsTheNearest) {
  std::string text = kValid2d;
  text.replace(text.find("alpha = 0.6"), 11, "alpah = 0.6");
  const std::string e = error_of(text);
  EXPECT_TRUE(std::regex_search(e, std::regex("case\\.toml:10:1: unknown key method\\.alpah: did you mean method\\.alpha\\?")))
      << e;
  EXPECT_NE(e.find("missing required key method.alpha"), std::string::npos) << e;
}

TEST_F(CaseFileTest, WrongTypeOutOfRangeAndMissingKeys) {
  auto replaced = [](std::string text, const std::string& from, const std::string& to) {
    text.replace(text.find(from), from.size(), to);
    return text;
  };
  std::string e = error_of(replaced(kValid2d, "E = 1e6", "E = \"stiff\""));
  EXPECT_TRUE(std::regex_search(e, std::regex("case\\.toml:6:5: material\\.E = 'stiff' is invalid: must be a number"))) << e;
  e = error_of(replaced(kValid2d, "cfl = 0.5", "cfl = 1.5"));
  EXPECT_NE(e.find("time.cfl = 1.5 is invalid: must lie in (0, 1]"), std::string::npos) << e;
  e = error_of(replaced(kValid2d, "nu = 0.25", "nu = 0.5"));
  EXPECT_NE(e.find("material.nu = 0.5 is invalid: must lie in (-1, 0.5)"), std::string::npos) << e;
  e = error_of(replaced(kValid2d, "rho = 1000.0\n", ""));
  EXPECT_NE(e.find("missing required key material.rho in [material]: add e.g. rho = 2000"), std::string::npos) << e;
  e = error_of(replaced(kValid2d, "upper = [1.0, 0.4]", "upper = [1.0]"));
  EXPECT_NE(e.find("geometry.box.upper = [ 1.0 ] is invalid: must have 2 components"), std::string::npos) << e;
  e = error_of(replaced(kValid2d, "upper = [1.0, 0.4]", "upper = [1.0, 0.45]"));
  EXPECT_NE(e.find("whole number"), std::string::npos) << e;
  e = error_of(replaced(kValid2d, "type = \"fixed\"", "type = \"fixd\""));
  EXPECT_NE(e.find("boundary[0].type = 'fixd' is invalid: must be one of: fixed, free, velocity, traction, symmetry, mirror (did you mean 'fixed'?)"),
            std::string::npos) << e;
  e = error_of(replaced(kValid2d, "dimension = 2", "dimension = 4"));
  EXPECT_NE(e.find("dimension = 4 is invalid: must be 1, 2 or 3"), std::string::npos) << e;
  e = error_of(replaced(kValid2d, "cfl = 0.5", "cfl = 0.5\ndt = 1e-6"));
  EXPECT_NE(e.find("keep one of them"), std::string::npos) << e;
  e = error_of(replaced(kValid2d, "alpha = 0.6", "alpha = 0.6\nkinematics = 3"));
  EXPECT_NE(e.find("method.kinematics = 3 is invalid: must be one of (in quotes): small_strain"), std::string::npos) << e;
  e = error_of(replaced(kValid2d, "alpha = 0.6", "alpha = 0.6\nvelocity_wall = \"wall\""));
  EXPECT_NE(e.find("method.velocity_wall = 'wall' is invalid: must be one of: automatic, characteristics, wall_gradient"),
            std::string::npos) << e;
  e = error_of(replaced(kValid2d, "alpha = 0.6", "alpha = 0.6\nfree_edge_uniaxial = true"));
  EXPECT_NE(e.find("method.free_edge_uniaxial = true is invalid: applies to dimension = 3 only"), std::string::npos) << e;
  e = error_of(replaced(kValid2d, "alpha = 0.6", "alpha = 0.6\nhourglass_stiffness = -0.1"));
  EXPECT_NE(e.find("method.hourglass_stiffness = -0.1 is invalid: must lie in [0, 1]"), std::string::npos) << e;
}

// A box list is the union of its boxes on one lattice: two halves give the particles
// of the whole box; an L gives its area; boxes off the common lattice are refused.
TEST_F(CaseFileTest, BoxListsAreUnionsOnOneLattice) {
  auto with_boxes = [&](const std::string& boxes) {
    std::string text = kValid2d;
    const std::string box = "box = { lower = [0.0, 0.0], upper = [1.0, 0.4] }";
    text.replace(text.find(box), box.size(), "box = [" + boxes + "]");
    return write("boxes.toml", text);
  };
  const CaseOverview whole = inspect_case(load_case(write("one.toml", kValid2d)));
  EXPECT_EQ(whole.real_particles, 11u * 5u);
  EXPECT_NEAR(whole.real_volume, 0.4, 1e-12);
  const CaseOverview halves = inspect_case(load_case(with_boxes(
      "{ lower = [0.0, 0.0], upper = [0.5, 0.4] }, { lower = [0.5, 0.0], upper = [1.0, 0.4] }")));
  EXPECT_EQ(halves.real_particles, whole.real_particles);
  EXPECT_EQ(halves.virtual_particles, whole.virtual_particles);
  EXPECT_NEAR(halves.real_volume, whole.real_volume, 1e-12);
  // An L: [0, 1] x [0, 0.4] and [0, 0.4] x [0.4, 1.0] (overlapping rows counted once).
  const CaseOverview l_shape = inspect_case(load_case(with_boxes(
      "{ lower = [0.0, 0.0], upper = [1.0, 0.4] }, { lower = [0.0, 0.3], upper = [0.4, 1.0] }")));
  EXPECT_EQ(l_shape.real_particles, 11u * 5u + 5u * 6u);
  EXPECT_EQ(l_shape.virtual_particles, 10u * 4u + 4u * 6u);
  EXPECT_NEAR(l_shape.real_volume, 0.4 + 0.4 * 0.6, 1e-12);
  const std::string e = error_of(
      R"(dimension = 2
[geometry]
spacing = 0.1
box = [{ lower = [0.0, 0.0], upper = [1.0, 0.4] }, { lower = [0.05, 0.4], upper = [0.45, 0.8] }]
[material]
E = 1e6
nu = 0.25
rho = 1000.0
[method]
alpha = 0.6
[time]
end = 1e-3
cfl = 0.5
)");
  EXPECT_NE(e.find("geometry.box[1].lower is invalid: the boxes must share one lattice"), std::string::npos) << e;
}

TEST_F(CaseFileTest, RegionSelectingNothingIsRefusedWhenBuilding) {
  std::string text = kValid2d;
  const std::string plane = "point = [0.0, 0.0], normal = [-1.0, 0.0]";
  text.replace(text.find(plane), plane.size(), "point = [-1.0, 0.0], normal = [-1.0, 0.0]");
  const CaseFile c = load_case(write("case.toml", text));
  try {
    inspect_case(c);
    FAIL() << "no error";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("boundary[0] 'left': region 'left' selects no particle"), std::string::npos)
        << e.what();
  }
}

TEST_F(CaseFileTest, MissingAndMalformedParticleFiles) {
  std::string text = kValid2d;
  const std::string box = "box = { lower = [0.0, 0.0], upper = [1.0, 0.4] }";
  text.replace(text.find(box), box.size(), "particle_file = \"beam.csv\"");
  const std::string path = write("case.toml", text);
  {
    const CaseFile c = load_case(path);
    try {
      inspect_case(c);
      FAIL() << "no error";
    } catch (const CaseError& e) {
      EXPECT_NE(std::string(e.what()).find("particle file '" + (directory_ / "beam.csv").string() + "' cannot be opened"),
                std::string::npos)
          << e.what();
    }
  }
  write("beam.csv", "x,y\n0,0\n0.1,0\n0.1,zero\n");
  const CaseFile c = load_case(path);
  try {
    inspect_case(c);
    FAIL() << "no error";
  } catch (const CaseError& e) {
    EXPECT_TRUE(std::regex_search(std::string(e.what()), std::regex("beam\\.csv.*line 4"))) << e.what();
  }
  // Both a box and a file: refused at load.
  std::string both = kValid2d;
  both.replace(both.find("[material]"), 10, "particle_file = \"beam.csv\"\n[material]");
  EXPECT_NE(error_of(both).find("exactly one of"), std::string::npos) << error_of(both);
}

TEST_F(CaseFileTest, MissingCaseFile) {
  try {
    load_case((directory_ / "none.toml").string());
    FAIL() << "no error";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("none.toml: case file cannot be read (no such file)"), std::string::npos);
  }
}

TEST(EditDistance, CountsInsertionsDeletionsSubstitutions) {
  EXPECT_EQ(edit_distance("alpha", "alpha"), 0u);
  EXPECT_EQ(edit_distance("alpah", "alpha"), 2u);
  EXPECT_EQ(edit_distance("E", "e"), 0u);
  EXPECT_EQ(edit_distance("", "rho"), 3u);
  EXPECT_EQ(edit_distance("kitten", "sitting"), 3u);
}

// The bar case file runs the same physics as the bar built by hand (101 lattice
// particles, the left end fixed, the velocity pulse at the right end, CFL 1 on the
// output times): the same profiles bitwise, and errors at round-off (docs/validation.md, Table 1).
TEST_F(CaseFileTest, BarCaseFileEqualsTheBarBuiltByHand) {
  const CaseFile c = load_case((kCases / "bar.toml").string());
  RunOptions options;
  options.out_dir = directory_.string();
  options.quiet = true;
  std::vector<std::vector<double>> velocities;
  options.on_frame = [&](const output::VtuFrame& f, double) {
    for (const auto& a : f.arrays)
      if (a.name == "velocity") {
        velocities.emplace_back();
        for (std::size_t i = 0; i < f.point_count; ++i) velocities.back().push_back(a.float64[3 * i]);
      }
  };
  set_thread_count(1);  // 101 particles: one thread is fastest on a busy machine
  const RunReport r = run_case(c, options);

  LatticeBox<1> box;
  box.node_count = {101};
  box.spacing = 1.0 / 100.0;
  ParticleSet<1> real = make_real_lattice(box, 2000.0);
  ParticleSet<1> virtual_particles = make_virtual_lattice(box, 2000.0);
  real.boundary.front() = 0;
  real.boundary.back() = 1;
  SolverSettings<1> settings;
  settings.smoothing_length = 0.6 * box.spacing;
  TaylorSph<1> solver(std::move(real), std::move(virtual_particles), LinearElastic<1>(8e7, 0.0, 2000.0), settings,
                      {BoundaryCondition<1>::fixed("left"),
                       BoundaryCondition<1>::velocity({TimeFunction::rectangular_pulse(1.0, 0.0, 2.5e-3)}, "right")});
  const double dt = box.spacing / 200.0;
  const BarExactSolution exact(1.0, 8e7, 2000.0, 1.0, 2.5e-3, true);
  ASSERT_EQ(velocities.size(), 3u);  // t = 0, 3.75 ms, 7.5 ms
  std::size_t frame = 1;
  std::int64_t steps = 0;
  for (double target : {3.75e-3, 7.5e-3}) {
    while (solver.time() < target - 1e-9 * dt) {
      const double remaining = target - solver.time();
      const bool lands = remaining <= dt * (1.0 + 1e-9);
      solver.step(lands ? remaining : dt);
      if (lands) solver.set_time(target);
      ++steps;
    }
    EXPECT_EQ(velocities[frame], solver.real().velocity[0]) << "t = " << target;
    std::vector<double> v_exact;
    for (double x : solver.real().initial_position[0]) v_exact.push_back(exact.velocity(x, target));
    double error = std::nan("");
    for (const auto& e : r.errors)
      if (e.name == "velocity_x_l2_percent" && e.time == target) error = e.value;
    EXPECT_EQ(error, relative_l2_percent(solver.real().velocity[0], v_exact));
    EXPECT_LT(error, 1e-9);  // alpha 0.6, CFL 1: exact (docs/validation.md, Table 1)
    ++frame;
  }
  EXPECT_EQ(r.steps, steps);
  EXPECT_EQ(r.frames, 3u);
  EXPECT_TRUE(fs::exists(directory_ / "particles.pvd"));
  EXPECT_TRUE(fs::exists(directory_ / "particles_000002.vtu"));
  EXPECT_TRUE(fs::exists(directory_ / "summary.json"));
  EXPECT_TRUE(fs::exists(directory_ / "probe_middle.csv"));
}

// The 2D cantilever case file against the beam built by hand (the lattice, the free
// faces, the parabolic tip shear of seed eq. 6 under a ramp over T1, the clamp; damping
// 2 omega_1, the hourglass filter), over the first 233 steps at CFL 0.9 (the last step
// of the case lands on time.end, so the time differs by round-off: equal to 1e-9, not
// bitwise). The case file holds the converged 2D options (method.velocity_wall =
// "wall_gradient", method.hourglass_stiffness = 0.05, method.surface_extrapolation =
// true); with the three set back (characteristics, 0, false) it runs the former ones.
class CantileverCaseFile : public CaseFileTest, public ::testing::WithParamInterface<bool> {};

TEST_P(CantileverCaseFile, EqualsTheBeamBuiltByHand) {
  const bool wall_gradient = GetParam();
  set_thread_count(1);
  CantileverBeam<2> beam;  // seed 4.2: 1 m x 0.1 m, plane stress, P = 1000 N
  beam.load = 1000.0;
  const double dx = 0.01, omega = beam.first_mode_frequency(), period = 2.0 * M_PI / omega;
  const LinearElastic<2> material(beam.young_modulus, beam.poisson_ratio, beam.density, PlaneMode::plane_stress);
  const double dt = 0.9 * dx / material.p_wave_speed(beam.density);

  LatticeBox<2> box;
  box.spacing = dx;
  box.lower = Vector<2>(0.0, -0.05);
  box.node_count = {101, 11};
  ParticleSet<2> real = make_real_lattice(box, beam.density);
  ParticleSet<2> virtual_particles = make_virtual_lattice(box, beam.density);
  auto tip_components = BoundaryCondition<2>::filled(TimeFunction::constant(0.0));
  tip_components[1] = TimeFunction::linear_ramp(1.0, 0.0, period);
  std::vector<BoundaryCondition<2>> conditions{
      BoundaryCondition<2>::free("free surface"),
      BoundaryCondition<2>::traction(tip_components, "tip shear",
                                     [beam](const Vector<2>& x) { return Vector<2>(0.0, beam.tip_shear(x[1])); }),
      BoundaryCondition<2>::fixed("clamp")};
  const double tol = 1e-6 * dx;
  assign_boundary(real, Region<2>::half_space("top", Vector<2>(1.0, 0.05), Vector<2>(0.0, 1.0)), 0, tol);
  assign_boundary(real, Region<2>::half_space("bottom", Vector<2>(0.0, -0.05), Vector<2>(0.0, -1.0)), 0, tol);
  assign_boundary(real, Region<2>::half_space("tip", Vector<2>(1.0, 0.0), Vector<2>(1.0, 0.0)), 1, tol);
  assign_boundary(real, Region<2>::half_space("clamp", Vector<2>(0.0, 0.0), Vector<2>(-1.0, 0.0)), 2, tol);
  SolverSettings<2> settings;
  settings.smoothing_length = 0.6 * dx;
  settings.damping = 2.0 * omega;
  settings.hourglass_coefficient = 0.02;
  if (wall_gradient) {
    settings.hourglass_stiffness = 0.05;
    settings.velocity_wall = SolverSettings<2>::VelocityWall::wall_gradient;
    settings.surface_extrapolation = Toggle::on;
  } else {
    settings.hourglass_stiffness = 0.0;
    settings.velocity_wall = SolverSettings<2>::VelocityWall::characteristics;
    settings.surface_extrapolation = Toggle::off;
  }
  TaylorSph<2> reference(std::move(real), std::move(virtual_particles), material, settings, conditions);
  for (int k = 0; k < 233; ++k) reference.step(dt);
  std::size_t tip = 0;
  for (std::size_t i = 0; i < reference.real().size(); ++i)
    if (std::abs(reference.real().initial_position[0][i] - 1.0) < tol &&
        std::abs(reference.real().initial_position[1][i]) < tol)
      tip = i;
  const double reference_tip = reference.real().displacement[1][tip];

  char end[64];
  std::snprintf(end, sizeof end, "time.end=%.17g", 233 * dt);
  std::vector<std::string> overrides{end, "damping.rest_velocity=0"};
  if (!wall_gradient) {
    overrides.emplace_back("method.velocity_wall=characteristics");
    overrides.emplace_back("method.hourglass_stiffness=0");
    overrides.emplace_back("method.surface_extrapolation=false");
  }
  const CaseFile c = load_case((kCases / "cantilever_2d.toml").string(), overrides);
  EXPECT_EQ(c.velocity_wall, wall_gradient ? CaseFile::VelocityWall::automatic : CaseFile::VelocityWall::characteristics);
  EXPECT_EQ(c.hourglass_stiffness, wall_gradient ? kAutomaticOption : 0.0);
  EXPECT_EQ(c.surface_extrapolation, wall_gradient ? Toggle::automatic : Toggle::off);
  RunOptions options;
  options.out_dir = directory_.string();
  options.quiet = true;
  const RunReport r = run_case(c, options);
  EXPECT_EQ(r.steps, 233);
  double tip_case = std::nan("");
  for (const auto& e : r.errors)
    if (e.name == "tip_displacement_y" && e.time == r.time) tip_case = e.value;
  ASSERT_GT(std::abs(reference_tip), 1e-9);  // the load has moved the tip
  EXPECT_NEAR(tip_case, reference_tip, 1e-9 * std::abs(reference_tip));
}
INSTANTIATE_TEST_SUITE_P(Clamp, CantileverCaseFile, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& clamp) { return clamp.param ? "WallGradient" : "Characteristics"; });

// The named initial profile: a free-free bar started in its fundamental mode,
// v = A cos(pi x / L) (sine with wavelength 2L, phase pi/2), is back to its initial
// velocity after one period 2L/c (CFL 1, alpha 0.6: the scheme shifts exactly).
TEST_F(CaseFileTest, SineInitialProfileGivesTheFreeBarsFundamentalMode) {
  const std::string path = write("mode.toml", R"(dimension = 1
[geometry]
spacing = 0.01
box = { lower = [0.0], upper = [1.0] }
[material]
E = 8e7
rho = 2000.0
[method]
alpha = 0.6
[time]
end = 0.01
cfl = 1.0
[[boundary]]
name = "ends"
type = "free"
region = [{ type = "half_space", point = [0.0], normal = [-1.0] },
          { type = "half_space", point = [1.0], normal = [1.0] }]
[initial.profile]
type = "sine"
amplitude = [0.5]
direction = [1.0]
wavelength = 2.0
phase = 1.5707963267948966
[output]
probe_every = 50
[[output.probe]]
name = "end"
point = [0.0]
[[output.probe]]
name = "quarter"
point = [0.25]
)");
  RunOptions options;
  options.out_dir = directory_.string();
  options.quiet = true;
  set_thread_count(1);
  const RunReport r = run_case(load_case(path), options);
  EXPECT_EQ(r.steps, 200);
  auto velocity_rows = [&](const std::string& probe) {
    std::ifstream in(directory_ / ("probe_" + probe + ".csv"));
    std::string line;
    std::getline(in, line);  // header: t,x0_x,ux,vx,...
    std::vector<std::pair<double, double>> rows;
    while (std::getline(in, line)) {
      std::vector<double> v;
      std::stringstream fields(line);
      for (std::string f; std::getline(fields, f, ',');) v.push_back(std::stod(f));
      rows.emplace_back(v[0], v[3]);
    }
    return rows;
  };
  const auto end = velocity_rows("end"), quarter = velocity_rows("quarter");
  ASSERT_EQ(end.size(), 5u);  // t = 0, T/4, T/2, 3T/4, T
  EXPECT_NEAR(end.front().second, 0.5, 1e-10);  // the CSV holds 11 digits
  EXPECT_NEAR(quarter.front().second, 0.5 * std::cos(M_PI * 0.25), 1e-10);
  EXPECT_NEAR(end[2].second, -0.5, 1e-9);  // half a period: reversed
  EXPECT_NEAR(end.back().second, 0.5, 1e-9);
  EXPECT_NEAR(quarter.back().second, 0.5 * std::cos(M_PI * 0.25), 1e-9);
  EXPECT_NEAR(end[1].second, 0.0, 1e-9);   // a quarter period: all strain, no velocity
}

TEST(ProgressLine, ShowsStepTimePercentEtaAndRate) {
  // Half way after 10 s: 10 s left; 100 particles x 50 steps / 10 s = 500 particle-steps/s.
  const std::string line = output::ProgressLine::format(50, 0.5, 1.0, 10.0, 100);
  EXPECT_NE(line.find("step       50"), std::string::npos) << line;
  EXPECT_NE(line.find("t = 5.000000e-01 s"), std::string::npos) << line;
  EXPECT_NE(line.find(" 50.0 %"), std::string::npos) << line;
  EXPECT_NE(line.find("ETA     10 s"), std::string::npos) << line;
  EXPECT_NE(line.find("5.000e+02 particle-steps/s"), std::string::npos) << line;
  // 1 % after 72 s: 7128 s left.
  EXPECT_NE(output::ProgressLine::format(1, 0.01, 1.0, 72.0, 1).find("ETA    2.0 h"), std::string::npos);
}

TEST_F(CaseFileTest, CheckpointRoundTripIsExactAndDamageIsRefused) {
  LatticeBox<2> box;
  box.spacing = 0.1;
  box.node_count = {4, 3};
  output::Checkpoint<2> c;
  c.real = make_real_lattice(box, 1000.0);
  c.virtual_particles = make_virtual_lattice(box, 1000.0);
  for (std::size_t i = 0; i < c.real.size(); ++i) {
    c.real.velocity[1][i] = std::sin(static_cast<double>(i)) / 3.0;  // not round numbers
    c.real.stress[2][i] = std::exp(static_cast<double>(i) * 0.37);
    c.real.boundary[i] = static_cast<std::int32_t>(i % 3) - 1;
    c.real.group[i] = 7;
  }
  c.time = 0.1 + 0.2;
  c.steps = 12345;
  c.frames = 3;
  c.real_series = {{0.0, "particles_000000.vtu"}, {c.time, "particles_000001.vtu"}};
  c.errors = {{c.time, "tip_error_percent", 1.0 / 3.0}};
  const std::string path = (directory_ / "state.bin").string();
  output::write_checkpoint(path, c);
  const auto back = output::read_checkpoint<2>(path);
  EXPECT_EQ(back.time, c.time);
  EXPECT_EQ(back.steps, c.steps);
  EXPECT_EQ(back.frames, c.frames);
  ASSERT_EQ(back.real.size(), c.real.size());
  ASSERT_EQ(back.virtual_particles.size(), c.virtual_particles.size());
  EXPECT_EQ(back.real.velocity[1], c.real.velocity[1]);
  EXPECT_EQ(back.real.stress[2], c.real.stress[2]);
  EXPECT_EQ(back.real.boundary, c.real.boundary);
  EXPECT_EQ(back.real.group, c.real.group);
  EXPECT_EQ(back.real.initial_position[0], c.real.initial_position[0]);
  EXPECT_EQ(back.virtual_particles.volume, c.virtual_particles.volume);
  ASSERT_EQ(back.real_series.size(), 2u);
  EXPECT_EQ(back.real_series[1].file, "particles_000001.vtu");
  ASSERT_EQ(back.errors.size(), 1u);
  EXPECT_EQ(back.errors[0].value, 1.0 / 3.0);
  EXPECT_FALSE(fs::exists(path + ".tmp"));
  // Another dimension, a truncated file, a file that is not a checkpoint.
  EXPECT_THROW(output::read_checkpoint<3>(path), std::runtime_error);
  fs::resize_file(path, fs::file_size(path) - 5);
  EXPECT_THROW(output::read_checkpoint<2>(path), std::runtime_error);
  EXPECT_THROW(output::read_checkpoint<2>(write("text.bin", "hello")), std::runtime_error);
}

}  // namespace

// The automatic method options (resolve_automatic_options): an elastic material in 2D or
// 3D takes the surface filter 0.02, the wall-gradient clamp, the hourglass stiffness 0.05
// and the surface extrapolation; a plastic material in 2D or 3D the wall gradient alone
// (2026-12-06: the smooth footing); 1D none; a value the caller set is kept. The case
// layer (resolved_method_options: memory estimate, restart record) and the builder agree
// with the solver.
TEST(CaseFile, AutomaticMethodOptionsFollowOneRule) {
  using S2 = SolverSettings<2>;
  // The four options of resolved settings s: filter, stiffness, wall gradient, extrapolation.
  auto expect_settings = [](const auto& s, double filter, double stiffness, bool wall, bool extrapolation) {
    using Settings = std::decay_t<decltype(s)>;
    EXPECT_EQ(s.hourglass_coefficient, filter);
    EXPECT_EQ(s.hourglass_stiffness, stiffness);
    EXPECT_EQ(s.velocity_wall, wall ? Settings::VelocityWall::wall_gradient : Settings::VelocityWall::characteristics);
    EXPECT_EQ(s.surface_extrapolation, extrapolation ? Toggle::on : Toggle::off);
  };
  const S2 elastic = resolve_automatic_options(S2{}, false, false);
  expect_settings(elastic, 0.02, 0.05, true, true);
  expect_settings(resolve_automatic_options(SolverSettings<3>{}, false, false), 0.02, 0.05, true, true);
  expect_settings(resolve_automatic_options(S2{}, true, false), 0.0, 0.0, true, false);
  expect_settings(resolve_automatic_options(SolverSettings<3>{}, true, false), 0.0, 0.0, true, false);
  expect_settings(resolve_automatic_options(SolverSettings<1>{}, true, false), 0.0, 0.0, false, false);
  expect_settings(S2::bare_scheme(), 0.0, 0.0, false, false);
  expect_settings(resolve_automatic_options(SolverSettings<1>{}, false, false), 0.0, 0.0, false, false);
  S2 set;
  set.hourglass_stiffness = 0.01;
  set.velocity_wall = S2::VelocityWall::characteristics;
  const S2 kept = resolve_automatic_options(set, false, false);
  EXPECT_EQ(kept.hourglass_stiffness, 0.01);
  EXPECT_EQ(kept.velocity_wall, S2::VelocityWall::characteristics);
  EXPECT_EQ(kept.surface_extrapolation, Toggle::on);  // the others still automatic
  EXPECT_EQ(resolve_automatic_options(elastic, true, false).hourglass_stiffness, 0.05);  // resolved values stay

  // The case layer: an elastic 2D case, the 1D bar, a plastic 2D case, an explicit value.
  auto expect_options = [](const CaseFile& c, double filter, double stiffness, bool wall, bool extrapolation) {
    const ResolvedMethodOptions r = resolved_method_options(c);
    EXPECT_EQ(r.hourglass, filter) << c.path;
    EXPECT_EQ(r.hourglass_stiffness, stiffness) << c.path;
    EXPECT_EQ(r.wall_gradient, wall) << c.path;
    EXPECT_EQ(r.surface_extrapolation, extrapolation) << c.path;
  };
  const CaseFile beam = load_case((kCases / "cantilever_2d.toml").string(), {"geometry.spacing=0.05"});
  expect_options(beam, 0.02, 0.05, true, true);
  BuiltCase<2> built = build_case<2>(beam);
  EXPECT_EQ(built.settings.hourglass_stiffness, kAutomaticOption);  // handed to the solver as set
  const S2 solver_settings = make_solver<2>(beam, built).settings();
  EXPECT_EQ(solver_settings.hourglass_coefficient, 0.02);
  EXPECT_EQ(solver_settings.hourglass_stiffness, 0.05);
  expect_options(load_case((kCases / "bar.toml").string()), 0.0, 0.0, false, false);
  const CaseFile footing = load_case((kCases / "footing_2d.toml").string(), {"geometry.spacing=0.1"});
  expect_options(footing, 0.0, 0.0, true, false);
  expect_options(load_case((kCases / "cantilever_2d.toml").string(), {"method.hourglass_stiffness=0.01"}), 0.02, 0.01,
                 true, true);

  // The restart record holds the resolved values in its former formats, so a checkpoint
  // written when the case set them (or before they were automatic) still matches.
  const std::string record = physics_record(beam);
  for (const char* line : {"method.hourglass = 0.02\n", "method.hourglass_stiffness = 0.05\n",
                           "method.velocity_wall = \"wall_gradient\"\n", "method.surface_extrapolation = true\n"})
    EXPECT_NE(record.find(line), std::string::npos) << line << "\n" << record;
  const std::string explicit_record = physics_record(load_case(
      (kCases / "cantilever_2d.toml").string(),
      {"geometry.spacing=0.05", "method.hourglass=0.02", "method.hourglass_stiffness=0.05",
       "method.velocity_wall=\"wall_gradient\"", "method.surface_extrapolation=true"}));
  EXPECT_EQ(explicit_record, record);
}

// The reference kernel's factor cache (engine/solver/kernel_factor_cache.hpp): the kernel
// factors read from the cache are the doubles the first pass computed, so a run with it
// and one without (solver.kernel_cache_mb = 0) are the same bits, and so is a run whose
// budget holds only the first rows of each list. Checked where the stencils differ most:
// the quarter Taylor bar (3D, mirror ghosts in the lists, J2, the adaptive step) and the
// plate (2D, elastic, the hourglass stiffness), each 40 steps.
struct CachedRun {
  std::vector<std::vector<double>> fields;  ///< positions, velocities, stresses, densities
  std::size_t cached_rows = 0, list_rows = 0;  ///< both lists together
  bool filled = false;
};

template <int Dim>
CachedRun run_steps(const CaseFile& c, int steps) {
  BuiltCase<Dim> built = build_case<Dim>(c);
  TaylorSph<Dim> solver = make_solver<Dim>(c, built);
  const double dt = case_time_step(c);
  for (int n = 0; n < steps; ++n) {
    double step = dt;
    if (c.adaptive_time_step) step = std::min(dt, c.cfl * solver.stable_time_step().time_step);
    solver.step(step);
  }
  CachedRun run;
  const SolverState<Dim>& state = solver.state();
  run.filled = state.half_kernel_factors.filled() && state.full_kernel_factors.filled();
  run.cached_rows = state.half_kernel_factors.rows() + state.full_kernel_factors.rows();
  run.list_rows = state.lists.virtual_from_real.query_count() + state.lists.real_from_virtual.query_count();
  const ParticleSet<Dim>& r = solver.real();
  for (int d = 0; d < Dim; ++d) run.fields.push_back(r.position[d]), run.fields.push_back(r.velocity[d]);
  for (int m = 0; m < stress_component_count<Dim>; ++m) run.fields.push_back(r.stress[m]);
  run.fields.push_back(r.density);
  return run;
}

template <int Dim>
void expect_same_bits_with_and_without_cache(const std::string& case_path) {
  const CachedRun with = run_steps<Dim>(load_case(case_path), 40);
  const CachedRun without = run_steps<Dim>(load_case(case_path, {"solver.kernel_cache_mb=0"}), 40);
  // 0.1 MiB: the first rows of each list only (its pairs take about 16 B each).
  const CachedRun part = run_steps<Dim>(load_case(case_path, {"solver.kernel_cache_mb=0.1"}), 40);
  EXPECT_TRUE(with.filled);
  EXPECT_EQ(with.cached_rows, with.list_rows);
  EXPECT_FALSE(without.filled);
  EXPECT_EQ(without.cached_rows, 0u);
  EXPECT_TRUE(part.filled);
  EXPECT_GT(part.cached_rows, 0u);
  EXPECT_LT(part.cached_rows, part.list_rows / 2);
  EXPECT_EQ(with.fields, without.fields);
  EXPECT_EQ(part.fields, without.fields);
}

TEST(KernelFactorCache, SameBitsWithAndWithout) {
  set_thread_count(2);
  expect_same_bits_with_and_without_cache<3>((kCases / "taylor_bar_quarter_3d.toml").string());
  expect_same_bits_with_and_without_cache<2>((kCases / "plate_2d.toml").string());
}
