// The oscillating plate and the twisting column (issue 14): their reference numbers
// (engine/validation/plate.hpp, twisting_column.hpp), the case format's beam mode shapes
// ([initial.profile] type = "cantilever_mode" / "twist"), the hourglass measure, and the
// validation cases of tools/validate/plate.cpp and column.cpp (quick versions here, the
// full ones labelled slow).
#include "engine/case/case_build.hpp"
#include "engine/case/case_file.hpp"
#include "engine/validation/plate.hpp"
#include "engine/validation/twisting_column.hpp"
#include "tools/validate/lattice_measures.hpp"
#include "tools/validate/validation_case.hpp"
#include "tests/case_helpers.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

namespace tsph {
namespace {

namespace fs = std::filesystem;

TEST(PlateReference, NumbersOfTheReference) {
  const OscillatingPlate plate;
  // Reference section 3: c0 = 57.03 m/s, omega = 24.73 rad/s, T = 0.2541 s (2 pi / 24.73;
  // the unrounded omega gives 0.25403 s).
  EXPECT_NEAR(plate.sound_speed(), 57.03, 0.005);
  EXPECT_NEAR(plate.omega(), 24.73, 0.005);
  EXPECT_NEAR(plate.period(), 0.2541, 1e-4);
  EXPECT_NEAR(2.0 * M_PI / 24.73, 0.2541, 1e-4);
  // V_f = 0.05: tip excursion about 0.58 L.
  EXPECT_NEAR(plate.linear_tip_amplitude(0.05) / plate.length, 0.58, 0.005);
  EXPECT_NEAR(plate.kl, cantilever_mode_wavenumber(1), 1e-12);
}

TEST(PlateReference, ModeShapeIsTheClampedFreeMode) {
  // Roots of cos x cosh x = -1.
  EXPECT_NEAR(cantilever_mode_wavenumber(1), 1.875104, 1e-6);
  EXPECT_NEAR(cantilever_mode_wavenumber(2), 4.694091, 1e-6);
  EXPECT_NEAR(cantilever_mode_wavenumber(3), 7.854757, 1e-6);
  for (int n = 1; n <= 3; ++n) {
    const double kl = cantilever_mode_wavenumber(n);
    auto phi = [&](double xi) { return cantilever_mode_shape(kl, xi); };
    const double h = 1e-3;
    // Clamped: phi(0) = phi'(0) = 0; free: phi''(1) = phi'''(1) = 0; phi(1) = 1.
    EXPECT_NEAR(phi(0.0), 0.0, 1e-12);
    EXPECT_NEAR((phi(h) - phi(-h)) / (2 * h), 0.0, h * h * std::pow(kl, 3));
    EXPECT_NEAR(phi(1.0), 1.0, 1e-12);
    const double second = (phi(1 + h) - 2 * phi(1) + phi(1 - h)) / (h * h);
    const double third = (phi(1 + 2 * h) - 2 * phi(1 + h) + 2 * phi(1 - h) - phi(1 - 2 * h)) / (2 * h * h * h);
    EXPECT_NEAR(second / (kl * kl), 0.0, 1e-5) << "mode " << n;
    EXPECT_NEAR(third / (kl * kl * kl), 0.0, 1e-4) << "mode " << n;
    // phi'''' = kl^4 phi (the beam equation) inside.
    const double xi = 0.37;
    const double fourth = (phi(xi + 2 * h) - 4 * phi(xi + h) + 6 * phi(xi) - 4 * phi(xi - h) + phi(xi - 2 * h)) /
                          (h * h * h * h);
    EXPECT_NEAR(fourth / std::pow(kl, 4), phi(xi), 1e-4) << "mode " << n;
  }
  // The initial kinetic energy integral against the closed form of the first mode:
  // int_0^1 phi^2 = 1/4 of phi(1)^2 for a clamped-free mode normalised to 1 at the tip.
  const OscillatingPlate plate;
  const double v = plate.tip_velocity(0.05);
  EXPECT_NEAR(plate.initial_kinetic_energy(0.05), 0.5 * plate.density * plate.thickness * plate.length * v * v / 4.0,
              1e-9);
}

TEST(ColumnReference, LinearEstimates) {
  const TwistingColumn column;
  EXPECT_NEAR(column.p_wave_speed(), 242.12, 0.01);
  EXPECT_NEAR(column.torsion_constant(), 0.140577, 1e-6);  // Timoshenko & Goodier, square: 0.1406 a^4
  EXPECT_NEAR(column.torsional_period(), 0.3580, 1e-4);
  EXPECT_NEAR(column.omega0_for(0.1), 34.24, 0.01);
  EXPECT_NEAR(column.peak_speed(34.0) / column.p_wave_speed(), 0.0993, 1e-4);
}

std::string case_text(const std::string& profile, int dim = 2) {
  const std::string geometry =
      dim == 2 ? "spacing = 0.01\nbox = { lower = [0.0, -0.01], upper = [0.2, 0.01] }\n"
               : "spacing = 0.25\nbox = { lower = [0.0, -0.5, -0.5], upper = [6.0, 0.5, 0.5] }\n";
  return fmt::format("dimension = {}\n[geometry]\n{}[material]\nE = 2e6\nnu = 0.3975\nrho = 1000.0\n"
                     "[method]\nalpha = 1.2\n[time]\nend = 1e-3\ncfl = 0.9\n{}\n",
                     dim, geometry, profile);
}

std::string error_of(const std::string& text) {
  try {
    load_case_text(text, "case.toml");
  } catch (const CaseError& e) {
    return e.what();
  }
  return "";
}

TEST(CaseFileProfiles, CantileverModeSetsTheModeShape) {
  const CaseFile c = load_case_text(case_text("[initial.profile]\ntype = \"cantilever_mode\"\naxis = [1.0, 0.0]\n"
                                              "length = 0.2\namplitude = [0.0, 2.0]\n"),
                                    "plate.toml");
  ASSERT_EQ(c.velocity_shapes.size(), 1u);
  const BuiltCase<2> b = build_case<2>(c);
  const OscillatingPlate plate;
  double largest = 0.0;
  for (const ParticleSet<2>* set : {&b.real, &b.virtual_particles})
    for (std::size_t i = 0; i < set->size(); ++i) {
      const double x = set->initial_position[0][i];
      EXPECT_NEAR(set->velocity[1][i], 2.0 * cantilever_mode_shape(plate.kl, x / 0.2), 1e-12);
      EXPECT_EQ(set->velocity[0][i], 0.0);
      largest = std::max(largest, set->velocity[1][i]);
    }
  EXPECT_NEAR(largest, 2.0, 1e-12);  // the tip
}

TEST(CaseFileProfiles, CantileverModeIsZeroBehindTheClampAndSumsWithWaves) {
  const CaseFile c = load_case_text(
      case_text("[[initial.profile]]\ntype = \"cantilever_mode\"\norigin = [0.1, 0.0]\naxis = [2.0, 0.0]\n"
                "length = 0.1\namplitude = [0.0, 1.0]\nmode = 2\n"
                "[[initial.profile]]\ntype = \"sine\"\namplitude = [0.5, 0.0]\ndirection = [1.0, 0.0]\n"
                "wavelength = 0.4\n"),
      "plate.toml");
  const BuiltCase<2> b = build_case<2>(c);
  const double kl = cantilever_mode_wavenumber(2);
  for (std::size_t i = 0; i < b.real.size(); ++i) {
    const double x = b.real.initial_position[0][i];
    const double expected = x < 0.1 ? 0.0 : cantilever_mode_shape(kl, (x - 0.1) / 0.1);
    EXPECT_NEAR(b.real.velocity[1][i], expected, 1e-12) << x;
    EXPECT_NEAR(b.real.velocity[0][i], 0.5 * std::sin(2 * M_PI * x / 0.4), 1e-12);
  }
}

TEST(CaseFileProfiles, TwistTurnsAboutTheAxis) {
  const CaseFile c = load_case_text(case_text("[initial.profile]\ntype = \"twist\"\naxis = [1.0, 0.0, 0.0]\n"
                                              "length = 6.0\nangular_velocity = 34.0\n",
                                              3),
                                    "column.toml");
  const BuiltCase<3> b = build_case<3>(c);
  double peak = 0.0;
  for (std::size_t i = 0; i < b.real.size(); ++i) {
    const double x = b.real.initial_position[0][i], y = b.real.initial_position[1][i],
                 z = b.real.initial_position[2][i];
    const double omega = 34.0 * std::sin(M_PI * x / 12.0);
    EXPECT_NEAR(b.real.velocity[0][i], 0.0, 1e-12);
    EXPECT_NEAR(b.real.velocity[1][i], -omega * z, 1e-12);
    EXPECT_NEAR(b.real.velocity[2][i], omega * y, 1e-12);
    peak = std::max(peak, std::hypot(b.real.velocity[1][i], b.real.velocity[2][i]));
  }
  EXPECT_NEAR(peak, TwistingColumn{}.peak_speed(34.0), 1e-9);
}

TEST(CaseFileProfiles, BadShapesAreReportedWithTheKey) {
  // twist in 2D
  EXPECT_NE(error_of(case_text("[initial.profile]\ntype = \"twist\"\naxis = [1.0, 0.0]\nlength = 1.0\n"
                               "angular_velocity = 1.0\n"))
                .find("is invalid: 'twist' needs dimension = 3 (a rotation about the axis)"),
            std::string::npos);
  // missing length, zero axis
  const std::string e = error_of(case_text("[initial.profile]\ntype = \"cantilever_mode\"\naxis = [0.0, 0.0]\n"
                                           "amplitude = [0.0, 1.0]\n"));
  EXPECT_NE(e.find("missing required key initial.profile.length"), std::string::npos) << e;
  EXPECT_NE(e.find("initial.profile.axis = [ 0.0, 0.0 ] is invalid: must be non-zero"), std::string::npos) << e;
  // a sine key on a mode shape, a bad mode, an unknown type
  const std::string f = error_of(case_text("[initial.profile]\ntype = \"cantilever_mode\"\naxis = [1.0, 0.0]\n"
                                           "length = 0.2\namplitude = [0.0, 1.0]\nmode = 0\nwavelength = 1.0\n"));
  EXPECT_NE(f.find("initial.profile.mode = 0 is invalid"), std::string::npos) << f;
  EXPECT_NE(f.find("wavelength"), std::string::npos) << f;
  EXPECT_NE(error_of(case_text("[initial.profile]\ntype = \"cantilever\"\n")).find("cantilever_mode"),
            std::string::npos);
}

TEST(CaseFileProfiles, ShippedCasesLoad) {
  const CaseFile plate = load_case(std::string(TSPH_SOURCE_DIR) + "/tools/cases/plate_2d.toml");
  EXPECT_EQ(plate.plane_mode, PlaneMode::plane_strain);
  EXPECT_EQ(plate.kinematics, Kinematics::updated_lagrangian);
  ASSERT_EQ(plate.velocity_shapes.size(), 1u);
  EXPECT_NEAR(plate.velocity_shapes[0].amplitude[1], OscillatingPlate{}.tip_velocity(0.01), 1e-6);
  const CaseFile column = load_case(std::string(TSPH_SOURCE_DIR) + "/tools/cases/twisting_column.toml");
  EXPECT_EQ(column.kinematics, Kinematics::updated_lagrangian);
  ASSERT_EQ(column.velocity_shapes.size(), 1u);
  EXPECT_EQ(column.velocity_shapes[0].angular_velocity, 34.0);
}

/// A frame of a lattice 2D or 3D with a given nodal field (initial positions on the lattice).
template <int Dim>
output::VtuFrame lattice_frame(int n, double dx, const std::function<std::array<double, 3>(std::array<int, Dim>)>& field,
                               std::vector<double>& values) {
  output::VtuFrame f;
  std::vector<double> x0;
  const int total = Dim == 2 ? n * n : n * n * n;
  for (int k = 0; k < total; ++k) {
    std::array<int, Dim> at;
    int rest = k;
    for (int d = 0; d < Dim; ++d) at[d] = rest % n, rest /= n;
    for (int d = 0; d < 3; ++d) x0.push_back(d < Dim ? at[d] * dx : 0.0);
    const auto v = field(at);
    values.insert(values.end(), v.begin(), v.end());
  }
  f.point_count = static_cast<std::size_t>(total);
  f.points = x0;
  f.arrays.push_back({"initial_position", 3, x0, {}, false});
  return f;
}

TEST(HourglassMeasure, ZeroOnQuadraticsOneOnACheckerboard) {
  const double dx = 0.1;
  {
    std::vector<double> smooth, checker;
    const auto f = lattice_frame<2>(
        7, dx,
        [&](std::array<int, 2> a) {
          const double x = a[0] * dx, y = a[1] * dx;
          return std::array<double, 3>{1 + 2 * x - y + x * x - 3 * x * y, 0.5 * y * y, 0.0};
        },
        smooth);
    lattice_frame<2>(7, dx, [](std::array<int, 2> a) { return std::array<double, 3>{0.0, (a[0] + a[1]) % 2 ? 1.0 : -1.0, 0.0}; },
                     checker);
    const validate::LatticeFrame<2> lattice(f, {0.0, 0.0}, {0.6, 0.6}, dx);
    EXPECT_LT(validate::hourglass_residual(lattice, smooth)[0], 1e-12);
    const auto r = validate::hourglass_residual(lattice, checker);
    EXPECT_GT(r[0], 0.5);  // of order the amplitude
    EXPECT_NEAR(r[0], r[1], 1e-12);
    EXPECT_EQ(lattice.volume_fraction(0), 0.25);
  }
  {
    std::vector<double> smooth, checker;
    const auto f = lattice_frame<3>(
        5, dx,
        [&](std::array<int, 3> a) {
          const double x = a[0] * dx, y = a[1] * dx, z = a[2] * dx;
          return std::array<double, 3>{x * z, 1 + y - z * z, x * y};
        },
        smooth);
    lattice_frame<3>(5, dx, [](std::array<int, 3> a) { return std::array<double, 3>{(a[0] + a[1] + a[2]) % 2 ? 1.0 : -1.0, 0.0, 0.0}; },
                     checker);
    const validate::LatticeFrame<3> lattice(f, {0.0, 0.0, 0.0}, {0.4, 0.4, 0.4}, dx);
    EXPECT_LT(validate::hourglass_residual(lattice, smooth)[0], 1e-12);
    EXPECT_GT(validate::hourglass_residual(lattice, checker)[0], 0.5);
  }
  // The period from zero crossings of a sampled cosine.
  std::vector<double> t, v;
  for (int k = 0; k <= 1000; ++k) t.push_back(k * 1e-3), v.push_back(std::cos(2 * M_PI * t.back() / 0.254));
  EXPECT_NEAR(validate::period_from_crossings(validate::zero_crossings(t, v)), 0.254, 1e-5);
}

/// Runs a validation case, prints its checks and notes, writes its series as CSV (for
/// the note), and returns it.
validate::Result run_validation(const validate::Case& c, bool quick) {
  validate::Options o;
  o.cases_dir = std::string(TSPH_SOURCE_DIR) + "/tools/cases";
  const fs::path out = fs::path(::testing::TempDir()) / ("tsph_validate_" + c.name + (quick ? "_quick" : ""));
  fs::remove_all(out);
  fs::create_directories(out);
  o.out_dir = out.string();
  o.quick = quick;
  const validate::Result r = c.run(o);
  for (const auto& k : r.checks)
    std::cout << fmt::format("{:<80} {:>12.6g} ref {:>10.6g} err {:>10.3e} ({}) tol {:g} {}\n", k.figure, k.value,
                             k.reference, k.error, k.error_kind, k.tolerance, k.pass ? "PASS" : "FAIL");
  for (const auto& n : r.notes) std::cout << "  " << n << "\n";
  for (const auto& s : r.series) {
    std::ofstream csv(out / (s.name + ".csv"));
    for (std::size_t k = 0; k < s.columns.size(); ++k) csv << (k ? "," : "") << s.columns[k];
    csv << "\n";
    for (const auto& row : s.rows) {
      for (std::size_t k = 0; k < row.size(); ++k) csv << (k ? "," : "") << fmt::format("{:.8g}", row[k]);
      csv << "\n";
    }
  }
  // The runs' frames are not needed after the figures: keep the series only.
  for (const auto& entry : fs::directory_iterator(out))
    if (entry.is_directory()) fs::remove_all(entry.path());
  std::cout << "  series in " << out.string() << "\n";
  return r;
}

const validate::Case& find_case(const std::vector<validate::Case>& cases, const std::string& name) {
  for (const auto& c : cases)
    if (c.name == name) return c;
  throw std::runtime_error("no validation case " + name);
}

TEST(PlateValidation, Registered) {
  const auto plate = validate::plate_cases();
  ASSERT_EQ(plate.size(), 2u);
  EXPECT_FALSE(find_case(plate, "plate_small").slow);
  EXPECT_TRUE(find_case(plate, "plate_large").slow);
  const auto column = validate::column_cases();
  ASSERT_EQ(column.size(), 2u);
  EXPECT_EQ(column[0].name, "twisting_column_alpha0.6");
  EXPECT_EQ(column[1].name, "twisting_column_alpha1.2");
}

/// What every result must hold whatever the method does: one check per figure with its
/// reference and tolerance, a note per run, and series whose rows match their columns.
/// Whether the checks pass is the verdict `tsph validate` reports (ctest
/// validate_quick_<case>; plate_small passes, plate_large fails at alpha 1.2 and
/// twisting_column_alpha0.6 fails: docs/validation.md). The plate's Quick tests here carry the
/// label slow (tests/CMakeLists.txt); the column's (about a second each) do not. They run what
/// validate_quick_<case> runs.
void expect_well_formed(const validate::Result& r, std::size_t checks, std::size_t notes,
                        const std::vector<std::string>& series) {
  EXPECT_EQ(r.checks.size(), checks);
  for (const auto& c : r.checks) {
    EXPECT_FALSE(c.figure.empty());
    EXPECT_TRUE(std::isfinite(c.reference)) << c.figure;
    EXPECT_GT(c.tolerance, 0.0) << c.figure;
    EXPECT_TRUE(c.error_kind == "rel" || c.error_kind == "abs" || c.error_kind == "max") << c.figure;
    if (!std::isfinite(c.value)) {
      EXPECT_FALSE(c.pass) << c.figure;  // a figure that could not be measured fails
    }
  }
  EXPECT_EQ(r.notes.size(), notes);
  ASSERT_EQ(r.series.size(), series.size());
  for (std::size_t k = 0; k < series.size(); ++k) {
    EXPECT_EQ(r.series[k].name, series[k]);
    EXPECT_FALSE(r.series[k].rows.empty()) << series[k];
    for (const auto& row : r.series[k].rows) ASSERT_EQ(row.size(), r.series[k].columns.size()) << series[k];
  }
}

TEST(PlateValidation, QuickSmall) {
  const auto r = run_validation(find_case(validate::plate_cases(), "plate_small"), true);
  expect_well_formed(r, 2, 2, {"tip_vy", "energy"});
  for (const auto& c : r.checks) EXPECT_NEAR(c.reference, OscillatingPlate{}.period(), 1e-12);
}
TEST(PlateValidation, QuickLarge) {
  const auto r = run_validation(find_case(validate::plate_cases(), "plate_large"), true);
  expect_well_formed(r, 6, 2, {"tip_vy", "energy", "hourglass"});
}
// Stable, no energy gain, no hourglass, and the tip's first peak within 25 % of the
// linear mode's (the quick grid: +18.8 % at alpha 1.2 on 2026-11-29).
TEST(ColumnValidation, Quick) {
  const auto r = run_validation(find_case(validate::column_cases(), "twisting_column_alpha1.2"), true);
  expect_well_formed(r, 4, 2, {"tip_rotation", "angular_momentum", "hourglass", "energy"});
  for (const auto& c : r.checks) EXPECT_TRUE(c.pass) << c.figure << ": " << c.value;
}
// Alpha 0.6 (its ctest validate_quick_ case is disabled: it twists too little, its tip
// peak 1.13 rad against the linear 1.94 (0.54 before 2026-12-07,
// docs/notes/2026-12-07-split-free-surfaces.md): it still runs to the end without gaining
// energy or an hourglass pattern (with the current kernel it diverged in its first 47 steps).
TEST(ColumnValidation, QuickAlpha06RunsToTheEnd) {
  const auto r = run_validation(find_case(validate::column_cases(), "twisting_column_alpha0.6"), true);
  expect_well_formed(r, 4, 2, {"tip_rotation", "angular_momentum", "hourglass", "energy"});
  for (std::size_t k = 0; k < 3; ++k) EXPECT_TRUE(r.checks[k].pass) << r.checks[k].figure << ": " << r.checks[k].value;
}

// Two free conditions are one free surface (BoundaryNormals::same_free_surface): the
// shipped column names its free end apart from its lateral faces, and the particles on
// the edges where they meet took the end face's normal, with the lateral faces' zero
// traction left out there; at alpha 0.6, dx = 1/12 the column diverged at those edges at
// step 149 (t = 0.046 s), and ran to its end with the two conditions as one
// (docs/notes/2026-12-07-split-free-surfaces.md). The shipped column and the same with
// the end face added to "free surface" now run the same steps bit for bit (25 x 5 x 5,
// alpha 0.6 and 1.2, 0.05 s; with the rule off they differ: at alpha 0.6 in positions,
// velocity and stress, at alpha 1.2 in positions at least).
TEST(ColumnValidation, NamingPartOfAFreeSurfaceApartChangesNothing) {
  std::ifstream in(testing_cases::shipped_case("twisting_column.toml"));
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string shipped = buffer.str();
  const std::string end_face = "{ type = \"half_space\", point = [6.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0] }";
  std::string merged = shipped;
  const std::size_t free_end = merged.find("[[boundary]]\nname = \"free end\"");
  const std::size_t clamp = merged.find("[[boundary]]\nname = \"clamp\"");
  ASSERT_NE(free_end, std::string::npos);
  ASSERT_NE(clamp, std::string::npos);
  merged.erase(free_end, clamp - free_end);
  const std::string last_side = "normal = [0.0, 0.0, -1.0] },\n]";
  const std::size_t sides_end = merged.find(last_side);
  ASSERT_NE(sides_end, std::string::npos);
  merged.replace(sides_end, last_side.size(), "normal = [0.0, 0.0, -1.0] },\n  " + end_face + ",\n]");
  for (const char* alpha : {"0.6", "1.2"}) {
    const std::vector<std::string> overrides{"geometry.spacing=0.25", "time.end=0.05", "output.every=0",
                                             std::string("method.alpha=") + alpha};
    RunReport two_report, one_report;
    const auto two = testing_cases::run_case_text(shipped, "column_two_conditions",
                                                  testing_cases::fresh_output_directory(), overrides, &two_report);
    const auto one = testing_cases::run_case_text(merged, "column_one_condition",
                                                  testing_cases::fresh_output_directory(), overrides, &one_report);
    ASSERT_EQ(two_report.status, RunReport::Status::finished) << alpha;
    ASSERT_EQ(one_report.status, RunReport::Status::finished) << alpha;
    ASSERT_GT(two.count, 0u);
    ASSERT_EQ(two.count, one.count);
    EXPECT_EQ(two.points, one.points) << "alpha " << alpha;
    for (const char* field : {"velocity", "stress"}) {
      ASSERT_TRUE(two.arrays.count(field) && one.arrays.count(field)) << field;
      EXPECT_EQ(two.arrays.at(field), one.arrays.at(field)) << field << ", alpha " << alpha;
    }
  }
}

// A 2D free corner's frame is the bisector of its two faces' normals, from the lattice
// (characteristics.hpp, FreeEdge::corner_face_normals), whatever the faces are named.
// Before, it was the particle's own normal: the kernel's diagonal where the faces are one
// condition (a free block), a face's normal where they are two (the plate's free end);
// and at full rank the second face's P relation was imposed along the frame's tangent,
// at the block's corners the other diagonal with its sign left to round-off. The corners
// of the rotating block's case (11 x 11, alpha 1.2 and 0.6) stretched by v = (0.5 x,
// -0.3 y) now move alike after one step whether its four faces are one condition or
// four: the corner's inputs at step 1 do not depend on the names. The hourglass filter
// and stiffness are off: after the boundary stage they mix in the neighbours'
// velocities, and the face particles next to a corner do depend on the names (one
// condition gives them the tilted kernel normal). With the former rule the corners at
// alpha 1.2 ended at (0.24259, 0.14999) m/s by one condition, (0.23637, 0.14685) m/s by
// four.
TEST(FreeCorner, NamingTheFacesApartChangesNotTheCornerVelocity) {
  std::ifstream in(testing_cases::shipped_case("rotation_2d.toml"));
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string one = buffer.str();
  const std::string cfl = "cfl = 0.9";
  const std::size_t at = one.find(cfl);
  ASSERT_NE(at, std::string::npos);
  one.replace(at, cfl.size(), "dt = 1e-3");
  const std::size_t first = one.find("[[boundary]]"), initial = one.find("[initial]");
  ASSERT_NE(first, std::string::npos);
  ASSERT_NE(initial, std::string::npos);
  std::string four = one.substr(0, first);
  const char* faces[][2] = {{"0.5, 0.0", "1.0, 0.0"}, {"-0.5, 0.0", "-1.0, 0.0"}, {"0.0, 0.5", "0.0, 1.0"},
                            {"0.0, -0.5", "0.0, -1.0"}};
  for (const auto& face : faces)
    four += fmt::format("[[boundary]]\nname = \"face {}\"\ntype = \"free\"\nregion = {{ type = \"half_space\", "
                        "point = [{}], normal = [{}] }}\n\n",
                        face[1], face[0], face[1]);
  four += one.substr(initial);
  for (const char* alpha : {"1.2", "0.6"}) {
    const std::vector<std::string> overrides{"geometry.spacing=0.1", "time.end=1e-3", std::string("method.alpha=") + alpha,
                                             "initial.velocity_gradient=[0.5, 0.0, 0.0, -0.3]", "method.hourglass=0",
                                             "method.hourglass_stiffness=0"};
    RunReport one_report, four_report;
    const auto by_one = testing_cases::run_case_text(one, "block_one_condition", testing_cases::fresh_output_directory(),
                                                     overrides, &one_report);
    const auto by_four = testing_cases::run_case_text(four, "block_four_conditions",
                                                      testing_cases::fresh_output_directory(), overrides, &four_report);
    ASSERT_EQ(one_report.status, RunReport::Status::finished) << alpha;
    ASSERT_EQ(four_report.status, RunReport::Status::finished) << alpha;
    ASSERT_EQ(by_one.count, 121u);
    ASSERT_EQ(by_four.count, 121u);
    const auto& v_one = by_one.arrays.at("velocity");
    const auto& v_four = by_four.arrays.at("velocity");
    int corners = 0;
    for (std::size_t i = 0; i < by_one.count; ++i) {
      if (std::abs(by_one.points[3 * i]) < 0.45 || std::abs(by_one.points[3 * i + 1]) < 0.45) continue;
      ++corners;
      const double scale = std::hypot(v_four[3 * i], v_four[3 * i + 1]);
      for (int d = 0; d < 2; ++d)
        EXPECT_NEAR(v_one[3 * i + d], v_four[3 * i + d], 1e-12 * scale)
            << "alpha " << alpha << ", corner at (" << by_one.points[3 * i] << ", " << by_one.points[3 * i + 1]
            << "), component " << d;
    }
    EXPECT_EQ(corners, 4) << "alpha " << alpha;
  }
}

// The shipped 3D cantilever in updated Lagrangian (tsph validate cantilever_3d_ul, quick:
// 41 x 5 x 5 to 1.2 s). Its free edges took the density of the characteristic relations
// on their diagonal normal, a volume rate of a stress state that the uniaxial edge stress
// then replaces: the compressed top edges next to the clamp grew a mode from about 0.47 s
// and the run diverged at t = 0.66 s (2026-11-28). With the edge's own volume rate
// (1 - 2 nu) e . grad v . e (FreeEdge::uniaxial_volume_rate) it rests: tip -3.92 %
// against the Timoshenko beam, drift 6.5e-6 L over the last 0.3 s. Label long (minutes
// under the sanitizers).
TEST(CantileverValidation, ThreeDimensionalUpdatedLagrangianBeamRests) {
  const auto r = run_validation(find_case(validate::cantilever_cases(), "cantilever_3d_ul"), true);
  ASSERT_EQ(r.checks.size(), 3u);  // no divergence (validate::no_divergence_check), tip, drift
  ASSERT_EQ(r.series.size(), 1u);
  EXPECT_EQ(r.series[0].columns, (std::vector<std::string>{"t", "u_y, 41 x 5 x 5", "ref Timoshenko beam"}));
  for (const auto& row : r.series[0].rows) ASSERT_EQ(row.size(), 3u);
  EXPECT_TRUE(r.checks[0].pass) << r.checks[0].figure << ": " << r.checks[0].value;  // no divergence
  EXPECT_LT(r.checks[1].error, 0.05) << r.checks[1].figure << ": " << r.checks[1].value;
  EXPECT_TRUE(r.checks[2].pass) << r.checks[2].figure << ": " << r.checks[2].value;  // at rest
}

// SolverSettings::surface_extrapolation in 3D fits the tangential Hessian of v_n over the
// neighbouring surface particles of the same normal. On an edge (and on the face rows
// next to one, whose normals tilt) those lie on a line: once the body has moved, the
// line's 2 x 2 moment matrix is rank one up to round-off (det 1e-12 to 1e-8 of its trace
// squared), which the former test (det against 1e-12 of its squared norm) took for
// invertible. The twisting column (25 x 5 x 5, alpha 1.2) then diverged at step 2 with
// a density 33 x rho0 next to an edge; with the stencil's principal-moment ratio checked
// it runs its first 0.05 s (54 steps) without gaining energy.
TEST(ColumnValidation, SurfaceExtrapolationLeavesEdgeLinesAlone) {
  const auto run = testing_cases::run_case_file(
      testing_cases::shipped_case("twisting_column.toml"),
      {"geometry.spacing=0.25", "time.end=0.05", "output.every=0", "method.surface_extrapolation=true",
       "method.hourglass_stiffness=0.05"},
      /*record_energy=*/true);
  ASSERT_EQ(run.report.status, RunReport::Status::finished);
  ASSERT_GT(run.steps.size(), 50u);
  const double e0 = run.steps.front().kinetic_energy + run.steps.front().strain_energy;
  double largest = 0.0;
  for (const auto& s : run.steps) largest = std::max(largest, s.kinetic_energy + s.strain_energy);
  EXPECT_LT(largest, e0 * (1.0 + 1e-3));
}

// surface_extrapolation fits d_t d_t v_n over the surface neighbours of the same normal.
// At alpha 0.6 a corner has one virtual neighbour: its half-step gradient is
// rank-deficient (the missing direction reads as zero) and is no sample of d_t v_n. The
// plate's free end (an unloaded face, unlike the cantilever's loaded tip) took its two
// corners into the fit, and the spurious Hessian made the end face's strain rate wrong:
// the plate 6 x too stiff (tip amplitude 0.0057 m against the linear 0.0231 m, period
// -61 %). With deficient stencils left out the quick plate (dx = 0.004, small strain)
// swings to 0.0230 m in its first quarter period.
TEST(PlateValidation, SurfaceExtrapolationLeavesDeficientCornersOut) {
  const auto run = testing_cases::run_case_file(
      testing_cases::shipped_case("plate_2d.toml"),
      {"geometry.spacing=0.004", "method.alpha=0.6", "method.kinematics=small_strain", "time.end=0.07",
       "output.every=100", "method.surface_extrapolation=true", "method.hourglass_stiffness=0.05"});
  ASSERT_EQ(run.report.status, RunReport::Status::finished);
  double largest = 0.0;
  for (const auto& f : run.frames)
    for (double u : f.displacement_y) largest = std::max(largest, std::abs(u));
  const OscillatingPlate plate;
  const double linear = 0.570266 / (2.0 * M_PI / plate.period());  // V_f c0 / omega
  EXPECT_NEAR(largest, linear, 0.1 * linear);
}

// surface_extrapolation moves a free surface's tangential strain rate from the depth at
// which its virtual stencil's gradient reads it to the surface. That depth is the row's
// normal moment (BoundaryParticles::normal_moment: -0.60 dx on a 2D face at alpha 1.2),
// not the stencil's centroid (-1.0 dx), which overshot: the plate's surface bending
// stress (dx = 0.004 m, small strain, the first turning point) was 24 % above the line
// through the two inner rows, and its energy kinetic + elastic 31 % above the initial;
// now 7 % and 13 % (of which about 8 % is the trapezoidal sum of a linear stress across 6
// rows, sum y^2 against int y^2).
TEST(PlateValidation, SurfaceExtrapolationReachesTheSurfaceNotBeyond) {
  const auto run = testing_cases::run_case_file(
      testing_cases::shipped_case("plate_2d.toml"),
      {"geometry.spacing=0.004", "method.kinematics=small_strain", "time.end=0.0635", "output.every=0"},
      /*record_energy=*/true);
  ASSERT_EQ(run.report.status, RunReport::Status::finished);
  const auto& f = run.frames.back();
  auto stress_at = [&](double x, double y) {
    for (std::size_t i = 0; i < f.x.size(); ++i)
      if (std::abs(f.x[i] - x) < 1e-9 && std::abs(f.y[i] - y) < 1e-9) return f.stress_xx[i];
    ADD_FAILURE() << "no particle at " << x << ", " << y;
    return 0.0;
  };
  for (double x : {0.04, 0.1})
    for (double side : {1.0, -1.0}) {
      const double line = 2.0 * stress_at(x, side * 0.006) - stress_at(x, side * 0.002);
      EXPECT_NEAR(stress_at(x, side * 0.01) / line, 1.0, 0.12) << "x = " << x << ", side " << side;
    }
  const double e0 = run.steps.front().kinetic_energy + run.steps.front().strain_energy;
  double largest = 0.0;
  for (const auto& s : run.steps) largest = std::max(largest, s.kinetic_energy + s.strain_energy);
  EXPECT_LT(largest / e0, 1.17);
  EXPECT_GT(largest / e0, 1.0);
}

// A free corner (both faces traction-free) carries no stress, and its velocity along the
// second face's normal follows that face's P characteristic (characteristics.hpp). Before,
// the corner took one face's normal and kept the stress along the other: the shipped
// plate (dx = 0.002 m, alpha 1.2) grew a symmetric mode at its free end, 0.38 % per step,
// and diverged at t = 0.150 s in small strain (0.061 s in updated Lagrangian).
TEST(PlateValidation, FreeCornersCarryNoStressAndThePlateEndStaysQuiet) {
  const auto run = testing_cases::run_case_file(testing_cases::shipped_case("plate_2d.toml"),
                                                {"method.kinematics=small_strain", "time.end=0.2",
                                                 "output.every=0", "output.times=[0.1, 0.2]"},
                                                /*record_energy=*/true);
  ASSERT_EQ(run.report.status, RunReport::Status::finished);
  const auto& f = run.frames.back();
  int corners = 0;
  for (std::size_t i = 0; i < f.x.size(); ++i)
    if (std::abs(f.x[i] - 0.2) < 1e-9 && std::abs(std::abs(f.y[i]) - 0.01) < 1e-9) {
      EXPECT_EQ(f.stress_xx[i], 0.0);
      ++corners;
    }
  EXPECT_EQ(corners, 2);
  const double e0 = run.steps.front().kinetic_energy + run.steps.front().strain_energy;
  for (const auto& s : run.steps) ASSERT_LT(s.kinetic_energy + s.strain_energy, 1.05 * e0) << "t = " << s.time;
}

// The stability monitor's energy balance (kCreatedEnergyFactor): the same plate in
// updated Lagrangian still grows a through-thickness mode at CFL 0.9 (docs/known-problems.md),
// 0.25 % per step, too slowly for the monitor's rate checks: it ran to the end with 150 x
// its initial energy and exit status 0. Now it stops once the scheme has made more energy
// than it was given (t = 0.235 s). When that mode is fixed, this test needs another slow
// runaway.
TEST(PlateValidation, SlowRunawayIsStoppedByTheEnergyBalance) {
  try {
    testing_cases::run_case_file(testing_cases::shipped_case("plate_2d.toml"), {"time.end=0.3", "output.every=0"});
    FAIL() << "the run was not stopped";
  } catch (const RunDiverged& e) {
    EXPECT_NE(std::string(e.what()).find("the scheme made"), std::string::npos) << e.what();
  }
}

// The full versions are `tsph validate plate_small | plate_large | twisting_column_alpha0.6 |
// twisting_column_alpha1.2` (ctest validate_<case>, label slow; disabled while they fail:
// tests/CMakeLists.txt).

}  // namespace
}  // namespace tsph
