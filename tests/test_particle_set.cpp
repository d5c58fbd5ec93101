// Particle storage (engine/particle_set.hpp) and lattices (engine/lattice.hpp), in 1, 2
// and 3 dimensions: resize numbers the particles, permute moves every field together,
// view() exposes the vectors, and the real and virtual lattices have the documented
// positions and trapezoidal / cell volumes.
#include "engine/lattice.hpp"
#include "engine/particle_set.hpp"

#include <gtest/gtest.h>

#include "tests/typed_dimensions.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace tsph {
namespace {

template <class DimConstant>
class ParticleSetTest : public ::testing::Test {};

using tsph::testing::Dimensions;
using tsph::testing::DimName;
TYPED_TEST_SUITE(ParticleSetTest, Dimensions, DimName);

/// Number of per-particle arrays: position, initial_position, velocity, displacement
/// (Dim each), stress, then mass, density, volume, id, boundary, group. A new field must
/// be added here and to expect_same_particle.
template <int Dim>
constexpr int kFieldCount = 4 * Dim + stress_component_count<Dim> + 6 + stress_component_count<Dim> + 4 +
                            Dim;  // the plastic fields: back stress, four more and the hourglass reference

/// A value that identifies (particle id, field number); exact in both double and int.
double tag(std::uint32_t id, int field) { return 1000.0 * field + id + 1.0; }
/// The tag as a field of type T holds it: a byte field (the yield flag) keeps its low
/// 8 bits (converting a double above 255 to a byte would be undefined behaviour).
template <class T>
T tag_as(std::uint32_t id, int field) {
  if constexpr (std::is_same_v<T, std::uint8_t>) return static_cast<T>(static_cast<std::uint32_t>(tag(id, field)) & 0xffu);
  else return static_cast<T>(tag(id, field));
}

/// Fills every field of particle i with tag(id[i], field number); ids stay as they are.
template <int Dim>
int fill_with_tags(ParticleSet<Dim>& set) {
  const std::vector<std::uint32_t> ids = set.id;
  int field = 0;
  set.for_each_field([&](auto& values) {
    using T = typename std::decay_t<decltype(values)>::value_type;
    if constexpr (!std::is_same_v<T, std::uint32_t>)  // the id field keeps the ids
      for (std::size_t i = 0; i < values.size(); ++i)
        values[i] = tag_as<T>(ids[i], field);
    ++field;
  });
  return field;
}

/// Every named member of particle p of `a` equals that of particle q of `b`.
template <int Dim>
void expect_same_particle(const ParticleSet<Dim>& a, std::size_t p, const ParticleSet<Dim>& b,
                          std::size_t q) {
  SCOPED_TRACE("particle " + std::to_string(p) + " vs " + std::to_string(q));
  for (int d = 0; d < Dim; ++d) {
    EXPECT_EQ(a.position[d][p], b.position[d][q]);
    EXPECT_EQ(a.initial_position[d][p], b.initial_position[d][q]);
    EXPECT_EQ(a.velocity[d][p], b.velocity[d][q]);
    EXPECT_EQ(a.displacement[d][p], b.displacement[d][q]);
  }
  for (int s = 0; s < ParticleSet<Dim>::stress_count; ++s)
    EXPECT_EQ(a.stress[s][p], b.stress[s][q]);
  EXPECT_EQ(a.mass[p], b.mass[q]);
  EXPECT_EQ(a.density[p], b.density[q]);
  EXPECT_EQ(a.volume[p], b.volume[q]);
  EXPECT_EQ(a.id[p], b.id[q]);
  EXPECT_EQ(a.boundary[p], b.boundary[q]);
  EXPECT_EQ(a.group[p], b.group[q]);
  if (a.carries_plastic_fields()) {
    EXPECT_EQ(a.plastic_strain[p], b.plastic_strain[q]);
    EXPECT_EQ(a.plastic_work[p], b.plastic_work[q]);
    EXPECT_EQ(a.temperature[p], b.temperature[q]);
    for (int s = 0; s < ParticleSet<Dim>::stress_count; ++s) EXPECT_EQ(a.back_stress[s][p], b.back_stress[s][q]);
    EXPECT_EQ(a.yielding[p], b.yielding[q]);
    for (int d = 0; d < Dim; ++d) EXPECT_EQ(a.hourglass_reference[d][p], b.hourglass_reference[d][q]);
  }
}

// resize numbers new particles 0..n-1, marks them unbounded and zeroes every other field;
// growing keeps the existing particles, shrinking truncates every field.
TYPED_TEST(ParticleSetTest, ResizeNumbersAndZeroesParticles) {
  constexpr int dim = TypeParam::value;
  ParticleSet<dim> set;
  EXPECT_EQ(set.size(), 0u);
  set.resize(5);
  ASSERT_EQ(set.size(), 5u);
  for (std::uint32_t i = 0; i < 5; ++i) {
    EXPECT_EQ(set.id[i], i);
    EXPECT_EQ(set.boundary[i], ParticleSet<dim>::kNoBoundary);
    EXPECT_EQ(set.mass[i], 0.0);
    EXPECT_EQ(set.group[i], 0);
    for (int d = 0; d < dim; ++d) {
      EXPECT_EQ(set.position[d][i], 0.0);
      EXPECT_EQ(set.displacement[d][i], 0.0);
    }
  }
  // The plastic fields are on demand: resize does not create them.
  EXPECT_FALSE(set.carries_plastic_fields());
  EXPECT_TRUE(set.plastic_strain.empty() && set.yielding.empty() && set.back_stress[0].empty());
  set.carry_plastic_fields(293.0);
  EXPECT_EQ(set.temperature[4], 293.0);
  EXPECT_EQ(set.plastic_strain[4], 0.0);
  set.mass[2] = 7.0;
  set.boundary[3] = 1;
  set.resize(9);
  std::size_t fields = 0;
  set.for_each_field([&](auto& values) {
    EXPECT_EQ(values.size(), 9u);
    ++fields;
  });
  EXPECT_EQ(fields, static_cast<std::size_t>(kFieldCount<dim>));
  EXPECT_EQ(set.mass[2], 7.0);
  EXPECT_EQ(set.boundary[3], 1);
  for (std::uint32_t i = 5; i < 9; ++i) {
    EXPECT_EQ(set.id[i], i);
    EXPECT_EQ(set.boundary[i], ParticleSet<dim>::kNoBoundary);
    EXPECT_EQ(set.volume[i], 0.0);
    for (int s = 0; s < ParticleSet<dim>::stress_count; ++s) EXPECT_EQ(set.stress[s][i], 0.0);
  }
  set.resize(3);
  set.for_each_field([](auto& values) { EXPECT_EQ(values.size(), 3u); });
}

// permute moves every field with its particle: after filling each field with a value
// derived from (id, field number) and applying a random permutation, every field of every
// particle still carries its own id. Checked once through for_each_field and once by
// name against a copy, so that a field missing from for_each_field is caught too.
TYPED_TEST(ParticleSetTest, PermuteReordersEveryFieldConsistently) {
  constexpr int dim = TypeParam::value;
  const std::size_t n = 57;
  ParticleSet<dim> set;
  set.resize(n);
  set.carry_plastic_fields(0.0);
  EXPECT_EQ(fill_with_tags(set), kFieldCount<dim>);
  const ParticleSet<dim> before = set;

  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::shuffle(order.begin(), order.end(), std::mt19937_64(99));
  set.permute(order);
  ASSERT_EQ(set.size(), n);

  // Through for_each_field: field f of particle p holds tag(id[p], f).
  for (std::size_t p = 0; p < n; ++p) EXPECT_EQ(set.id[p], order[p]);
  int field = 0;
  set.for_each_field([&](auto& values) {
    using T = typename std::decay_t<decltype(values)>::value_type;
    for (std::size_t p = 0; p < n; ++p)
      if constexpr (!std::is_same_v<T, std::uint32_t>) {
        EXPECT_EQ(values[p], tag_as<T>(set.id[p], field)) << "field " << field;
      }
    ++field;
  });

  // By name: new particle p is old particle order[p] in every member.
  for (std::size_t p = 0; p < n; ++p) expect_same_particle(set, p, before, order[p]);

  // The inverse permutation restores the original set.
  std::vector<std::uint32_t> inverse(n);
  for (std::size_t p = 0; p < n; ++p) inverse[order[p]] = static_cast<std::uint32_t>(p);
  set.permute(inverse);
  for (std::size_t p = 0; p < n; ++p) expect_same_particle(set, p, before, p);
}

// An order of the wrong length, with a duplicate or out of range is rejected, and the
// set is left untouched.
TYPED_TEST(ParticleSetTest, PermuteWithWrongSizeThrows) {
  constexpr int dim = TypeParam::value;
  ParticleSet<dim> set;
  set.resize(4);
  fill_with_tags(set);
  const ParticleSet<dim> before = set;
  EXPECT_THROW(set.permute({0, 1, 2}), std::invalid_argument);
  EXPECT_THROW(set.permute({0, 1, 2, 3, 4}), std::invalid_argument);
  EXPECT_THROW(set.permute({}), std::invalid_argument);
  EXPECT_THROW(set.permute({0, 1, 1, 3}), std::invalid_argument);  // a duplicate would lose particle 2
  EXPECT_THROW(set.permute({0, 1, 2, 4}), std::invalid_argument);  // out of range
  EXPECT_EQ(set.mass, before.mass);
  EXPECT_EQ(set.id, before.id);
  ParticleSet<dim> empty;
  EXPECT_NO_THROW(empty.permute({}));
}

// Released optional fields (release_optional_fields) stay released through permute and
// resize, the other fields move as before, and check_field_sizes accepts a released
// optional field but not a required one of the wrong size.
TYPED_TEST(ParticleSetTest, ReleasedOptionalFieldsStayReleased) {
  constexpr int dim = TypeParam::value;
  const std::size_t n = 23;
  ParticleSet<dim> set;
  set.resize(n);
  fill_with_tags(set);
  const ParticleSet<dim> before = set;
  set.release_optional_fields(true);
  EXPECT_TRUE(set.carries(set.initial_position));
  EXPECT_FALSE(set.carries(set.displacement));
  EXPECT_FALSE(set.carries(set.id));
  EXPECT_TRUE(set.id.empty() && set.boundary.empty() && set.group.empty());
  EXPECT_NO_THROW(set.check_field_sizes("test"));
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::shuffle(order.begin(), order.end(), std::mt19937_64(5));
  set.permute(order);
  for (std::size_t p = 0; p < n; ++p) {
    EXPECT_EQ(set.mass[p], before.mass[order[p]]);
    for (int d = 0; d < dim; ++d) {
      EXPECT_EQ(set.position[d][p], before.position[d][order[p]]);
      EXPECT_EQ(set.initial_position[d][p], before.initial_position[d][order[p]]);
      EXPECT_TRUE(set.displacement[d].empty());
    }
  }
  set.resize(n + 4);
  EXPECT_EQ(set.size(), n + 4);
  EXPECT_TRUE(set.id.empty() && set.boundary.empty() && set.displacement[0].empty());
  EXPECT_EQ(set.initial_position[0].size(), n + 4);
  set.release_optional_fields(false);
  EXPECT_TRUE(set.initial_position[0].empty());
  EXPECT_NO_THROW(set.check_field_sizes("test"));
  set.mass.pop_back();  // a required field short of one value
  EXPECT_THROW(set.check_field_sizes("test"), std::invalid_argument);
  ParticleSet<dim> partial = before;
  partial.id.pop_back();  // an optional field neither whole nor released
  EXPECT_THROW(partial.check_field_sizes("test"), std::invalid_argument);
}

// view() points at the vectors' storage and reports the size.
TYPED_TEST(ParticleSetTest, ViewPointsAtTheFields) {
  constexpr int dim = TypeParam::value;
  ParticleSet<dim> set;
  set.resize(6);
  fill_with_tags(set);
  const ParticleView<dim> view = set.view();
  static_assert(std::is_trivially_copyable_v<ParticleView<dim>>);
  EXPECT_EQ(view.count, 6u);
  for (int d = 0; d < dim; ++d) {
    EXPECT_EQ(view.position[d], set.position[d].data());
    EXPECT_EQ(view.velocity[d], set.velocity[d].data());
  }
  for (int s = 0; s < ParticleSet<dim>::stress_count; ++s)
    EXPECT_EQ(view.stress[s], set.stress[s].data());
  EXPECT_EQ(view.mass, set.mass.data());
  EXPECT_EQ(view.density, set.density.data());
  EXPECT_EQ(view.volume, set.volume.data());
  for (std::size_t i = 0; i < 6; ++i) EXPECT_EQ(view.position_of(i), set.position_of(i));
  // Writes through the view reach the set.
  view.mass[4] = -3.5;
  EXPECT_EQ(set.mass[4], -3.5);
}

/// A box with different node counts per axis and a lower corner off the origin.
template <int Dim>
LatticeBox<Dim> test_box(double spacing) {
  LatticeBox<Dim> box;
  box.spacing = spacing;
  const double lower[3] = {-0.7, 0.25, 3.1};
  const std::int64_t nodes[3] = {7, 4, 5};
  for (int d = 0; d < Dim; ++d) {
    box.lower[d] = lower[d];
    box.node_count[d] = nodes[d];
  }
  return box;
}

/// Multi-index of linear index i, axis 0 fastest.
template <int Dim>
std::array<std::int64_t, Dim> multi_index(std::int64_t i, const std::array<std::int64_t, Dim>& n) {
  std::array<std::int64_t, Dim> index{};
  for (int d = 0; d < Dim; ++d) {
    index[d] = i % n[d];
    i /= n[d];
  }
  return index;
}

// Real particles sit on the lattice nodes (axis 0 fastest), at rest, unstressed, with
// the trapezoidal volume dx^Dim / 2^(faces it lies on); the volumes add up to the box
// volume and integrate linear fields exactly; mass = density * volume.
TYPED_TEST(ParticleSetTest, RealLatticeHasNodePositionsAndTrapezoidVolumes) {
  constexpr int dim = TypeParam::value;
  const double dx = 0.13, density = 2700.0;
  const LatticeBox<dim> box = test_box<dim>(dx);
  const ParticleSet<dim> real = make_real_lattice(box, density);
  ASSERT_EQ(real.size(), static_cast<std::size_t>(box.total_nodes()));
  std::size_t expected_count = 1;
  double box_volume = 1.0;
  for (int d = 0; d < dim; ++d) {
    expected_count *= static_cast<std::size_t>(box.node_count[d]);
    box_volume *= static_cast<double>(box.node_count[d] - 1) * dx;
  }
  EXPECT_EQ(real.size(), expected_count);

  double volume_sum = 0.0, integral = 0.0;
  Vector<dim> slope;
  for (int d = 0; d < dim; ++d) slope[d] = 0.5 + d;
  Vector<dim> centre;
  for (int d = 0; d < dim; ++d)
    centre[d] = box.lower[d] + 0.5 * static_cast<double>(box.node_count[d] - 1) * dx;
  for (std::size_t i = 0; i < real.size(); ++i) {
    const auto index = multi_index<dim>(static_cast<std::int64_t>(i), box.node_count);
    double volume = 1.0;
    for (int d = 0; d < dim; ++d) {
      EXPECT_NEAR(real.position[d][i], box.lower[d] + static_cast<double>(index[d]) * dx, 1e-14);
      EXPECT_EQ(real.initial_position[d][i], real.position[d][i]);
      EXPECT_EQ(real.velocity[d][i], 0.0);
      const bool on_face = index[d] == 0 || index[d] == box.node_count[d] - 1;
      volume *= on_face ? 0.5 * dx : dx;
    }
    for (int s = 0; s < ParticleSet<dim>::stress_count; ++s) EXPECT_EQ(real.stress[s][i], 0.0);
    EXPECT_NEAR(real.volume[i], volume, 1e-15 * volume);
    EXPECT_EQ(real.density[i], density);
    EXPECT_DOUBLE_EQ(real.mass[i], density * real.volume[i]);
    EXPECT_EQ(real.id[i], i);
    EXPECT_EQ(real.boundary[i], ParticleSet<dim>::kNoBoundary);
    volume_sum += real.volume[i];
    integral += real.volume[i] * (1.0 + slope.dot(real.position_of(i)));
  }
  EXPECT_NEAR(volume_sum, box_volume, 1e-13 * box_volume);
  // The trapezoidal rule integrates (multi)linear fields exactly: volume * f(centre).
  const double exact = box_volume * (1.0 + slope.dot(centre));
  EXPECT_NEAR(integral, exact, 1e-12 * std::abs(exact));
}

// Virtual particles sit at the (n - 1)^Dim cell centres, each with volume dx^Dim, inside
// the box; their volumes add up to the box volume too.
TYPED_TEST(ParticleSetTest, VirtualLatticeHasCellCentresWithCellVolumes) {
  constexpr int dim = TypeParam::value;
  const double dx = 0.13, density = 1.5;
  const LatticeBox<dim> box = test_box<dim>(dx);
  const ParticleSet<dim> virtual_set = make_virtual_lattice(box, density);
  std::array<std::int64_t, dim> cells;
  std::size_t expected_count = 1;
  double box_volume = 1.0;
  for (int d = 0; d < dim; ++d) {
    cells[d] = box.node_count[d] - 1;
    expected_count *= static_cast<std::size_t>(cells[d]);
    box_volume *= static_cast<double>(cells[d]) * dx;
  }
  ASSERT_EQ(virtual_set.size(), expected_count);
  EXPECT_EQ(virtual_set.size(), static_cast<std::size_t>(box.total_cells()));
  const double cell_volume = std::pow(dx, dim);
  double volume_sum = 0.0;
  for (std::size_t i = 0; i < virtual_set.size(); ++i) {
    const auto index = multi_index<dim>(static_cast<std::int64_t>(i), cells);
    for (int d = 0; d < dim; ++d) {
      const double x = virtual_set.position[d][i];
      EXPECT_NEAR(x, box.lower[d] + (static_cast<double>(index[d]) + 0.5) * dx, 1e-14);
      EXPECT_GT(x, box.lower[d]);
      EXPECT_LT(x, box.lower[d] + static_cast<double>(cells[d]) * dx);
      EXPECT_EQ(virtual_set.initial_position[d][i], x);
    }
    EXPECT_NEAR(virtual_set.volume[i], cell_volume, 1e-15 * cell_volume);
    EXPECT_DOUBLE_EQ(virtual_set.mass[i], density * virtual_set.volume[i]);
    EXPECT_EQ(virtual_set.id[i], i);
    volume_sum += virtual_set.volume[i];
  }
  EXPECT_NEAR(volume_sum, box_volume, 1e-13 * box_volume);
}

// LatticeBox::validate (and so both factories) rejects a non-positive or NaN spacing and
// fewer than two nodes on any axis; a minimal box of two nodes per axis is accepted.
TYPED_TEST(ParticleSetTest, LatticeBoxValidation) {
  constexpr int dim = TypeParam::value;
  LatticeBox<dim> good;
  good.spacing = 0.5;
  good.node_count.fill(2);
  EXPECT_NO_THROW(good.validate());
  EXPECT_EQ(make_real_lattice(good, 1.0).size(), std::size_t{1} << dim);
  EXPECT_EQ(make_virtual_lattice(good, 1.0).size(), 1u);

  for (double spacing : {0.0, -0.1, std::numeric_limits<double>::quiet_NaN()}) {
    LatticeBox<dim> box = good;
    box.spacing = spacing;
    EXPECT_THROW(box.validate(), std::invalid_argument) << "dx = " << spacing;
    EXPECT_THROW(make_real_lattice(box, 1.0), std::invalid_argument);
    EXPECT_THROW(make_virtual_lattice(box, 1.0), std::invalid_argument);
  }
  for (int d = 0; d < dim; ++d)
    for (std::int64_t count : {1, 0, -3}) {
      LatticeBox<dim> box = good;
      box.node_count[d] = count;
      EXPECT_THROW(box.validate(), std::invalid_argument) << "axis " << d << ": " << count;
      EXPECT_THROW(make_real_lattice(box, 1.0), std::invalid_argument);
      EXPECT_THROW(make_virtual_lattice(box, 1.0), std::invalid_argument);
    }
}

}  // namespace
}  // namespace tsph
