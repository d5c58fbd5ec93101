// Linear elasticity and the stress utilities: kept as an include for the code that
// names it; the models live in engine/material/ (docs/architecture.md, the material
// interface).
#pragma once

#include "engine/material/linear_elastic.hpp"
#include "engine/material/stress.hpp"
