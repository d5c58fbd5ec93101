// Diagnostic (docs/notes/2026-12-06-deficient-tangents.md): the free rotating 3D cube
// (tools/cases/rotation_3d.toml) step by step. Per particle class (interior, face, edge,
// corner: on how many of the box's faces the initial position lies): the angular momentum
// about z against the rigid one at the initial omega, the mean radial speed and |v_z|;
// the cumulative torque of the velocity update split by class, by row from the surface
// (0, 1, 2, >= 3) and by which faces (none, +-z only, +-x / +-y, both).
//   rotation_classes CASE.toml [override...]
//   env DIAG_EVERY: print every N steps (20); DIAG_PROBE=ID: one particle's velocity
//   against the rigid one and its stress, every step.
#include "tools/diag/diagnostic_run.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using namespace tsph;

int main(int argc, char** argv) {
  DiagnosticRun<3> run(argc, argv, 20);
  const CaseFile& c = run.c;
  TaylorSph<3>& solver = run.solver;
  const double dt = run.dt;
  const auto& r = solver.real();
  const std::size_t n = r.size();
  std::vector<int> cls(n), row(n), kind(n);
  for (std::size_t i = 0; i < n; ++i) {
    bool on_face[3];
    double depth = 1e30;
    for (int d = 0; d < 3; ++d) {
      const double below = r.initial_position[d][i] - c.box_lower[d], above = c.box_upper[d] - r.initial_position[d][i];
      on_face[d] = std::abs(below) < 1e-9 || std::abs(above) < 1e-9;
      depth = std::min(depth, std::min(below, above));
    }
    cls[i] = on_face[0] + on_face[1] + on_face[2];
    row[i] = std::min(3, static_cast<int>(std::lround(depth / c.spacing)));
    const bool on_xy = on_face[0] || on_face[1];
    kind[i] = on_face[2] && on_xy ? 3 : on_xy ? 2 : on_face[2] ? 1 : 0;
  }
  // The spin about z of the initial velocity gradient (row-major): omega = (L_yx - L_xy) / 2.
  if (c.velocity_gradient.size() != 9) {
    std::fprintf(stderr, "rotation_classes: the case needs initial.velocity_gradient (a spin about z)\n");
    return 2;
  }
  const double omega = 0.5 * (c.velocity_gradient[3] - c.velocity_gradient[1]);
  auto report = [&](std::int64_t s) {
    double cx = 0, cy = 0, m = 0;
    for (std::size_t i = 0; i < n; ++i) { m += r.mass[i]; cx += r.mass[i] * r.position[0][i]; cy += r.mass[i] * r.position[1][i]; }
    cx /= m; cy /= m;
    double L[4] = {0, 0, 0, 0}, Lr[4] = {0, 0, 0, 0}, vz[4] = {0, 0, 0, 0}, vr[4] = {0, 0, 0, 0}, cnt[4] = {0, 0, 0, 0};
    for (std::size_t i = 0; i < n; ++i) {
      const double x = r.position[0][i] - cx, y = r.position[1][i] - cy;
      const double l = r.mass[i] * (x * r.velocity[1][i] - y * r.velocity[0][i]);
      L[cls[i]] += l;
      Lr[cls[i]] += r.mass[i] * omega * (x * x + y * y);
      const double rr = std::sqrt(x * x + y * y) + 1e-30;
      vr[cls[i]] += (x * r.velocity[0][i] + y * r.velocity[1][i]) / rr;
      vz[cls[i]] += std::abs(r.velocity[2][i]);
      cnt[cls[i]] += 1;
    }
    std::printf("%5lld t=%.4f", (long long)s, solver.time());
    for (int k = 0; k < 4; ++k)
      std::printf(" | c%d L/Lrigid %.4f vr %+.2e |vz| %.2e", k, L[k] / Lr[k], vr[k] / cnt[k], vz[k] / cnt[k]);
    std::printf("\n");
  };
  report(0);
  double torque[4] = {0, 0, 0, 0}, by_row[4] = {0, 0, 0, 0}, by_kind[4] = {0, 0, 0, 0}, l0 = 0;
  for (std::size_t i = 0; i < n; ++i) l0 += r.mass[i] * omega * (r.position[0][i] * r.position[0][i] + r.position[1][i] * r.position[1][i]);
  std::vector<double> x0[3], v0[3];
  for (std::int64_t s = 0; s < run.steps; ++s) {
    for (int d = 0; d < 3; ++d) { x0[d] = r.position[d]; v0[d] = r.velocity[d]; }
    solver.step(dt);
    for (std::size_t i = 0; i < n; ++i) {  // the torque of the velocity update about the midpoint position (z axis through 0)
      const double xm = x0[0][i] + 0.5 * dt * v0[0][i], ym = x0[1][i] + 0.5 * dt * v0[1][i];
      const double tq = r.mass[i] * (xm * (r.velocity[1][i] - v0[1][i]) - ym * (r.velocity[0][i] - v0[0][i]));
      torque[cls[i]] += tq;
      by_row[row[i]] += tq;
      by_kind[kind[i]] += tq;
    }
    if (std::getenv("DIAG_PROBE")) {  // one particle's velocity against the rigid one (the initial omega)
      const std::size_t q = static_cast<std::size_t>(std::atoi(std::getenv("DIAG_PROBE")));
      const double x = r.position[0][q], y = r.position[1][q];
      std::printf("probe %zu step %lld X (%.2f %.2f %.2f) v - rigid (%+.3e %+.3e %+.3e) |v|/(omega r) %.5f stress", q, (long long)(s + 1),
                  r.initial_position[0][q], r.initial_position[1][q], r.initial_position[2][q], r.velocity[0][q] + omega * y,
                  r.velocity[1][q] - omega * x, r.velocity[2][q],
                  std::hypot(r.velocity[0][q], r.velocity[1][q]) / (omega * std::hypot(x, y)));
      for (int m = 0; m < 6; ++m) std::printf(" %+.2e", r.stress[m][q]);
      std::printf("\n");
    }
    if ((s + 1) % run.every == 0) {
      report(s + 1);
      std::printf("      torque by class / L0 (cumulative): %+.4e %+.4e %+.4e %+.4e\n", torque[0] / l0, torque[1] / l0, torque[2] / l0, torque[3] / l0);
      std::printf("      by row (0 1 2 >=3): %+.4e %+.4e %+.4e %+.4e   by surface (none, z faces, x/y faces, both): %+.4e %+.4e %+.4e %+.4e\n",
                  by_row[0] / l0, by_row[1] / l0, by_row[2] / l0, by_row[3] / l0, by_kind[0] / l0, by_kind[1] / l0, by_kind[2] / l0, by_kind[3] / l0);
    }
  }
}
