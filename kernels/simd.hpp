// Packs of doubles for the stencil and evaluation loops (bench/RESULTS.md, "SIMD pass"),
// and the choice between the SSE2 baseline and an AVX2 build of those loops at run time.
//
// A `Pack` is kLanes = 4 doubles (GCC/clang vector extension): arithmetic and comparisons
// act lane by lane, compiled to two SSE2 instructions per operation in the baseline build
// and to one AVX2 instruction inside a function compiled with
// `[[gnu::target("avx2,fma")]]`. The AVX2 build contracts a * b + c into fused
// multiply-adds (-5 % instructions in 2D, -8 % in 3D; bench/RESULTS.md, "FMA"), so the two
// paths agree to round-off, not bitwise (tests/test_corrected_operators.cpp checks 1e-13);
// lanes are summed in one fixed order, so the thread count never changes a result.
//
// Loops over a neighbour row work on buffers padded to a multiple of kLanes with zeros
// (volume 0, offset 0, weight 0), whose contributions to every sum are exactly zero.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

namespace tsph {

inline constexpr std::size_t kLanes = 4;
using Pack = double __attribute__((vector_size(kLanes * sizeof(double))));
using PackMask = decltype(Pack{} < Pack{});

/// n rounded up to a whole number of packs.
constexpr std::size_t padded_size(std::size_t n) { return (n + kLanes - 1) / kLanes * kLanes; }

[[gnu::always_inline]] inline Pack load_pack(const double* p) {
  Pack v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
[[gnu::always_inline]] inline void store_pack(double* p, Pack v) { std::memcpy(p, &v, sizeof v); }
/// The pack {p[j[0]], ..., p[j[kLanes - 1]]}: scalar loads into lanes (no buffer).
[[gnu::always_inline]] inline Pack load_indexed_pack(const double* p, const std::array<std::uint32_t, kLanes>& j) {
  return Pack{p[j[0]], p[j[1]], p[j[2]], p[j[3]]};
}
[[gnu::always_inline]] inline Pack broadcast(double x) { return Pack{} + x; }
/// Sum of the lanes in a fixed order: (l0 + l1) + (l2 + l3).
[[gnu::always_inline]] inline double lane_sum(Pack v) { return (v[0] + v[1]) + (v[2] + v[3]); }
/// The lane sums of four packs at once, {lane_sum(a), lane_sum(b), lane_sum(c),
/// lane_sum(d)} bitwise (same pairs, same order), in 6 shuffles and adds instead of 4 x 6.
[[gnu::always_inline]] inline Pack lane_sums(Pack a, Pack b, Pack c, Pack d) {
  const Pack ab = __builtin_shufflevector(a, b, 0, 4, 2, 6) + __builtin_shufflevector(a, b, 1, 5, 3, 7);
  const Pack cd = __builtin_shufflevector(c, d, 0, 4, 2, 6) + __builtin_shufflevector(c, d, 1, 5, 3, 7);
  // ab = {a0 + a1, b0 + b1, a2 + a3, b2 + b3}, cd likewise.
  return __builtin_shufflevector(ab, cd, 0, 1, 4, 5) + __builtin_shufflevector(ab, cd, 2, 3, 6, 7);
}
template <std::size_t K, std::size_t N>
[[gnu::always_inline]] inline Pack pack_or_zero(const std::array<Pack, N>& v) {
  if constexpr (K < N) return v[K];
  else return Pack{};
}
template <std::size_t First, std::size_t N>
[[gnu::always_inline]] inline void lane_sums_of_group(const std::array<Pack, N>& v, std::array<double, N>& out) {
  const Pack sums = lane_sums(pack_or_zero<First>(v), pack_or_zero<First + 1>(v), pack_or_zero<First + 2>(v),
                              pack_or_zero<First + 3>(v));
  if constexpr (First < N) out[First] = sums[0];
  if constexpr (First + 1 < N) out[First + 1] = sums[1];
  if constexpr (First + 2 < N) out[First + 2] = sums[2];
  if constexpr (First + 3 < N) out[First + 3] = sums[3];
}
template <std::size_t N, std::size_t... Group>
[[gnu::always_inline]] inline void lane_sums_of_groups(const std::array<Pack, N>& v, std::array<double, N>& out,
                                                       std::index_sequence<Group...>) {
  (lane_sums_of_group<4 * Group>(v, out), ...);
}
/// lane_sum of every pack of an array, four at a time (lane_sums), unrolled at compile
/// time so that the packs can stay in registers.
template <std::size_t N>
[[gnu::always_inline]] inline std::array<double, N> lane_sums(const std::array<Pack, N>& v) {
  std::array<double, N> out;
  lane_sums_of_groups(v, out, std::make_index_sequence<(N + 3) / 4>{});
  return out;
}

// Branch-free helpers written once for double and Pack, so that a kernel's shape
// function serves the scalar reference and the packed loop alike.
[[gnu::always_inline]] inline double select(bool condition, double a, double b) {
  return condition ? a : b;
}
[[gnu::always_inline]] inline Pack select(PackMask condition, Pack a, Pack b) {
  return condition ? a : b;
}
[[gnu::always_inline]] inline double max_of(double a, double b) { return a > b ? a : b; }
[[gnu::always_inline]] inline Pack max_of(Pack a, double b) {
  const Pack bb = broadcast(b);
  return a > bb ? a : bb;
}
[[gnu::always_inline]] inline double square_root(double x) { return std::sqrt(x); }
/// Lane by lane (sqrtpd with -fno-math-errno, which CMakeLists.txt sets).
[[gnu::always_inline]] inline Pack square_root(Pack x) {
  Pack r;
  for (std::size_t l = 0; l < kLanes; ++l) r[l] = std::sqrt(x[l]);
  return r;
}

/// Marks the AVX2 build of a packed loop (x86-64 only; elsewhere it is the baseline).
#if defined(__x86_64__) || defined(__i386__)
#define TSPH_TARGET_AVX2 [[gnu::target("avx2,fma")]]
#else
#define TSPH_TARGET_AVX2
#endif

/// The instruction set the packed loops run with.
enum class SimdPath { sse2, avx2 };

inline std::string_view to_string(SimdPath path) { return path == SimdPath::avx2 ? "avx2" : "sse2"; }

/// AVX2 (with FMA) where the CPU has it, unless the environment variable TSPH_SIMD=sse2 asks for the
/// baseline (to measure one against the other on the same binary). Decided once.
inline SimdPath simd_path() {
  static const SimdPath path = [] {
    const char* forced = std::getenv("TSPH_SIMD");
    if (forced != nullptr && std::string_view(forced) == "sse2") return SimdPath::sse2;
#if defined(__x86_64__) || defined(__i386__)
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return SimdPath::avx2;
#endif
    return SimdPath::sse2;
  }();
  return path;
}

/// std::vector storage aligned to a cache line, for the packed buffers.
template <class T>
struct CacheAlignedAllocator {
  using value_type = T;
  static constexpr std::align_val_t alignment{64};
  CacheAlignedAllocator() = default;
  template <class U>
  CacheAlignedAllocator(const CacheAlignedAllocator<U>&) {}
  T* allocate(std::size_t n) { return static_cast<T*>(::operator new(n * sizeof(T), alignment)); }
  void deallocate(T* p, std::size_t) { ::operator delete(p, alignment); }
  template <class U>
  bool operator==(const CacheAlignedAllocator<U>&) const { return true; }
};

using PackBuffer = std::vector<double, CacheAlignedAllocator<double>>;

}  // namespace tsph
