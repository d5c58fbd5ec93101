// The memory estimate (engine/memory_estimate.hpp) and the refusal of a particle count
// that cannot fit, before anything is allocated; the updated-Lagrangian stepper holds
// one half-step list at a time and it is the list of the current positions.
#include "bench/block_case.hpp"
#include "engine/memory_estimate.hpp"
#include "neighbor/brute_force.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace tsph {
namespace {

TEST(MemoryEstimate, CountsSetsListsAndCellList) {
  // 2D: two sets of 15 doubles + 3 int32 (264 B), v^n 16 B, one list of pi 2.4^2 pairs
  // (8 + 4 x 18.1 = 80.4 B), boundary offsets 8 B, cell list 24 B.
  EXPECT_NEAR(estimate_bytes_per_real_particle<2>(1.2), 264.0 + 16.0 + 80.38 + 8.0 + 24.0, 0.1);
  // 3D: two sets of 21 doubles + 3 int32 (360 B), 24 B, 8 + 4 x 57.9 B, 8 B, 32 B.
  EXPECT_NEAR(estimate_bytes_per_real_particle<3>(1.2), 360.0 + 24.0 + 239.6 + 8.0 + 32.0, 0.2);
  // More neighbours, more memory.
  EXPECT_GT(estimate_bytes_per_real_particle<3>(1.6), estimate_bytes_per_real_particle<3>(1.2));
  // Transposed lists: two lists (8 B offsets + 4 B per pair each) instead of one and the cell list.
  EXPECT_NEAR(estimate_bytes_per_real_particle<2>(1.2, true), 264.0 + 16.0 + 2.0 * 80.38 + 8.0, 0.2);
  // A skin of 10 % of 2h: two lists of 1.1^2 the pairs (8 + 4 x 21.9 B each); no stored
  // positions (path bounds), no cell list at the peak.
  EXPECT_NEAR(estimate_bytes_per_real_particle<2>(1.2, false, 0.1),
              264.0 + 16.0 + 2.0 * (8.0 + 4.0 * 1.21 * 18.096) + 8.0, 0.2);
  for (double bad : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN()})
    EXPECT_THROW(estimate_bytes_per_real_particle<2>(bad), std::invalid_argument);
  EXPECT_THROW(estimate_bytes_per_real_particle<2>(1.2, false, -0.1), std::invalid_argument);
}

TEST(MemoryEstimate, RefusesACountThatDoesNotFitWithTheEstimateAndTheLimit) {
  const double per_particle = 400.0;
  const std::size_t limit = std::size_t{4} << 30;  // 4 GiB
  EXPECT_NO_THROW(check_memory_budget(per_particle, 10'000'000, limit));  // 3.7 GiB
  try {
    check_memory_budget(per_particle, 20'000'000, limit);  // 7.5 GiB
    FAIL() << "20e6 particles at 400 B should not fit in 4 GiB";
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("particles = 20000000"), std::string::npos) << message;
    EXPECT_NE(message.find("7.5 GiB"), std::string::npos) << message;
    EXPECT_NE(message.find("4.0 GiB are available"), std::string::npos) << message;
    EXPECT_NE(message.find("at most 10737418 particles"), std::string::npos) << message;
  }
  EXPECT_NO_THROW(check_memory_budget(per_particle, 20'000'000, 0));  // limit unknown
  EXPECT_GT(available_memory_bytes(), std::size_t{0});  // /proc/meminfo on Linux
}

TEST(MemoryEstimate, UpdatedLagrangianHoldsOneCurrentHalfStepList) {
  auto solver = bench::make_block<2>(900, 1.2);
  const double dt = bench::block_time_step(solver, 1.2);
  for (int k = 0; k < 3; ++k) solver.step(dt);
  EXPECT_EQ(solver.real_from_virtual().pair_count(), 0u);  // released until the full step
  const auto& real = solver.real();
  const auto& virtual_particles = solver.virtual_particles();
  const NeighborList expected = brute_force_neighbors<2>(
      points_of<2>(virtual_particles), points_of<2>(real), solver.support_radius());
  EXPECT_TRUE(solver.virtual_from_real() == expected);  // built at the moved positions
  EXPECT_GT(expected.pair_count(), 10 * virtual_particles.size());
}

}  // namespace
}  // namespace tsph
