// The one instantiation of TaylorSph<2> (engine/taylor_sph.hpp declares it extern, so
// no other translation unit compiles the stages again).
#include "engine/taylor_sph.hpp"

namespace tsph {
template class TaylorSph<2>;
}  // namespace tsph
