// What the running CPU prefers where the same lanes can be computed two ways.
#pragma once

namespace sphfluid::simd {

// Whether the seed's double pair forces take 1/r from rsqrt14 and two Newton
// steps (terms/seed.hpp, RecipRoot) on this CPU rather than a square root and
// a division. Measured on the 10k dam break, 1 thread: on an Intel Xeon
// (AVX-512, 2026-11-25) forces 251 -> 217 us a step; on an AMD EPYC (Zen 4)
// 311 -> 341 (BENCHMARKS.md). Intel's 512-bit square root and division are
// the slow ones; so Intel CPUs take the Newton steps. (In float, with eight
// lanes of 256 bits, the root and division stay on both: on the Xeon the
// Newton step lost, 193 -> 210 us.)
inline bool prefers_recip_root() {
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
  return __builtin_cpu_is("intel");
#else
  return false;
#endif
}

}  // namespace sphfluid::simd
