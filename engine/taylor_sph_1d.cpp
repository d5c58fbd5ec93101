// The one instantiation of TaylorSph<1> (engine/taylor_sph.hpp declares it extern, so
// no other translation unit compiles the stages again).
#include "engine/taylor_sph.hpp"

namespace tsph {
template class TaylorSph<1>;
}  // namespace tsph
