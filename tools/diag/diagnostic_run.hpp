// The set-up the diagnostics in tools/diag share: a case file and its overrides from the
// command line (CASE.toml [KEY=VALUE...]), the built case, its solver, the step and the
// number of steps, and the print interval (env DIAG_EVERY, at least 1).
#pragma once

#include "engine/case/case_build.hpp"
#include "engine/case/case_file.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

namespace tsph {

template <int Dim>
struct DiagnosticRun {
  CaseFile c;
  BuiltCase<Dim> b;  ///< before the solver, which make_solver builds from it
  double dt;
  TaylorSph<Dim> solver;
  std::int64_t steps;
  int every;

  DiagnosticRun(int argc, char** argv, int default_every)
      : c(load_case(argv[1], std::vector<std::string>(argv + 2, argv + argc))),
        b(build_case<Dim>(c)),
        dt(b.dt),
        solver(make_solver<Dim>(c, b)),
        steps(count_steps(c, dt)),
        every(std::max(1, std::getenv("DIAG_EVERY") ? std::atoi(std::getenv("DIAG_EVERY")) : default_every)) {}
};

}  // namespace tsph
