// tsph spectrum CASE: the one-step map of a case, U^{n+1} = G U^n + f, assembled column
// by column (engine/analysis/step_map.hpp), its eigenvalues, and its fixed point.
//
//   tsph spectrum tools/cases/cantilever_2d.toml --set geometry.spacing=0.025 [--modes 8] [--out DIR]
//
// Prints the spectral radius, the eigenvalues of largest modulus with what their modes
// are made of (which particles, which fields, how much of the cell-wise checkerboard the
// virtual particles cannot see), the slowest oscillations (a beam's bending modes: period,
// growth per step and per period), and the fixed point U* = (I - G)^-1 f under the load at
// time.end: a velocity in U* is a creep at constant speed, which damping cannot remove.
// The case must be one box on a lattice (the modes are read on it); its particles are
// grouped by the type of their boundary condition (fixed: clamp, traction or velocity:
// loaded end, free: free surface). Writes eigenvalues.csv (every eigenvalue and its
// mode's make-up), modes.csv (the leading modes, particle by particle) and
// fixed_point.csv (U* per particle) to --out. G is dense: keep the case small (41 x 5).
#include "engine/case/case_build.hpp"
#include "engine/case/case_file.hpp"
#include "engine/output_file.hpp"
#include "engine/parallel.hpp"
#include "engine/analysis/step_map.hpp"
#include "engine/validation/cantilever.hpp"
#include "tools/cli_common.hpp"
#include "tools/tsph_commands.hpp"

#include <CLI/CLI.hpp>
#include <Eigen/Eigenvalues>
#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>
#include <filesystem>
#include <memory>
#include <numbers>
#include <numeric>
#include <string>
#include <string_view>

namespace tsph::cli {
namespace {

using Complex = std::complex<double>;

struct SpectrumOptions {
  std::string case_path;
  std::vector<std::string> overrides;
  int modes = 8;
  std::string out = "out/spectrum";
  int threads = -1;
  bool write_map = false;
};

/// Where a particle is: the part of the beam its mode weight is summed over.
enum Region { kBulk, kNearClamp, kFree, kTip, kTipCorner, kClamp, kClampCorner, kRegionCount };
constexpr const char* kRegionNames[kRegionCount] = {"bulk",   "near_clamp", "free",        "tip",
                                                    "tip_corner", "clamp", "clamp_corner"};

template <int Dim>
struct Geometry {
  std::vector<std::array<int, 3>> index;  ///< lattice index per real particle
  std::vector<Region> region;
  std::array<int, 3> count{1, 1, 1};
  std::vector<int> at;  ///< lattice index -> particle (-1 none)
  int particle_at(int i, int j, int k) const {
    if (i < 0 || j < 0 || k < 0 || i >= count[0] || j >= count[1] || k >= count[2]) return -1;
    return at[static_cast<std::size_t>((k * count[1] + j) * count[0] + i)];
  }
};

template <int Dim>
Geometry<Dim> classify(const TaylorSph<Dim>& solver, const CaseFile& c) {
  Geometry<Dim> g;
  const auto& r = solver.real();
  const double dx = c.spacing;
  double lower[3] = {0.0, 0.0, 0.0};
  for (int d = 0; d < Dim; ++d) {
    lower[d] = c.box_lower[static_cast<std::size_t>(d)];
    g.count[static_cast<std::size_t>(d)] =
        static_cast<int>(std::lround((c.box_upper[static_cast<std::size_t>(d)] - lower[d]) / dx)) + 1;
  }
  g.at.assign(static_cast<std::size_t>(g.count[0] * g.count[1] * g.count[2]), -1);
  for (std::size_t p = 0; p < r.size(); ++p) {
    std::array<int, 3> idx{0, 0, 0};
    for (int d = 0; d < Dim; ++d)
      idx[static_cast<std::size_t>(d)] =
          static_cast<int>(std::lround((r.initial_position[d][p] - lower[d]) / dx));
    g.index.push_back(idx);
    g.at[static_cast<std::size_t>((idx[2] * g.count[1] + idx[1]) * g.count[0] + idx[0])] =
        static_cast<int>(p);
    bool side = false;  // on a lateral face (y or z extreme)
    for (int d = 1; d < Dim; ++d)
      side = side || idx[static_cast<std::size_t>(d)] == 0 ||
             idx[static_cast<std::size_t>(d)] == g.count[static_cast<std::size_t>(d)] - 1;
    const std::int32_t b = r.boundary[p];  // an index into the case's boundaries, or none
    const std::string type = b >= 0 && static_cast<std::size_t>(b) < c.boundaries.size()
                                 ? c.boundaries[static_cast<std::size_t>(b)].type
                                 : "";
    Region region = kBulk;
    if (type == "fixed") region = side ? kClampCorner : kClamp;
    else if (type == "traction" || type == "velocity") region = side ? kTipCorner : kTip;
    else if (type == "free") region = kFree;
    else if (idx[0] <= 2) region = kNearClamp;
    g.region.push_back(region);
  }
  return g;
}

/// What a mode (eigenvector w) is made of.
struct ModeMakeUp {
  std::array<double, kRegionCount> region{};  ///< fraction of |w|^2 per region
  double stress = 0.0, velocity = 0.0, displacement = 0.0;  ///< fraction per field
  /// Fraction of the cell-wise Hadamard coefficients with two or more alternating axes
  /// (the checkerboard twist(s)): what the 2^Dim corner values of a cell hold beyond their
  /// mean and linear part, i.e. what a virtual particle at alpha 0.6 cannot see.
  double invisible = 0.0;
  double odd_even_x = 0.0;  ///< |second difference along x|^2 / (16 |w|^2): 1 for (-1)^i
  std::size_t peak = 0;     ///< particle of the largest |w|
};

template <int Dim>
ModeMakeUp make_up(const Eigen::VectorXcd& w, const StepMapLayout<Dim>& layout, const Geometry<Dim>& g) {
  ModeMakeUp m;
  const double total = w.squaredNorm();
  const std::size_t particles = g.index.size();
  // Per particle, per unknown slot: gather values to walk the lattice.
  const std::size_t per = layout.unknowns.size() / particles;
  std::vector<double> particle_weight(particles, 0.0);
  for (std::size_t k = 0; k < layout.unknowns.size(); ++k) {
    const auto& u = layout.unknowns[k];
    const double a = std::norm(w[static_cast<Eigen::Index>(k)]);
    m.region[g.region[u.particle]] += a / total;
    particle_weight[u.particle] += a;
    (u.field == StepMapUnknown::Field::stress     ? m.stress
     : u.field == StepMapUnknown::Field::velocity ? m.velocity
                                                  : m.displacement) += a / total;
  }
  m.peak = static_cast<std::size_t>(
      std::max_element(particle_weight.begin(), particle_weight.end()) - particle_weight.begin());
  auto value = [&](int p, std::size_t slot) { return w[static_cast<Eigen::Index>(static_cast<std::size_t>(p) * per + slot)]; };
  double invisible = 0.0, cell_total = 0.0, second = 0.0;
  const int kc = Dim == 3 ? g.count[2] : 1;
  for (int k = 0; k < kc; ++k)
    for (int j = 0; j < g.count[1]; ++j)
      for (int i = 0; i < g.count[0]; ++i) {
        const int p = g.particle_at(i, j, k);
        if (i > 0 && i + 1 < g.count[0])
          for (std::size_t slot = 0; slot < per; ++slot)
            second += std::norm(value(g.particle_at(i - 1, j, k), slot) - 2.0 * value(p, slot) +
                                value(g.particle_at(i + 1, j, k), slot));
        if (i + 1 >= g.count[0] || j + 1 >= g.count[1] || (Dim == 3 && k + 1 >= kc)) continue;
        for (std::size_t slot = 0; slot < per; ++slot)
          for (int s = 0; s < (1 << Dim); ++s) {  // Hadamard coefficient s of the cell
            Complex c = 0.0;
            for (int b = 0; b < (1 << Dim); ++b) {
              const int corner = g.particle_at(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1));
              const int sign = __builtin_popcount(static_cast<unsigned>(s & b)) % 2 ? -1 : 1;
              c += static_cast<double>(sign) * value(corner, slot);
            }
            const double a = std::norm(c);
            cell_total += a;
            if (__builtin_popcount(static_cast<unsigned>(s)) >= 2) invisible += a;
          }
      }
  m.invisible = cell_total > 0.0 ? invisible / cell_total : 0.0;
  m.odd_even_x = second / (16.0 * total);
  return m;
}

template <int Dim>
std::string field_name(const StepMapUnknown& u) {
  static const char* axes = "xyz";
  if (u.field == StepMapUnknown::Field::velocity) return fmt::format("v{}", axes[u.component]);
  if (u.field == StepMapUnknown::Field::displacement) return fmt::format("u{}", axes[u.component]);
  for (int a = 0; a < 3; ++a)
    for (int b = a; b < 3; ++b)
      if ((a < Dim && b < Dim && stress_index<Dim>(a, b) == u.component) ||
          (Dim == 2 && a == 2 && b == 2 && u.component == 3))
        return fmt::format("s{}{}", axes[a], axes[b]);
  return fmt::format("s{}", u.component);
}

template <int Dim>
int run(const SpectrumOptions& o, const CaseFile& c) {
  if constexpr (Dim == 1) {
    throw CaseError({c.path + ": tsph spectrum reads the modes on a 2D or 3D lattice: give a case of dimension 2 or 3"});
  } else {
  if (c.box_lower.empty())
    throw CaseError({c.path + ": tsph spectrum needs geometry.box (one box on a lattice): the modes are read on it"});
  BuiltCase<Dim> built = build_case<Dim>(c);
  built.settings.energy_ledger = false;  // the step map's many steps write no energy.csv
  const auto* beam = dynamic_cast<const CantileverValidation<Dim>*>(built.exact.get());
  const double dt = built.dt;
  TaylorSph<Dim> solver = make_solver(c, built);
  const StepMapLayout<Dim> layout = step_map_layout(solver, dt);
  const auto n = static_cast<Eigen::Index>(layout.unknowns.size());
  const Geometry<Dim> geometry = classify(solver, c);
  const double dx = c.spacing;
  const double depth = c.box_upper[1] - c.box_lower[1];
  const double width = Dim == 3 ? c.box_upper[2] - c.box_lower[2] : 0.0;
  const std::size_t tip = beam ? beam->tip() : geometry.index.size();
  fmt::print("{} ({}D) {} x {}{}{}, alpha {}, CFL {:.3g}, damping {:.4g} 1/s, hourglass filter {}, "
             "hourglass stiffness {}, velocity_wall {}: {} unknowns\n",
             c.path, Dim, geometry.count[0], geometry.count[1], Dim == 3 ? fmt::format(" x {}", geometry.count[2]) : "",
             Dim == 2 ? (c.plane_mode == PlaneMode::plane_strain ? " (plane strain)" : " (plane stress)") : "",
             c.alpha, dt * built.wave_speed / dx, solver.settings().damping, solver.settings().hourglass_coefficient,
             solver.settings().hourglass_stiffness,
             solver.settings().velocity_wall == SolverSettings<Dim>::VelocityWall::wall_gradient ? "wall_gradient"
                                                                                               : "characteristics",
             n);

  auto clock = std::chrono::steady_clock::now();
  auto lap = [&] {
    const auto now = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(now - clock).count();
    clock = now;
    return seconds;
  };
  // G at t = 0 (any time: the step is affine), f under the full load (after the ramp).
  const Eigen::MatrixXd map = assemble_step_map(solver, layout, 0.0, dt);
  const double loaded_time = c.end_time;  // the load as it stands at time.end
  const Eigen::VectorXd load = apply_step(solver, layout, Eigen::VectorXd::Zero(n), loaded_time, dt);
  fmt::print("G assembled in {:.1f} s\n", lap());

  Eigen::EigenSolver<Eigen::MatrixXd> eigen(map, true);
  if (eigen.info() != Eigen::Success) {
    fmt::print(stderr, "tsph: failed: the eigenvalue iteration did not converge\n");
    return cli::kExitFailure;
  }
  const Eigen::VectorXcd lambda = eigen.eigenvalues();
  const Eigen::MatrixXcd vectors = eigen.eigenvectors();
  fmt::print("eigen-decomposition in {:.1f} s\n", lap());
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), Eigen::Index{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](Eigen::Index a, Eigen::Index b) { return std::abs(lambda[a]) > std::abs(lambda[b]); });
  int above = 0, at_one = 0, near_one = 0;
  for (Eigen::Index k = 0; k < n; ++k) {
    const double modulus = std::abs(lambda[k]);
    above += modulus > 1.0 + 1e-9;
    at_one += std::abs(lambda[k] - 1.0) < 1e-8;
    near_one += std::abs(lambda[k] - 1.0) < 1e-3;
  }
  fmt::print("spectral radius {:.12f}; |lambda| > 1 + 1e-9: {}; |lambda - 1| < 1e-8: {}; < 1e-3: {}\n",
             std::abs(lambda[order[0]]), above, at_one, near_one);

  std::vector<ModeMakeUp> makeup(static_cast<std::size_t>(n));
  for (Eigen::Index k = 0; k < n; ++k)
    makeup[static_cast<std::size_t>(k)] = make_up(Eigen::VectorXcd(vectors.col(k)), layout, geometry);
  auto describe = [&](Eigen::Index k) {
    const ModeMakeUp& m = makeup[static_cast<std::size_t>(k)];
    std::string where;
    std::array<int, kRegionCount> rank{};
    std::iota(rank.begin(), rank.end(), 0);
    std::sort(rank.begin(), rank.end(), [&](int a, int b) { return m.region[static_cast<std::size_t>(a)] > m.region[static_cast<std::size_t>(b)]; });
    for (int q = 0; q < 3; ++q)
      if (m.region[static_cast<std::size_t>(rank[static_cast<std::size_t>(q)])] > 0.05)
        where += fmt::format("{}{} {:.0f}%", where.empty() ? "" : ", ", kRegionNames[rank[static_cast<std::size_t>(q)]],
                             100.0 * m.region[static_cast<std::size_t>(rank[static_cast<std::size_t>(q)])]);
    const auto& idx = geometry.index[m.peak];
    return fmt::format("stress {:3.0f}% velocity {:3.0f}%{} | invisible {:4.2f} odd-even-x {:4.2f} | peak ({},{},{}) | {}",
                       100.0 * m.stress, 100.0 * m.velocity,
                       m.displacement > 0.0 ? fmt::format(" displacement {:3.0f}%", 100.0 * m.displacement) : "",
                       m.invisible, m.odd_even_x, idx[0], idx[1], idx[2], where);
  };
  fmt::print("largest |lambda|:\n");
  const int shown = std::min<int>(16, static_cast<int>(n));
  for (int q = 0; q < shown; ++q) {
    const Eigen::Index k = order[static_cast<std::size_t>(q)];
    fmt::print("  {:+.9f} {:+.9f}i  |{:.9f}|  {}\n", lambda[k].real(), lambda[k].imag(),
               std::abs(lambda[k]), describe(k));
  }

  // The structure's slowest oscillations (a beam's bending modes): angle between
  // kSlowestAngle (below it, the unit displacement modes' round-off) and kSlowAngle rad per
  // step, amplitude above 0.1 after one period (not the heavily damped near-static modes
  // of the displacement unknowns), by period. Among the largest |lambda| they are hidden by
  // the unit displacement modes, and a slow growth there (a few 1e-6 per step: per cent of
  // energy per period) is what a long run shows (docs/notes/2026-11-28-plate-energy-step-map.md).
  constexpr double kSlowestAngle = 1e-7, kSlowAngle = 0.05;  // a period of 6e7 .. 126 steps
  auto period_steps = [&](Eigen::Index k) { return 2.0 * std::numbers::pi / std::arg(lambda[k]); };
  std::vector<Eigen::Index> slow;
  for (Eigen::Index k = 0; k < n; ++k) {
    const double angle = std::arg(lambda[k]);
    if (angle > kSlowestAngle && angle <= kSlowAngle && std::pow(std::abs(lambda[k]), period_steps(k)) > 0.1)
      slow.push_back(k);
  }
  std::stable_sort(slow.begin(), slow.end(), [&](Eigen::Index a, Eigen::Index b) { return period_steps(a) > period_steps(b); });
  fmt::print("slowest oscillations ({} < angle <= {} rad per step, amplitude > 0.1 after a period): {}\n", kSlowestAngle,
             kSlowAngle, slow.size());
  for (std::size_t q = 0; q < std::min<std::size_t>(6, slow.size()); ++q) {
    const Eigen::Index k = slow[q];
    const double steps = period_steps(k);
    fmt::print("  period {:.4e} s ({:.0f} steps)  |lambda| - 1 = {:+.3e} per step, energy x {:.4f} per period  {}\n",
               steps * dt, steps, std::abs(lambda[k]) - 1.0, std::pow(std::abs(lambda[k]), 2.0 * steps), describe(k));
  }

  // The fixed point under the full load, and how singular I - G is.
  const Eigen::MatrixXd system = Eigen::MatrixXd::Identity(n, n) - map;
  Eigen::BDCSVD<Eigen::MatrixXd> svd(system, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::VectorXd sigma = svd.singularValues();
  fmt::print("I - G: largest singular value {:.4e}, smallest {:.4e}, {:.4e}, {:.4e}\n", sigma[0],
             sigma[n - 1], sigma[n - 2], sigma[n - 3]);
  fmt::print("  load f along the left singular vectors of the 3 smallest: {:.3e} {:.3e} {:.3e} (of |f| = {:.3e})\n",
             std::abs(svd.matrixU().col(n - 1).dot(load)), std::abs(svd.matrixU().col(n - 2).dot(load)),
             std::abs(svd.matrixU().col(n - 3).dot(load)), load.norm());
  // The state the damped run tends to: U^n = sum_k G^(n-k) f_k -> (I - P1) U*, with U* any
  // solution of (I - G) U* = f and P1 the spectral projector on the eigenvalue 1,
  // P1 = V0 (U0^T V0)^-1 U0^T (V0, U0: right and left null vectors of I - G). It exists
  // when f is orthogonal to U0 (else the state grows linearly) and U0^T V0 is regular
  // (else a Jordan block at 1: growth too).
  Eigen::Index nullity = 0;
  while (nullity < n && sigma[n - 1 - nullity] < 1e-10 * sigma[0]) ++nullity;
  Eigen::VectorXd fixed = svd.solve(load);
  const Eigen::MatrixXd right_null = svd.matrixV().rightCols(nullity);
  const Eigen::MatrixXd left_null = svd.matrixU().rightCols(nullity);
  std::vector<Eigen::Index> velocity_rows;
  for (Eigen::Index k = 0; k < n; ++k)
    if (layout.unknowns[static_cast<std::size_t>(k)].field == StepMapUnknown::Field::velocity) velocity_rows.push_back(k);
  if (nullity > 0) {
    const Eigen::MatrixXd coupling = left_null.transpose() * right_null;
    Eigen::JacobiSVD<Eigen::MatrixXd> coupling_svd(coupling);
    const Eigen::VectorXd cs = coupling_svd.singularValues();
    fmt::print("eigenvalue 1: {} null vectors of I - G; U0^T V0 singular values {:.3e} .. {:.3e} ({}); "
               "load along U0 {:.3e} of |f|\n",
               nullity, cs[0], cs[nullity - 1], cs[nullity - 1] > 1e-8 ? "semisimple: no Jordan block" : "JORDAN BLOCK",
               (left_null.transpose() * load).norm() / load.norm());
    fixed -= right_null * coupling.fullPivLu().solve(left_null.transpose() * fixed);
    Eigen::MatrixXd velocity_part(static_cast<Eigen::Index>(velocity_rows.size()), nullity);
    for (std::size_t r = 0; r < velocity_rows.size(); ++r) velocity_part.row(static_cast<Eigen::Index>(r)) = right_null.row(velocity_rows[r]);
    Eigen::JacobiSVD<Eigen::MatrixXd> vsvd(velocity_part);
    const Eigen::VectorXd vs = vsvd.singularValues();
    Eigen::Index moving = 0;
    for (Eigen::Index k = 0; k < vs.size(); ++k) moving += vs[k] > 1e-6;
    fmt::print("  of these, {} carry a velocity (steady motion at steady stress: mechanisms); the others are "
               "self-equilibrated stresses at rest (incompatible, as in the continuum)\n", moving);
  }
  const double residual = (system * fixed - load).norm() / load.norm();
  double speed = 0.0, stress_max = 0.0, tip_velocity = 0.0;
  std::size_t fastest = 0;
  std::vector<double> particle_speed(geometry.index.size(), 0.0);
  for (Eigen::Index k = 0; k < n; ++k) {
    const auto& u = layout.unknowns[static_cast<std::size_t>(k)];
    if (u.field == StepMapUnknown::Field::velocity) particle_speed[u.particle] += fixed[k] * fixed[k];
    if (u.field == StepMapUnknown::Field::stress) stress_max = std::max(stress_max, std::abs(fixed[k]) * layout.stress_unit);
    if (u.particle == tip && u.field == StepMapUnknown::Field::velocity && u.component == 1)
      tip_velocity = fixed[k];
  }
  for (std::size_t p = 0; p < particle_speed.size(); ++p)
    if (particle_speed[p] > speed) speed = particle_speed[p], fastest = p;
  speed = std::sqrt(speed);
  fmt::print("limit state (I - P1) U* under the full load (residual {:.2e}): largest |v| {:.4e} m/s at particle "
             "({},{},{}) [{}]; largest |sigma| {:.4e} Pa\n",
             residual, speed, geometry.index[fastest][0], geometry.index[fastest][1], geometry.index[fastest][2],
             kRegionNames[geometry.region[fastest]], stress_max);
  if (beam)
    fmt::print("  tip v_y {:.4e} m/s = {:.3g} exact tip deflections per second\n", tip_velocity,
               tip_velocity / beam->tip_exact());

  // The displacement rate in the limit state: one step from it, displacement from zero.
  {
    StepMapLayout<Dim> with_displacement = layout;
    if (!(solver.settings().hourglass_stiffness > 0.0))  // else the layout holds them
      for (std::uint32_t p = 0; p < geometry.index.size(); ++p)
        for (int d = 0; d < Dim; ++d)
          with_displacement.unknowns.push_back({p, StepMapUnknown::Field::displacement, d});
    Eigen::VectorXd state = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(with_displacement.unknowns.size()));
    state.head(n) = fixed;
    const Eigen::VectorXd next = apply_step(solver, with_displacement, state, loaded_time, dt);
    double tip_rate = 0.0, largest_rate = 0.0;
    for (std::size_t k = 0; k < with_displacement.unknowns.size(); ++k) {
      const auto& u = with_displacement.unknowns[k];
      if (u.field != StepMapUnknown::Field::displacement) continue;
      const auto e = static_cast<Eigen::Index>(k);
      const double rate = (next[e] - state[e]) * with_displacement.displacement_unit / dt;
      largest_rate = std::max(largest_rate, std::abs(rate));
      if (u.particle == tip && u.component == 1) tip_rate = rate;
    }
    fmt::print("displacement rate in the limit state: largest |du/dt| {:.4e} m/s\n", largest_rate);
    if (beam)
      fmt::print("  tip du_y/dt {:.4e} m/s = {:.3g} exact tip deflections per second (the creep)\n", tip_rate,
                 tip_rate / beam->tip_exact());
  }

  // Files.
  const std::filesystem::path out(o.out);
  std::string csv = "rank,re,im,abs,stress,velocity,displacement,invisible,odd_even_x,peak_i,peak_j,peak_k";
  for (const char* name : kRegionNames) csv += fmt::format(",{}", name);
  csv += "\n";
  for (Eigen::Index q = 0; q < n; ++q) {
    const Eigen::Index k = order[static_cast<std::size_t>(q)];
    const ModeMakeUp& m = makeup[static_cast<std::size_t>(k)];
    const auto& idx = geometry.index[m.peak];
    fmt::format_to(std::back_inserter(csv), "{},{:.15g},{:.15g},{:.15g},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{},{},{}", q,
                   lambda[k].real(), lambda[k].imag(), std::abs(lambda[k]), m.stress, m.velocity,
                   m.displacement, m.invisible, m.odd_even_x, idx[0], idx[1], idx[2]);
    for (double f : m.region) fmt::format_to(std::back_inserter(csv), ",{:.6f}", f);
    csv += "\n";
  }
  write_file_atomically(out / "eigenvalues.csv", csv);
  const std::size_t per = layout.unknowns.size() / geometry.index.size();
  std::string header = "i,j,k,x,y,z,region";
  for (std::size_t slot = 0; slot < per; ++slot) header += "," + field_name<Dim>(layout.unknowns[slot]);
  std::string modes = "mode,re,im," + header + "\n";
  for (int q = 0; q < std::min<int>(o.modes, static_cast<int>(n)); ++q) {
    const Eigen::Index k = order[static_cast<std::size_t>(q)];
    Eigen::VectorXcd w = vectors.col(k);
    Eigen::Index peak = 0;
    w.cwiseAbs().maxCoeff(&peak);
    w *= std::abs(w[peak]) / w[peak];  // phase: the largest entry real and positive
    w /= w.cwiseAbs().maxCoeff();
    for (std::size_t p = 0; p < geometry.index.size(); ++p) {
      const auto& idx = geometry.index[p];
      fmt::format_to(std::back_inserter(modes), "{},{:.12g},{:.12g},{},{},{},{:.6g},{:.6g},{:.6g},{}", q,
                     lambda[k].real(), lambda[k].imag(), idx[0], idx[1], idx[2], idx[0] * dx,
                     idx[1] * dx - 0.5 * depth, Dim == 3 ? idx[2] * dx - 0.5 * width : 0.0,
                     kRegionNames[geometry.region[p]]);
      for (std::size_t slot = 0; slot < per; ++slot)
        fmt::format_to(std::back_inserter(modes), ",{:.6e}", w[static_cast<Eigen::Index>(p * per + slot)].real());
      modes += "\n";
    }
  }
  write_file_atomically(out / "modes.csv", modes);
  std::string fixed_csv = header + "\n";
  for (std::size_t p = 0; p < geometry.index.size(); ++p) {
    const auto& idx = geometry.index[p];
    fmt::format_to(std::back_inserter(fixed_csv), "{},{},{},{:.6g},{:.6g},{:.6g},{}", idx[0], idx[1], idx[2],
                   idx[0] * dx, idx[1] * dx - 0.5 * depth, Dim == 3 ? idx[2] * dx - 0.5 * width : 0.0,
                   kRegionNames[geometry.region[p]]);
    for (std::size_t slot = 0; slot < per; ++slot) {
      const auto& u = layout.unknowns[p * per + slot];
      fmt::format_to(std::back_inserter(fixed_csv), ",{:.9e}",
                     fixed[static_cast<Eigen::Index>(p * per + slot)] * detail::unit_of(layout, u));
    }
    fixed_csv += "\n";
  }
  write_file_atomically(out / "fixed_point.csv", fixed_csv);
  if (o.write_map) {  // G itself, for analyses of its own (numpy.fromfile(..., '<f8').reshape(n, n))
    const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> row_major = map;
    write_file_atomically(out / "map.f64", std::string_view(reinterpret_cast<const char*>(row_major.data()),
                                                            static_cast<std::size_t>(n * n) * sizeof(double)));
    std::string rows = "row,particle,i,j,k,region,field\n";
    for (std::size_t p = 0; p < geometry.index.size(); ++p)
      for (std::size_t slot = 0; slot < per; ++slot) {
        const auto& idx = geometry.index[p];
        fmt::format_to(std::back_inserter(rows), "{},{},{},{},{},{},{}\n", p * per + slot, p, idx[0], idx[1], idx[2],
                       kRegionNames[geometry.region[p]], field_name<Dim>(layout.unknowns[p * per + slot]));
      }
    write_file_atomically(out / "map_rows.csv", rows);
  }
  fmt::print("SVD, analysis and files in {:.1f} s; output in {}\n", lap(), o.out);
  return kExitOk;
  }
}

int run_spectrum(const SpectrumOptions& o) {
  const CaseFile c = load_case(o.case_path, o.overrides);
  set_thread_count(o.threads >= 0 ? o.threads : c.threads);
  if (!prepare_output_directory("tsph", o.out)) return kExitBadInput;
  switch (c.dimension) {
    case 2: return run<2>(o, c);
    case 3: return run<3>(o, c);
    default: return run<1>(o, c);
  }
}

}  // namespace

Subcommand add_spectrum(CLI::App& app) {
  auto o = std::make_shared<SpectrumOptions>();
  CLI::App* sub = app.add_subcommand(
      "spectrum", "eigenvalues and fixed point of a case's one-step map (a small 2D or 3D box case)");
  sub->add_option("CASE", o->case_path, "case file (TOML)")->required();
  sub->add_option("--set", o->overrides, "override a key of the case, e.g. --set geometry.spacing=0.025 (repeatable)")
      ->type_name("KEY=VALUE")
      ->take_all()
      ->allow_extra_args(false);
  sub->add_option("--modes", o->modes, "leading modes written to modes.csv")->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--out", o->out, "output directory")->capture_default_str();
  sub->add_flag("--write-map", o->write_map,
                "also write G (map.f64: n x n float64, row-major, little-endian; map_rows.csv: what each row is; "
                "the stress scaled by rho c_p, the displacement by dt)");
  sub->add_option("--threads", o->threads, "OpenMP threads (0: OpenMP default; overrides the case's threads)")
      ->check(CLI::NonNegativeNumber);
  return {sub, [o] {
            try {
              return run_spectrum(*o);
            } catch (const CaseError& e) {
              for (const auto& m : e.messages()) fmt::print(stderr, "tsph: error: {}\n", m);
              return kExitBadInput;
            } catch (const std::exception& e) {
              fmt::print(stderr, "tsph: failed: {}\n", e.what());
              return kExitFailure;
            }
          }};
}

}  // namespace tsph::cli
