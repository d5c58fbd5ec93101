// The one list of dimensions that typed tests run over (docs/conventions.md: "one test body runs
// over every kernel, every search and every dimension"), with readable names (1d, 2d, 3d).
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <type_traits>

namespace tsph::testing {

using Dimensions = ::testing::Types<std::integral_constant<int, 1>, std::integral_constant<int, 2>,
                                    std::integral_constant<int, 3>>;

struct DimName {
  template <class DimConstant>
  static std::string GetName(int) {
    return std::to_string(DimConstant::value) + "d";
  }
};

}  // namespace tsph::testing
