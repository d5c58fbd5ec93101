// Smooth rigid strip footing on undrained (Tresca) soil (issue 16, item 3;
// ../shared/reference/large-deformation.md section 6): tools/cases/footing_2d.toml, the
// footing of width B pushed into weightless soil of cohesion c at a slow speed; the
// load-settlement curve q(delta) against Prandtl's collapse pressure q_u = (2 + pi) c.
// The footing's pressure: the vertical force through the soil one footing width below it
// (equilibrium of the weightless soil) divided by B; its settlement: the mean over its
// particles (initially on y = 0, |x| <= B / 2).
#include "tools/validate/support.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace tsph::validate {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kFrames = 100;  ///< the energy balance integrates over the frames

Result run_footing(const Options& o) {
  // Full: dx = B / 10 to 5 s (settlement 0.095 B); quick: dx = B / 4 to 4 s, a coarse
  // version whose plateau lies 10 % below Prandtl's and is still rising by a few per cent
  // (the full one within 5 % and flat within 1 %).
  const double dx = o.quick ? 0.25 : 0.1, end = o.quick ? 4.0 : 5.0;
  const double tolerance = o.quick ? 0.2 : 0.05, flatness = o.quick ? 0.05 : 0.01;
  std::vector<std::string> overrides = {fmt::format("geometry.spacing={}", dx), fmt::format("time.end={}", end),
                                        output_times(end, kFrames)};
  CaseRun run = run_case_file(o, "footing_2d.toml", overrides, "run");
  Result result;
  const double cohesion = run.file.plasticity.cohesion, prandtl = (2.0 + kPi) * cohesion;
  double half_width = 0.0;  // B / 2: the footing condition's box (case file)
  for (const auto& b : run.file.boundaries)
    if (b.name == "footing" && !b.regions.empty() && b.regions[0].upper.size() == 2)
      half_width = std::round(b.regions[0].upper[0] / dx) * dx;
  if (!(half_width > 0.0)) throw std::runtime_error("footing_2d.toml: no box condition named 'footing'");

  Series series;
  series.name = "load_settlement";
  series.title = fmt::format("strip footing, Tresca soil, dx = B / {:.0f}", 2.0 * half_width / dx);
  series.x_label = "settlement / B";
  series.y_label = "q / c";
  series.columns = {"settlement / B", "q / c", "ref Prandtl (2 + pi)"};
  std::vector<double> settlement, pressure, kinetic, stored;  // stored: elastic + plastic work
  // The box's lattice volumes (case_build.cpp: a node's share of its cells; small strain,
  // so they stay), and the material (plane strain).
  const auto& lower = run.file.box_lower;
  const auto& upper = run.file.box_upper;
  const double young = run.file.young_modulus, nu = run.file.poisson_ratio, rho = run.file.density;
  auto volume_at = [&](double x, double y) {
    double v = dx * dx;
    if (std::abs(x - lower[0]) < 1e-9 * dx || std::abs(x - upper[0]) < 1e-9 * dx) v *= 0.5;
    if (std::abs(y - lower[1]) < 1e-9 * dx || std::abs(y - upper[1]) < 1e-9 * dx) v *= 0.5;
    return v;
  };
  for (const auto& frame : run.frames) {
    const auto& velocity = array_of(frame, "velocity");
    const auto& plastic_work = array_of(frame, "plastic_work");
    {
      const auto& x0 = array_of(frame, "initial_position");
      const auto& s = array_of(frame, "stress");
      double k = 0.0, e = 0.0;
      for (std::size_t i = 0; i < frame.point_count; ++i) {
        const double v = volume_at(x0[3 * i], x0[3 * i + 1]);
        e += v * (elastic_energy_density(s.data() + 6 * i, young, nu) + plastic_work[i]);
        k += 0.5 * rho * v *
             (velocity[3 * i] * velocity[3 * i] + velocity[3 * i + 1] * velocity[3 * i + 1]);
      }
      kinetic.push_back(k);
      stored.push_back(e);
    }
    const auto& x0 = array_of(frame, "initial_position");
    const auto& s = array_of(frame, "stress");  // VTK order: xx yy zz xy yz xz
    const auto& u = array_of(frame, "displacement");
    // The load: the vertical force through the row of particles one footing width below
    // the surface (trapezoid rule across the block). The soil is weightless, the sides are
    // smooth and the motion quasi-static, so every row carries the footing's load (they
    // agree to 0.03 %); the footing's own particles would miss what their neighbours
    // beyond its edges carry (6 % low at dx = B / 10).
    double force = 0.0, down = 0.0, count = 0.0;
    const double depth = -2.0 * half_width;
    for (std::size_t i = 0; i < frame.point_count; ++i) {
      const double x = x0[3 * i], y = x0[3 * i + 1];
      if (std::abs(y - depth) < 1e-9 * dx) {
        const double side = std::abs(x - lower[0]) < 1e-9 * dx || std::abs(x - upper[0]) < 1e-9 * dx;
        force -= s[6 * i + 1] * (side ? 0.5 * dx : dx);
      }
      if (std::abs(y) > 1e-9 * dx || std::abs(x) > half_width + 1e-9 * dx) continue;
      down -= u[3 * i + 1];  // the footing's settlement: the mean over its particles
      count += 1.0;
    }
    const double width = 2.0 * half_width;
    settlement.push_back(down / count / width);
    pressure.push_back(force / width);
    series.rows.push_back({settlement.back(), pressure.back() / cohesion, 2.0 + kPi});
  }
  result.checks.push_back(no_divergence_check(run, result));
  if (run.diverged || run.frames.size() < 4) {
    result.series.push_back(std::move(series));
    return result;
  }
  // The plateau: the frames past 60 % of the final settlement.
  double sum = 0.0, low = 1e300, high = -1e300, n = 0.0;
  for (std::size_t f = 0; f < settlement.size(); ++f)
    if (settlement[f] >= 0.6 * settlement.back()) {
      sum += pressure[f];
      low = std::min(low, pressure[f]);
      high = std::max(high, pressure[f]);
      n += 1.0;
    }
  const double plateau = sum / n;
  result.checks.push_back(relative_check("plateau pressure q / c (mean past 60 % of the settlement)", plateau / cohesion,
                                         prandtl / cohesion, tolerance));
  result.checks.push_back(bound_check("plateau flatness, (max - min) / mean", (high - low) / plateau, flatness));
  // Energy balance (per unit thickness), reported, not yet checked (issue 16 asks for 1 %;
  // docs/validation.md, Plasticity): the work of the footing, int F d(delta) over the
  // frames, against the elastic energy + the plastic work + the kinetic energy + what
  // the velocity damping dissipated, int 2 c KE dt. The stored energy falls short, by
  // 18 % at dx = B / 10 and 45 % at B / 4 (2026-11-26; more with the soil elastic): the
  // displacement field under the footing carries a checkerboard (hourglass) mode that
  // the stress does not see.
  {
    const double width = 2.0 * half_width, damping = run.file.damping;
    double external = 0.0, dissipated = 0.0;
    for (std::size_t f = 1; f < run.frames.size(); ++f) {
      external += 0.5 * (pressure[f] + pressure[f - 1]) * width * (settlement[f] - settlement[f - 1]) * width;
      dissipated += damping * (kinetic[f] + kinetic[f - 1]) * (run.frame_times[f] - run.frame_times[f - 1]);
    }
    result.notes.push_back(fmt::format("energy at the end (J/m; not yet balanced): footing work {:.6g}, elastic + "
                                       "plastic {:.6g}, kinetic {:.3g}, damped {:.4g}: {:.1f} % of the work accounted for",
                                       external, stored.back(), kinetic.back(), dissipated,
                                       100.0 * (stored.back() + kinetic.back() + dissipated) / external));
  }
  result.notes.push_back(fmt::format("dx = {} m ({} particles), final settlement {:.4f} B, {} steps, {:.1f} s wall", dx,
                                     run.report.real_particles, settlement.back(), run.report.steps, run.wall_seconds));
  result.series.push_back(std::move(series));
  return result;
}

}  // namespace

std::vector<Case> footing_cases() {
  return {{"footing_tresca", "smooth strip footing on Tresca soil against Prandtl's (2 + pi) c", true, run_footing}};
}

}  // namespace tsph::validate
