#pragma once
// Private: the compiler switches of the fast path's hot code (fast.cpp and lanes.cpp).

#include <cstdint>
#include <cstring>

// The hot functions are compiled twice, for x86-64-v3 (AVX2 + FMA: a multiply-add is one
// instruction, 4 doubles per register) and for the baseline; the loader picks the one the CPU
// runs (GNU ifunc). Other compilers/targets get the baseline only.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(ISOWRENCH_NO_CLONES)
#define ISOWRENCH_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define ISOWRENCH_CLONES
#endif

#if defined(__GNUC__)
#define ISOWRENCH_INLINE inline __attribute__((always_inline))
#define ISOWRENCH_NOINLINE __attribute__((noinline))
#else
#define ISOWRENCH_INLINE inline
#define ISOWRENCH_NOINLINE
#endif

// Full unrolling of loops whose trip count is a compile-time constant (the statics kernels'
// N > 0): straight-line code the compiler keeps in registers.
#if defined(__GNUC__) && !defined(__clang__)
#define ISOWRENCH_UNROLL _Pragma("GCC unroll 16")
#elif defined(__clang__)
#define ISOWRENCH_UNROLL _Pragma("unroll")
#else
#define ISOWRENCH_UNROLL
#endif

#if !defined(__GNUC__)
#error "isowrench's fast path needs GCC or Clang vector extensions (vector_size)"
#endif

namespace isowrench {

// 4 doubles / 4 64-bit integers (GCC/Clang vector extensions): one AVX register in the
// x86-64-v3 clone, two SSE2 registers in the baseline. Helpers take them by reference and
// constants are made by macro: a 32-byte vector passed or returned by value would draw GCC's
// -Wpsabi note (its ABI depends on AVX being enabled).
typedef double V4 __attribute__((vector_size(32)));
typedef std::int64_t V4i __attribute__((vector_size(32)));

}  // namespace isowrench

#define ISOWRENCH_V4_SPLAT(x) (::isowrench::V4{(x), (x), (x), (x)})
#define ISOWRENCH_V4_LOAD(v, p) std::memcpy(&(v), (p), sizeof(::isowrench::V4))
#define ISOWRENCH_V4_STORE(p, v) std::memcpy((p), &(v), sizeof(::isowrench::V4))
