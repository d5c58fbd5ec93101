// The one-step map of a 1D bar (docs/notes/2026-12-06-alpha12-boundary-energy.md):
// `tsph spectrum` reads modes on a 2D or 3D lattice only, so this small program builds the
// bar of tests/test_step_map.cpp (L = 1 m, E = 8e7 Pa, rho = 2000 kg/m^3) with either end
// free or fixed and writes G (column-major float64) and its unknowns.
//   c++ -DFMT_SHARED -I. -isystem /usr/include/eigen3 -O2 -fopenmp -std=gnu++20 -Wno-psabi \
//       -o /tmp/barmap docs/notes/2026-12-06-bar-step-map.cpp engine/taylor_sph_1d.cpp engine/particle_file.cpp -lfmt
//   /tmp/barmap N ALPHA CFL free|fixed free|fixed map.bin
// (numpy: G = np.fromfile("map.bin").reshape(n, n).T; max |eig(G)| - 1 is the growth per step.)
#include "engine/lattice.hpp"
#include "engine/analysis/step_map.hpp"
#include <cstdio>
#include <cstdlib>
#include <string>
using namespace tsph;
int main(int argc, char** argv) {
  int particles = std::atoi(argv[1]);
  double alpha = std::atof(argv[2]), cfl = std::atof(argv[3]);
  std::string left = argv[4], right = argv[5];
  const char* out = argv[6];
  const double dx = 1.0 / (particles - 1), density = 2000.0, young = 8e7;
  LatticeBox<1> box;
  box.lower[0] = 0.0;
  box.node_count = {particles};
  box.spacing = dx;
  ParticleSet<1> real = make_real_lattice(box, density);
  ParticleSet<1> virtual_particles = make_virtual_lattice(box, density);
  auto bc = [](const std::string& k, const char* name) {
    return k == "free" ? BoundaryCondition<1>::free(name) : BoundaryCondition<1>::fixed(name);
  };
  std::vector<BoundaryCondition<1>> boundaries{bc(left, "left"), bc(right, "right")};
  real.boundary.front() = 0;
  real.boundary.back() = 1;
  SolverSettings<1> settings;
  settings.smoothing_length = alpha * dx;
  TaylorSph<1> solver(std::move(real), std::move(virtual_particles), LinearElastic<1>(young, 0.0, density), settings, boundaries);
  const double dt = cfl * dx / std::sqrt(young / density);
  const auto layout = step_map_layout(solver, dt);
  Eigen::MatrixXd map = assemble_step_map(solver, layout, 0.0, dt);
  FILE* f = std::fopen(out, "wb");
  std::fwrite(map.data(), sizeof(double), map.size(), f);  // column-major
  std::fclose(f);
  std::printf("%ld unknowns\n", (long)map.rows());
  for (auto& u : layout.unknowns) std::printf("%u %d\n", u.particle, (int)u.field);
}
