// The extension module sphfluid._cpu: which SIMD levels this CPU runs, read
// before a core is loaded (python/sphfluid/_dispatch.py). Compiled for the
// compiler's default target, so that any CPU can import it; it registers no
// types, so it never meets a core's.
#include <pybind11/pybind11.h>

#include "simd/cpu.hpp"

namespace py = pybind11;

PYBIND11_MODULE(_cpu, m) {
  m.doc() = "which SIMD levels this CPU runs";
  m.def(
      "features",
      [] {
        const auto f = sphfluid::simd::cpu_features();
        py::dict d;
        d["avx2"] = f.avx2;
        d["avx512"] = f.avx512;
        return d;
      },
      "{'avx2': bool, 'avx512': bool}: whether this CPU runs x86-64-v3 (AVX2, FMA, BMI1/2, "
      "F16C, LZCNT, MOVBE) and x86-64-v4 (AVX-512 F, BW, CD, DQ, VL) code.");
}
