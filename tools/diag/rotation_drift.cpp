// Diagnostic (docs/notes/2026-11-26-rotation-drift.md): the free rotating 2D block
// step by step, the change of the angular momentum split into the torque of the velocity
// update (bulk and boundary particles) and the motion term m dx x v^{n+1}.
//   rotation_drift CASE.toml [override...]   (env DIAG_EVERY: print every N steps)
#include "tools/diag/diagnostic_run.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using namespace tsph;

int main(int argc, char** argv) {
  DiagnosticRun<2> run(argc, argv, 50);
  const CaseFile& c = run.c;
  TaylorSph<2>& solver = run.solver;
  const double dt = run.dt;
  const std::int64_t steps = run.steps;
  const int every = run.every;
  const auto& r = solver.real();
  const std::size_t n = r.size();
  auto centre = [&]() {
    double m = 0, cx = 0, cy = 0;
    for (std::size_t i = 0; i < n; ++i) { m += r.mass[i]; cx += r.mass[i] * r.position[0][i]; cy += r.mass[i] * r.position[1][i]; }
    return std::pair<double, double>(cx / m, cy / m);
  };
  auto momentum = [&](std::pair<double, double> cc) {
    double l = 0;
    for (std::size_t i = 0; i < n; ++i)
      l += r.mass[i] * ((r.position[0][i] - cc.first) * r.velocity[1][i] - (r.position[1][i] - cc.second) * r.velocity[0][i]);
    return l;
  };
  auto kinetic = [&]() {
    double e = 0;
    for (std::size_t i = 0; i < n; ++i) e += 0.5 * r.mass[i] * (r.velocity[0][i] * r.velocity[0][i] + r.velocity[1][i] * r.velocity[1][i]);
    return e;
  };
  const double l0 = momentum(centre()), e0 = kinetic();
  double sum_bulk = 0, sum_bnd = 0, sum_kin = 0, sum_at_n = 0;
  double by_layer[4] = {0, 0, 0, 0};  // torque by row from the surface: 0 (surface), 1, 2, >= 3
  const double spacing = c.spacing;
  std::printf("# dt %.6g steps %lld n %zu boundary %zu\n# step t L/L0-1 torque_bulk torque_bnd motion (cumulative, /L0) KE/KE0-1 angle_lag\n", dt,
              (long long)steps, n, solver.boundary_particles().size());
  std::vector<double> x0[2], v0[2];
  const std::size_t probe = 0;  // the angle of particle 0 (a corner) about the centre
  const double a0 = std::atan2(r.position[1][probe], r.position[0][probe]);
  for (std::int64_t s = 0; s < steps; ++s) {
    const auto cc = centre();
    for (int d = 0; d < 2; ++d) { x0[d] = r.position[d]; v0[d] = r.velocity[d]; }
    solver.step(dt);
    const auto& slot = solver.state().boundary.slot;
    for (std::size_t i = 0; i < n; ++i) {
      const double dx = r.position[0][i] - x0[0][i], dy = r.position[1][i] - x0[1][i];
      const double dvx = r.velocity[0][i] - v0[0][i], dvy = r.velocity[1][i] - v0[1][i];
      // d(x v) = xp x dv + [dx x v^{n+1} - dt/2 v^n x dv] exactly, xp = x^n + dt/2 v^n the
      // predictor at which the full step evaluates the force: the torque, then the motion term.
      const double xm = x0[0][i] + 0.5 * dt * v0[0][i] - cc.first, ym = x0[1][i] + 0.5 * dt * v0[1][i] - cc.second;
      const double torque = r.mass[i] * (xm * dvy - ym * dvx);
      (slot[i] >= 0 ? sum_bnd : sum_bulk) += torque;
      {
        const double X = r.initial_position[0][i], Y = r.initial_position[1][i];
        const double depth = std::min(c.box_upper[0] - X, std::min(X - c.box_lower[0], std::min(c.box_upper[1] - Y, Y - c.box_lower[1])));
        by_layer[std::min(3, static_cast<int>(std::lround(depth / spacing)))] += torque;
      }
      sum_at_n += r.mass[i] * ((x0[0][i] - cc.first) * dvy - (x0[1][i] - cc.second) * dvx);
      sum_kin += r.mass[i] * (dx * r.velocity[1][i] - dy * r.velocity[0][i] - 0.5 * dt * (v0[0][i] * dvy - v0[1][i] * dvx));
    }
    if ((s + 1) % every == 0 || s + 1 == steps) {
      const double t = solver.time();
      const double a = std::atan2(r.position[1][probe] - centre().second, r.position[0][probe] - centre().first);
      std::printf("%lld %.5f %+.4e %+.4e %+.4e %+.4e %+.4e %+.4e torque_at_xn %+.4e\n", (long long)(s + 1), t, momentum(centre()) / l0 - 1,
                  sum_bulk / l0, sum_bnd / l0, sum_kin / l0, kinetic() / e0 - 1,
                  std::remainder(2.0 * t - (a - a0), 2 * M_PI), sum_at_n / l0);
    }
  }
  std::printf("# torque by row from the surface (0 = surface, 1, 2, >= 3), / L0: %+.4e %+.4e %+.4e %+.4e\n", by_layer[0] / l0,
              by_layer[1] / l0, by_layer[2] / l0, by_layer[3] / l0);
}
