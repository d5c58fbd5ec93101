// Time functions of prescribed velocities and tractions.
#include "engine/time_function.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace tsph {
namespace {

TEST(TimeFunction, RectangularPulseIsOnForStartExclusiveEndInclusive) {
  const auto f = TimeFunction::rectangular_pulse(2.0, 0.0, 2.5e-3);
  EXPECT_EQ(f(0.0), 0.0);
  EXPECT_EQ(f(1e-9), 2.0);
  EXPECT_EQ(f(2.5e-3), 2.0);
  EXPECT_EQ(f(2.6e-3), 0.0);
  EXPECT_EQ(f(-1.0), 0.0);
  // Ten steps of 0.1 land on t_end = 1 up to round-off: counted as on, like t_end.
  const auto g = TimeFunction::rectangular_pulse(1.0, 0.0, 1.0);
  double t = 0.0;
  for (int k = 0; k < 10; ++k) t += 0.1;
  EXPECT_NE(t, 1.0);  // the round-off this guards against is real
  EXPECT_EQ(g(t), 1.0);
  EXPECT_EQ(g(t + 0.1), 0.0);
}

TEST(TimeFunction, RampAndConstant) {
  const auto ramp = TimeFunction::linear_ramp(3.0, 1.0, 3.0);
  EXPECT_EQ(ramp(0.5), 0.0);
  EXPECT_DOUBLE_EQ(ramp(2.0), 1.5);
  EXPECT_EQ(ramp(4.0), 3.0);
  EXPECT_EQ(TimeFunction::constant(-7.0)(123.0), -7.0);
}

TEST(TimeFunction, TableInterpolatesLinearlyAndHoldsItsEnds) {
  const auto f = TimeFunction::table({0.0, 1.0, 3.0}, {0.0, 2.0, -2.0});
  EXPECT_EQ(f(-1.0), 0.0);
  EXPECT_DOUBLE_EQ(f(0.5), 1.0);
  EXPECT_DOUBLE_EQ(f(2.0), 0.0);
  EXPECT_EQ(f(10.0), -2.0);
}

// int_0^t f against a composite midpoint rule on a grid that puts every switching
// instant on a cell boundary (exact for piecewise-linear f), and the closed forms.
TEST(TimeFunction, IntegralIsExactForEveryKind) {
  const std::vector<TimeFunction> functions = {
      TimeFunction::constant(-2.5), TimeFunction::rectangular_pulse(3.0, 0.5, 1.25),
      TimeFunction::linear_ramp(2.0, 0.25, 1.5), TimeFunction::table({0.5, 1.0, 2.0}, {1.0, 1.0, -1.0}),
      TimeFunction::table({-1.0, 0.75, 1.75}, {4.0, -2.0, 3.0}), TimeFunction::table({1.0}, {-3.0})};
  for (std::size_t k = 0; k < functions.size(); ++k) {
    const TimeFunction& f = functions[k];
    for (double t : {0.0, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.75}) {
      const int cells = static_cast<int>(std::lround(t * 4000.0));  // a cell of 1/4000 s
      double sum = 0.0;
      for (int c = 0; c < cells; ++c) sum += f((c + 0.5) / 4000.0) / 4000.0;
      EXPECT_NEAR(f.integral(t), sum, 1e-10) << "function " << k << " at t = " << t;
    }
  }
  EXPECT_DOUBLE_EQ(TimeFunction::linear_ramp(2.0, 1.0, 3.0).integral(5.0), 2.0 + 4.0);
  EXPECT_DOUBLE_EQ(TimeFunction::table({1.0, 2.0}, {1.0, -1.0}).integral(2.0), 1.0);
  EXPECT_EQ(TimeFunction::constant(7.0).integral(0.0), 0.0);
}

TEST(TimeFunction, InvalidDefinitionsThrow) {
  EXPECT_THROW(TimeFunction::rectangular_pulse(1.0, 2.0, 1.0), std::invalid_argument);
  EXPECT_THROW(TimeFunction::linear_ramp(1.0, 0.0, 0.0), std::invalid_argument);
  EXPECT_THROW(TimeFunction::table({0.0, 0.0}, {1.0, 2.0}), std::invalid_argument);
  EXPECT_THROW(TimeFunction::table({0.0}, {1.0, 2.0}), std::invalid_argument);
  EXPECT_THROW(TimeFunction::table({}, {}), std::invalid_argument);
}

}  // namespace
}  // namespace tsph
