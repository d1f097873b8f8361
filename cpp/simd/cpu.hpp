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

// What the running CPU can execute, for picking a core at import: the
// instruction sets the avx2 (x86-64-v3) and avx512 (x86-64-v4) cores are
// compiled for, each true only when the CPU has all of them (and the
// operating system saves their registers, which __builtin_cpu_supports
// checks). On other processors: false.
struct CpuFeatures {
  bool avx2 = false;    // AVX2, FMA, BMI1/2, F16C, LZCNT, MOVBE
  bool avx512 = false;  // AVX-512 F, BW, CD, DQ, VL (and the above)
};

inline CpuFeatures cpu_features() {
  CpuFeatures f;
#if defined(__GNUC__) && defined(__x86_64__)
  __builtin_cpu_init();
#if !defined(__clang__) && __GNUC__ >= 11  // the levels by name
  f.avx2 = __builtin_cpu_supports("x86-64-v3");
  f.avx512 = __builtin_cpu_supports("x86-64-v4");
#else  // the sets the cores' code uses
  f.avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
           __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2");
  f.avx512 = f.avx2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
             __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
             __builtin_cpu_supports("avx512vl");
#endif
#endif
  return f;
}

}  // namespace sphfluid::simd
