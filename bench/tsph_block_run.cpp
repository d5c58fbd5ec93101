// Runs a few steps of the benchmark block (bench/block_case.hpp) and prints what they
// cost: the driver of the memory measurements (/usr/bin/time -v) and of the CI timing
// workload (tools/check_timing.py, under callgrind).
//
//   tsph-block-run --dim 2 --particles 10000000 --steps 3 [--threads 2] [--alpha 1.2]
//                  [--small-strain] [--order none|shuffled|cells|morton]
//                  [--search auto|cell_list|kd_tree] [--transpose]
//                  [--solver-order none|cells|morton] [--skin S (default 0.05; 0: none)]
//                  [--kernel reference|current (default reference: the skin does not apply)]
#include "bench/block_case.hpp"
#include "engine/memory_estimate.hpp"
#include "engine/parallel.hpp"
#include "neighbor/spatial_order.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <random>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include <sys/resource.h>

namespace {

using namespace tsph;

struct Options {
  int dim = 2;
  std::int64_t particles = 10'000;
  int steps = 3;
  int threads = 0;
  double alpha = 1.2;
  Kinematics kinematics = Kinematics::updated_lagrangian;
  /// none: lattice order (axis 0 fastest); shuffled: a random order (what locality is
  /// worth); cells / morton: shuffled, then sorted by cell, row by row or along the Z
  /// curve (neighbor/spatial_order.hpp).
  std::string order = "none";
  NeighborSearch search = NeighborSearch::automatic;
  bool transpose_lists = false;  ///< SolverSettings::transpose_lists
  /// SolverSettings::spatial_order: the solver sorts the sets when their order decays.
  SpatialOrder solver_order = SpatialOrder::none;
  double skin = 0.05;  ///< SolverSettings::neighbor_skin (fraction of 2h; its default; 0: none)
  /// SolverSettings::kernel_configuration (updated Lagrangian): reference, the default (the
  /// lists of X, searched once: the skin does not apply), or current (the lists follow
  /// the particles: searched again when the skin is used up, or at every step without).
  std::string kernel = "reference";
  /// material.model (issue 16): elastic, j2 (yield stress `yield`) or drucker_prager
  /// (cohesion `yield`, phi 20, psi 10); the default yield of 1 Pa makes every particle
  /// yield at every step (the plastic step's full cost), 1e30 none.
  std::string model = "elastic";
  double yield = 1.0;
};

[[noreturn]] void usage_error(const std::string& message) {
  std::fprintf(stderr, "tsph-block-run: error: %s\n", message.c_str());
  std::fprintf(stderr,
               "usage: tsph-block-run [--dim 2|3] [--particles N] [--steps K] [--threads T] "
               "[--alpha A] [--small-strain] [--order none|shuffled|cells|morton] "
               "[--search auto|cell_list|kd_tree] [--transpose] [--solver-order none|cells|morton] "
               "[--skin S] [--kernel reference|current] [--model elastic|j2|drucker_prager] [--yield Y]\n");
  std::exit(2);
}

/// Peak resident memory of this process in bytes (getrusage's ru_maxrss, in KiB on
/// Linux; 0 where it cannot be read).
double peak_resident_bytes() {
  struct rusage usage {};
  return ::getrusage(RUSAGE_SELF, &usage) == 0 ? 1024.0 * static_cast<double>(usage.ru_maxrss) : 0.0;
}

/// The timed part, one function so that callgrind can count it alone
/// (--toggle-collect='*run_steps*', tools/check_timing.py).
template <int Dim>
[[gnu::noinline]] void run_steps(TaylorSph<Dim>& solver, double dt, int steps) {
  for (int k = 0; k < steps; ++k) solver.step(dt);
}

template <int Dim>
int run(const Options& o) {
  const auto box = bench::block_box<Dim>(o.particles);
  const auto real_count = static_cast<std::size_t>(box.total_nodes());
  const bool moving = o.kinematics == Kinematics::updated_lagrangian;
  const double skin = moving ? o.skin : 0.0;
  const bool reference_lists = moving && o.kernel == "reference";
  // A plastic model: its fields, and (an upper bound: J2 takes it, the 20-degree
  // Drucker-Prager here does not) the volumetric average's stencils.
  const bool plastic = o.model != "elastic";
  const double estimate = estimate_bytes_per_real_particle<Dim>(
      o.alpha, {.transposed_lists = o.transpose_lists, .skin = skin, .reference_lists = reference_lists,
                .plastic_fields = plastic, .volumetric_average = plastic});
  try {
    check_memory_budget(estimate, real_count,
                        available_memory_bytes());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tsph-block-run: error: %s\n", e.what());
    return 2;
  }
  const auto start = std::chrono::steady_clock::now();
  auto reorder = [&o](ParticleSet<Dim>& set, double radius) {
    if (o.order == "none") return;
    std::vector<std::uint32_t> order(set.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<std::uint32_t>(i);
    std::shuffle(order.begin(), order.end(), std::mt19937_64(12345));
    set.permute(order);
    // Cells of a quarter of the support radius (0.6 dx at alpha 1.2): at most one
    // lattice particle per cell, so a lattice gets back its row order.
    if (o.order == "cells") set.permute(cell_order<Dim>(points_of<Dim>(set), 0.25 * radius));
    if (o.order == "morton") set.permute(morton_order<Dim>(points_of<Dim>(set), 0.25 * radius));
  };
  auto configure = [&o](SolverSettings<Dim>& settings) {
    settings.neighbor_search = o.search;
    settings.transpose_lists = o.transpose_lists;
    settings.spatial_order = o.solver_order;
    settings.neighbor_skin = o.skin;
    settings.kernel_configuration = o.kernel == "current" ? SolverSettings<Dim>::KernelConfiguration::current
                                                          : SolverSettings<Dim>::KernelConfiguration::reference;
  };
  const std::string material_keys =
      o.model == "j2" ? fmt::format("model = \"j2\"\nyield_stress = {:.17g}\n", o.yield)
      : o.model == "drucker_prager"
          ? fmt::format("model = \"drucker_prager\"\ncohesion = {:.17g}\nfriction_angle = 20\ndilation_angle = 10\n", o.yield)
          : std::string();
  auto solver = bench::make_block<Dim>(o.particles, o.alpha, o.kinematics, reorder, configure, material_keys);
  const auto built = std::chrono::steady_clock::now();
  const double dt = bench::block_time_step(solver, o.alpha);
  run_steps(solver, dt, o.steps);
  const auto end = std::chrono::steady_clock::now();
  const double setup_s = std::chrono::duration<double>(built - start).count();
  const double steps_s = std::chrono::duration<double>(end - built).count();
  std::printf("material %s\n", solver.material().name());
  std::printf("dim %d, real %zu, virtual %zu, pairs virtual<-real %zu, "
              "threads %d, search %s, reorders %lld, skin %g, list builds %lld in %d steps\n",
              Dim, solver.real().size(), solver.virtual_particles().size(),
              solver.virtual_from_real().pair_count(),
              thread_count(), std::string(to_string(solver.neighbor_search_used())).c_str(),
              static_cast<long long>(solver.counters().reorders), skin,
              static_cast<long long>(solver.counters().neighbor_builds), o.steps);
  std::printf("setup %.3f s, %d steps %.3f s, %.3f M real-particle-steps/s, estimate %.0f B "
              "per real particle, kinetic energy %.9e\n",
              setup_s, o.steps, steps_s,
              o.steps > 0 ? 1e-6 * static_cast<double>(real_count) * o.steps / steps_s : 0.0,
              estimate, solver.kinetic_energy());
  // Peak resident memory of the whole process, setup included.
  if (const double peak = peak_resident_bytes(); peak > 0.0)
    std::printf("peak RSS %.3f GiB, %.0f B per real particle\n", peak / 1073741824.0,
                peak / static_cast<double>(real_count));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int a = 1; a < argc; ++a) {
    const std::string key = argv[a];
    if (key == "--order") {
      if (a + 1 >= argc) usage_error("option --order needs a value");
      o.order = argv[++a];
      if (o.order != "none" && o.order != "shuffled" && o.order != "cells" && o.order != "morton")
        usage_error("order = '" + o.order + "' is invalid: must be one of: none, shuffled, cells, morton");
      continue;
    }
    if (key == "--search" || key == "--solver-order") {
      if (a + 1 >= argc) usage_error("option " + key + " needs a value");
      const std::string value = argv[++a];
      if (key == "--search") {
        const auto search = parse_neighbor_search(value);
        if (!search) usage_error("search = '" + value + "' is invalid: must be one of: auto, cell_list, kd_tree");
        o.search = *search;
      } else {
        if (value != "none" && value != "cells" && value != "morton")
          usage_error("solver-order = '" + value + "' is invalid: must be one of: none, cells, morton");
        o.solver_order = value == "none" ? SpatialOrder::none : value == "cells" ? SpatialOrder::cells : SpatialOrder::morton;
      }
      continue;
    }
    if (key == "--model") {
      if (a + 1 >= argc) usage_error("option --model needs a value");
      o.model = argv[++a];
      if (o.model != "elastic" && o.model != "j2" && o.model != "drucker_prager")
        usage_error("model = '" + o.model + "' is invalid: must be one of: elastic, j2, drucker_prager");
      continue;
    }
    if (key == "--kernel") {
      if (a + 1 >= argc) usage_error("option --kernel needs a value");
      o.kernel = argv[++a];
      if (o.kernel != "reference" && o.kernel != "current")
        usage_error("kernel = '" + o.kernel + "' is invalid: must be one of: reference, current");
      continue;
    }
    if (key == "--transpose") {
      o.transpose_lists = true;
      continue;
    }
    if (key == "--small-strain") {
      o.kinematics = Kinematics::small_strain;
      continue;
    }
    if (a + 1 >= argc) usage_error("option " + key + " needs a value");
    const std::string value = argv[++a];
    char* end = nullptr;
    const double number = std::strtod(value.c_str(), &end);
    if (end == value.c_str() || *end != '\0' || !std::isfinite(number))
      usage_error(key + " = '" + value + "' is not a number");
    if (key == "--dim") {
      if (number != 2.0 && number != 3.0) usage_error("dim = " + value + " is invalid: must be 2 or 3");
      o.dim = static_cast<int>(number);
    } else if (key == "--particles") {
      if (!(number >= 8.0 && number <= 4e9)) usage_error("particles = " + value + " is invalid: must lie in [8, 4e9]");
      o.particles = static_cast<std::int64_t>(number);
    } else if (key == "--steps") {
      if (!(number >= 0.0 && number <= 1e6)) usage_error("steps = " + value + " is invalid: must lie in [0, 1e6]");
      o.steps = static_cast<int>(number);
    } else if (key == "--skin") {
      if (!(number >= 0.0 && number <= 1.0)) usage_error("skin = " + value + " is invalid: must lie in [0, 1] (a fraction of the support radius 2h)");
      o.skin = number;
    } else if (key == "--threads") {
      if (!(number >= 1.0 && number <= 1024.0)) usage_error("threads = " + value + " is invalid: must lie in [1, 1024]");
      o.threads = static_cast<int>(number);
    } else if (key == "--yield") {
      if (!(number > 0.0)) usage_error("yield = " + value + " is invalid: must be positive (Pa)");
      o.yield = number;
    } else if (key == "--alpha") {
      o.alpha = number;  // its range is the case file's method.alpha (checked where the block is built)
    } else {
      usage_error("unknown option " + key);
    }
  }
  set_thread_count(o.threads);
  try {
    return o.dim == 2 ? run<2>(o) : run<3>(o);
  } catch (const CaseError& e) {  // the block's case refused (method.alpha out of range)
    for (const auto& m : e.messages()) std::fprintf(stderr, "tsph-block-run: error: %s\n", m.c_str());
    return 2;
  }
}
