// Taylor-SPH in 2D and 3D (bench/block_case.hpp: a block held at one end, updated
// Lagrangian, alpha = 1.2 unless said), in real-particle-steps per second, real time:
//   Step    the whole step as run by default: boundary pre-pass, half step, full step,
//           boundary conditions, move, normals; the kernel in the reference
//           configuration (SolverSettings::kernel_configuration, the default since
//           2026-11-29: the lists of X, searched once);
//   StepCurrent  the whole step with the kernel in the current configuration and the
//           Verlet skin (0.05 of 2h): the neighbour rebuild (cell list) when the skin no
//           longer covers the motion (Step before 2026-11-29);
//   StepNoSkin  the current kernel without skin (two searches per step);
//   Half    seed eq. (3) alone (real -> virtual), lists kept (small strain);
//   Full    seed eq. (4) alone (virtual -> real), lists kept (small strain);
//   Rebuild all three neighbour lists and the boundary normals alone;
//   StepTransposed  the current kernel without skin, with SolverSettings::transpose_lists
//           (the full step's list transposed from the half step's instead of searched).
//   StepSkin<P>  the current kernel with a Verlet skin of P % of 2h
//           (SolverSettings::neighbor_skin; counter steps_per_build).
// Arguments: particles, threads.
#include "bench/block_case.hpp"
#include "bench/thread_axis.hpp"
#include "engine/parallel.hpp"

#include <benchmark/benchmark.h>

namespace {

using namespace tsph;
constexpr double kAlpha = 1.2;

enum class Stage { step, half, full, rebuild };

template <int Dim, Stage stage, bool transposed = false, int skin_percent = 5, bool current = false>
void BM_Stage(benchmark::State& state) {
  const int before = thread_count();
  set_thread_count(static_cast<int>(state.range(1)));
  // The stages alone run in small strain, where the lists are built once and kept;
  // the whole step runs updated Lagrangian.
  auto solver = bench::make_block<Dim>(
      state.range(0), kAlpha,
      stage == Stage::step ? Kinematics::updated_lagrangian : Kinematics::small_strain,
      [](ParticleSet<Dim>&, double) {},
      [](SolverSettings<Dim>& settings) {
        settings.transpose_lists = transposed;
        settings.neighbor_skin = 0.01 * skin_percent;
        if (current) settings.kernel_configuration = SolverSettings<Dim>::KernelConfiguration::current;
      });
  const std::int64_t builds_before = solver.counters().neighbor_builds;
  const double dt = bench::block_time_step(solver, kAlpha);
  for (auto _ : state) {
    if constexpr (stage == Stage::step) solver.step(dt);
    else if constexpr (stage == Stage::half) solver.half_step(dt);
    else if constexpr (stage == Stage::full) solver.full_step(dt);
    else solver.rebuild_neighbors();
  }
  const auto real_count = static_cast<std::int64_t>(solver.real().size());
  state.SetItemsProcessed(state.iterations() * real_count);
  state.counters["real"] = static_cast<double>(real_count);
  state.counters["threads"] = static_cast<double>(state.range(1));
  state.counters["pairs_per_virtual"] =
      static_cast<double>(solver.virtual_from_real().pair_count()) /
      static_cast<double>(solver.virtual_particles().size());
  if constexpr (stage == Stage::step)
    state.counters["steps_per_build"] =
        static_cast<double>(state.iterations()) /
        static_cast<double>(std::max<std::int64_t>(1, solver.counters().neighbor_builds - builds_before));
  set_thread_count(before);
}

void sizes_2d(benchmark::internal::Benchmark* b) {
  b->ArgNames({"particles", "threads"})
      ->ArgsProduct({{10'000, 100'000, 1'000'000, 10'000'000}, bench::thread_axis()})
      ->UseRealTime()
      ->Unit(benchmark::kMillisecond);
}
void sizes_3d(benchmark::internal::Benchmark* b) {
  b->ArgNames({"particles", "threads"})
      ->ArgsProduct({{10'000, 100'000, 1'000'000}, bench::thread_axis()})
      ->UseRealTime()
      ->Unit(benchmark::kMillisecond);
}

BENCHMARK(BM_Stage<2, Stage::step>)->Name("Step2D")->Apply(sizes_2d);
BENCHMARK(BM_Stage<2, Stage::step, false, 5, true>)->Name("StepCurrent2D")->Apply(sizes_2d);
BENCHMARK(BM_Stage<2, Stage::half>)->Name("Half2D")->Apply(sizes_2d);
BENCHMARK(BM_Stage<2, Stage::full>)->Name("Full2D")->Apply(sizes_2d);
BENCHMARK(BM_Stage<2, Stage::rebuild>)->Name("Rebuild2D")->Apply(sizes_2d);
BENCHMARK(BM_Stage<2, Stage::step, true, 0, true>)->Name("StepTransposed2D")->Apply(sizes_2d);
BENCHMARK(BM_Stage<2, Stage::step, false, 0, true>)->Name("StepNoSkin2D")->Apply(sizes_2d);
BENCHMARK(BM_Stage<2, Stage::step, false, 10, true>)->Name("StepSkin10_2D")->Apply(sizes_2d);
BENCHMARK(BM_Stage<2, Stage::step, false, 20, true>)->Name("StepSkin20_2D")->Apply(sizes_2d);
BENCHMARK(BM_Stage<3, Stage::step>)->Name("Step3D")->Apply(sizes_3d);
BENCHMARK(BM_Stage<3, Stage::step, false, 5, true>)->Name("StepCurrent3D")->Apply(sizes_3d);
BENCHMARK(BM_Stage<3, Stage::step, false, 0, true>)->Name("StepNoSkin3D")->Apply(sizes_3d);
BENCHMARK(BM_Stage<3, Stage::step, false, 10, true>)->Name("StepSkin10_3D")->Apply(sizes_3d);
BENCHMARK(BM_Stage<3, Stage::step, true, 0, true>)->Name("StepTransposed3D")->Apply(sizes_3d);
BENCHMARK(BM_Stage<3, Stage::half>)->Name("Half3D")->Apply(sizes_3d);
BENCHMARK(BM_Stage<3, Stage::full>)->Name("Full3D")->Apply(sizes_3d);
BENCHMARK(BM_Stage<3, Stage::rebuild>)->Name("Rebuild3D")->Apply(sizes_3d);

}  // namespace

BENCHMARK_MAIN();
