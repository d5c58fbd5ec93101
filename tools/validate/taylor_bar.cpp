// Taylor bar impact (issue 16, item 3; ../shared/reference/large-deformation.md section
// 5): a copper cylinder (L0 = 32.4 mm, R0 = 3.2 mm, J2 with linear isotropic hardening)
// hits a frictionless rigid wall at 227 m/s; at 80 us its impact face has spread to
// R_f = 7.11-7.23 mm and its length is L_f = 21.42-21.48 mm (finite elements: Simo 1992,
// Zienkiewicz et al. 1998, Foulk et al. 2021). tools/cases/taylor_bar_3d.toml, the whole
// bar (no symmetry planes), updated Lagrangian with the adaptive time step; the real
// particles are written here for each spacing (write_cylinder) and read as a particle
// file. `taylor_bar_quarter`: the quarter y, z >= 0 between two mirror planes
// (tools/cases/taylor_bar_quarter_3d.toml; ghost particles: the whole bar's run to
// round-off, a quarter of its cost).
//
// The body on the cubic lattice of spacing dx: the union of the lattice cells whose
// centre lies in the circle of radius R0 (its area is pi R0^2 to a few per cent), the
// real particles at their corners, each carrying a quarter of the area of every filled
// cell it touches (the box's trapezoid rule), scaled so that the mass is exact. The
// figures: R_f, the mean distance from the axis of the impact-face particles that start
// on the true radius, (+-R0, 0) and (0, +-R0) (two of them in the quarter; the staircase's corners stand out
// to R0 + 0.3 dx); L_f, the mean axial position of the far end's particles.
#include "tools/validate/support.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cstdlib>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace tsph::validate {
namespace {

namespace fs = std::filesystem;

constexpr double kPi = 3.14159265358979323846;
constexpr double kLength = 32.4e-3, kRadius = 3.2e-3, kSpeed = 227.0, kEnd = 80e-6;
// The finite-element references (large-deformation.md section 5): their range's middle.
constexpr double kFinalRadius = 0.5 * (7.11e-3 + 7.23e-3), kFinalLength = 0.5 * (21.42e-3 + 21.48e-3);
constexpr int kFrames = 16;

/// The bar's length on the lattice: L0 rounded to a whole number of spacings (L0 = 10.125
/// R0 is one at dx = R0 / 8 and R0 / 16 only; at R0 / 4 the bar is 1.2 % shorter, at
/// R0 / 6 0.4 % longer, and the figures are compared as L_f / L0 and R_f / R0).
double discrete_length(double dx) { return std::round(kLength / dx) * dx; }

/// Group tags of the particle file (the case file's regions).
constexpr int kInterior = 0, kSide = 1, kFarEnd = 2;

/// Whether the lattice cell with lower corner (j, k) of the section belongs to a bar nr
/// cells in radius: its centre lies within the radius (see the file comment).
bool cell_filled(int j, int k, int nr) {
  return (j + 0.5) * (j + 0.5) + (k + 0.5) * (k + 0.5) <= static_cast<double>(nr) * nr;
}

/// The cylinder's real particles (see the file comment), written as a particle file:
/// columns x, y, z, volume, vx, vy, vz, group; the impact face (x = 0) starts at rest on
/// the wall, the rest at -kSpeed along x. `quarter`: the quarter y >= 0, z >= 0 only (the
/// symmetry planes y = 0 and z = 0 of tools/cases/taylor_bar_3d.toml), each particle
/// carrying its share of the quarter's cells (half on a plane, a quarter on the axis).
void write_cylinder(const std::string& path, double dx, bool quarter) {
  const int nx = static_cast<int>(std::lround(discrete_length(dx) / dx)), nr = static_cast<int>(std::lround(kRadius / dx));
  if (std::abs(nr * dx - kRadius) > 1e-9 * kRadius)
    throw std::invalid_argument(fmt::format("taylor_bar: dx = {} must divide R0 = {}", dx, kRadius));
  // Filled cells touching each section node: in the whole section (the side test) and in
  // the part modelled (the volume).
  std::map<std::pair<int, int>, int> cells_at_node, modelled_cells_at_node;
  int cells = 0;
  for (int j = -nr - 1; j <= nr; ++j)
    for (int k = -nr - 1; k <= nr; ++k)
      if (cell_filled(j, k, nr)) {
        const bool modelled = !quarter || (j >= 0 && k >= 0);
        cells += modelled;
        for (int a = 0; a < 2; ++a)
          for (int b = 0; b < 2; ++b) {
            ++cells_at_node[{j + a, k + b}];
            if (modelled) ++modelled_cells_at_node[{j + a, k + b}];
          }
      }
  const double scale = (quarter ? 0.25 : 1.0) * kPi * kRadius * kRadius / (cells * dx * dx);
  std::ofstream out(path);
  out << fmt::format("# Taylor bar{}: L0 = {} m, R0 = {} m, dx = {} m; written by tsph validate taylor_bar\n",
                     quarter ? " (quarter y >= 0, z >= 0)" : "", nx * dx, kRadius, dx);
  out << "x,y,z,volume,vx,vy,vz,group\n";
  for (int i = 0; i <= nx; ++i)
    for (const auto& [node, count] : modelled_cells_at_node) {
      const double volume = (i == 0 || i == nx ? 0.5 : 1.0) * dx * dx * dx * 0.25 * count * scale;
      // A node in one or two filled cells of the section is on the side; one in three is
      // a concave step of the staircase, which the solver counts as inside
      // (docs/cases.md, regions).
      const int group = i == nx ? kFarEnd : (cells_at_node.at(node) <= 2 ? kSide : kInterior);
      out << fmt::format("{:.10g},{:.10g},{:.10g},{:.10g},{},0,0,{}\n", i * dx, node.first * dx, node.second * dx,
                         volume, i == 0 ? 0.0 : -kSpeed, group);
    }
  if (!out) throw std::runtime_error("taylor_bar: cannot write " + path);
}

/// A face particle at lattice node (j, k) of a bar n cells in radius lies on the lateral
/// surface: not all four cells around it have their centre within the radius (write_cylinder's rule).
bool on_outer_ring(int j, int k, int n) {
  int filled = 0;
  for (const int a : {j - 1, j})
    for (const int b : {k - 1, k}) filled += cell_filled(a, b, n);
  return filled > 0 && filled < 4;
}

Result run_taylor_bar(const Options& o, bool quarter) {
  // The convergence table is the quarter model's (issue 16 asks for the quarter model
  // between symmetry planes; the mirror planes make it the whole bar's run to round-off,
  // at a quarter of the cost): dx = R0 / 4, 6 and 8 in the full suite (0.2, 1 and 3.6 min
  // on 2 cores: the flattened impact face takes the adaptive step to a fifth). The whole
  // bar runs R0 / 4 only, in the full suite as in the quick one, held to the quick
  // tolerance (its R0 / 6 run took 2.8 min for the quarter's figures to round-off).
  // TSPH_VALIDATE_DIVISIONS="4,6,8,10" replaces the list (a study).
  std::vector<int> divisions = o.quick || !quarter ? std::vector<int>{4} : std::vector<int>{4, 6, 8};
  if (const char* list = std::getenv("TSPH_VALIDATE_DIVISIONS")) {
    divisions.clear();
    for (const char* p = list; *p;) {
      char* end = nullptr;
      const long n = std::strtol(p, &end, 10);
      if (end == p || n < 2 || n > 64)
        throw std::invalid_argument(std::string("TSPH_VALIDATE_DIVISIONS = '") + list +
                                    "': give particles across the radius, e.g. \"4,6,8\" (each 2 to 64)");
      divisions.push_back(static_cast<int>(n));
      p = *end == ',' ? end + 1 : end;
    }
  }
  Result result;
  Series convergence;
  convergence.name = "convergence";
  convergence.title = "Taylor bar at 80 us against dx";
  convergence.x_label = "dx / R0";
  convergence.y_label = "R_f / R0, L_f / L0";
  convergence.columns = {"dx / R0", "R_f / R0", "L_f / L0", "ref R_f / R0", "ref L_f / L0"};
  for (std::size_t run_index = 0; run_index < divisions.size(); ++run_index) {
    const int n = divisions[run_index];
    const double dx = kRadius / n;
    const std::string name = fmt::format("r0_over_{}", n);
    const fs::path particles = fs::path(o.out_dir) / (name + ".csv");
    write_cylinder(particles.string(), dx, quarter);
    CaseRun run = run_case_file(o, quarter ? "taylor_bar_quarter_3d.toml" : "taylor_bar_3d.toml",
                                {fmt::format("geometry.spacing={}", dx),
                                 fmt::format("geometry.particle_file=\"{}\"", fs::absolute(particles).string()),
                                 output_times(kEnd, kFrames)},
                                name);
    const std::string at = fmt::format(", dx = R0 / {}", n);
    const double bar_length = discrete_length(dx);
    Series history;
    history.name = "history_" + name;
    history.title = "Taylor bar" + at;
    history.x_label = "t (us)";
    history.y_label = "R / R0, L / L0";
    history.columns = {"t (us)", "R / R0", "L / L0", "ref R_f / R0", "ref L_f / L0"};
    double radius = 0.0, ring_radius = 0.0, length = 0.0, largest_strain = 0.0;
    for (std::size_t f = 0; f < run.frames.size(); ++f) {
      const auto& frame = run.frames[f];
      const auto& x0 = array_of(frame, "initial_position");
      const auto& x = frame.points;  // the current positions (the displacement field is
                                     // integrated from the particles' own velocity and
                                     // drifts from them by up to 1.7 % of R_f here)
      const auto& strain = array_of(frame, "plastic_strain");
      double r_sum = 0.0, r_count = 0.0, l_sum = 0.0, l_count = 0.0, ring_sum = 0.0, ring_count = 0.0;
      for (std::size_t p = 0; p < frame.point_count; ++p) {
        const double* X = x0.data() + 3 * p;
        const std::array<int, 3> node{static_cast<int>(std::lround(X[0] / dx)), static_cast<int>(std::lround(X[1] / dx)),
                                      static_cast<int>(std::lround(X[2] / dx))};
        largest_strain = std::max(largest_strain, strain[p]);
        const bool on_axis_tip = (std::abs(node[1]) == n && node[2] == 0) || (node[1] == 0 && std::abs(node[2]) == n);
        if (node[0] == 0 && on_axis_tip) {
          r_sum += std::hypot(x[3 * p + 1], x[3 * p + 2]);
          r_count += 1.0;
        }
        // The face's outer ring (a face particle not surrounded by four filled cells): its
        // mean stretch r / r0, a reported figure (not a check; docs/notes/2026-12-06-volumetric-average.md).
        // In the quarter a particle on a mirror plane stands for two of the whole bar's
        // ring, one off the planes for four: weights 1/2 and 1 give the whole bar's mean.
        if (node[0] == 0 && on_outer_ring(node[1], node[2], n)) {
          const double w = quarter ? (node[1] == 0 ? 0.5 : 1.0) * (node[2] == 0 ? 0.5 : 1.0) : 1.0;
          ring_sum += w * std::hypot(x[3 * p + 1], x[3 * p + 2]) / std::hypot(X[1], X[2]);
          ring_count += w;
        }
        if (std::abs(X[0] - bar_length) < 1e-9 * bar_length) {
          l_sum += x[3 * p];
          l_count += 1.0;
        }
      }
      radius = r_sum / r_count;
      ring_radius = ring_count > 0.0 ? kRadius * ring_sum / ring_count : 0.0;
      length = l_sum / l_count;
      history.rows.push_back({run.frame_times[f] * 1e6, radius / kRadius, length / bar_length, kFinalRadius / kRadius,
                              kFinalLength / kLength});
    }
    result.series.push_back(std::move(history));
    Check reached = no_divergence_check(run, result);
    reached.figure += at;
    result.checks.push_back(reached);
    // The energy ledger (energy.csv): E = kinetic + elastic + plastic work against the
    // works of the boundaries (none here: a free surface and a fixed smooth wall) and of
    // the hourglass stiffness, whose stored energy is the ledger's hourglass_energy.
    const double energy0 = run.energy.empty() ? 0.0 : run.energy.at("kinetic").front();
    const double balance = largest_balance_error(run, energy0);
    result.notes.push_back(fmt::format(
        "dx = R0 / {}: {} real particles, {} steps (adaptive), {:.0f} s wall; largest equivalent plastic strain {:.2f}; "
        "energy ledger: balance error at 80 us {:.2f} % of E0, largest {:.1f} % (the hourglass stiffness holds {:.1f} %); "
        "the face's outer ring: mean r / r0 = {:.4f} (R_f above: the two particles on the lattice axes)",
        n, run.report.real_particles, run.report.steps, run.wall_seconds, largest_strain,
        run.energy.empty() ? 0.0 : 100.0 * run.energy.at("balance_error").back() / energy0, 100.0 * balance,
        run.energy.empty() ? 0.0 : 100.0 * run.energy.at("hourglass_energy").back() / energy0, ring_radius / kRadius));
    if (run.diverged) continue;
    // R0 / 4 (four particles across the radius: the quick run, and the whole bar's only
    // one) is held to 5 % (it lies within 3 % of both references, in part by luck: R0 / 6
    // is further off); a finer finest spacing to the 3 %.
    const bool finest = run_index + 1 == divisions.size();
    const double tolerance = o.quick || n <= 4 ? 0.05 : 0.03;
    if (o.quick || finest) {
      result.checks.push_back(relative_check("impact-face radius R_f / R0 at 80 us" + at, radius / kRadius,
                                             kFinalRadius / kRadius, tolerance));
      result.checks.push_back(relative_check("length L_f / L0 at 80 us" + at, length / bar_length,
                                             kFinalLength / kLength, tolerance));
      // The 1 % energy balance: checked in the full version (the balance error
      // reaches 6 % of E0 in the first microseconds of the impact at R0 / 4 and returns to
      // 0.04 % by 80 us), reported in the quick one's notes.
      if (!o.quick)
        result.checks.push_back(bound_check("energy balance, largest |balance error| / E0" + at, balance, 0.01));
    }
    convergence.rows.push_back({1.0 / n, radius / kRadius, length / bar_length, kFinalRadius / kRadius,
                                kFinalLength / kLength});
  }
  result.series.push_back(std::move(convergence));
  return result;
}

}  // namespace

std::vector<Case> taylor_bar_cases() {
  return {{"taylor_bar", "Taylor bar impact (copper, 227 m/s, 80 us) against finite-element references", true,
           [](const Options& o) { return run_taylor_bar(o, false); }},
          {"taylor_bar_quarter",
           "Taylor bar, quarter model between mirror planes (ghost particles: the whole bar's run)", true,
           [](const Options& o) { return run_taylor_bar(o, true); }}};
}

}  // namespace tsph::validate
