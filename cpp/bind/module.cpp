// The extension module sphfluid._core (or, in a build with a core per SIMD
// level, sphfluid._core_baseline, _core_avx2, _core_avx512; SPHFLUID_MODULE):
// only calls the bind_* functions.
#include <pybind11/pybind11.h>

#include "core/types.hpp"

namespace py = pybind11;

void bind_params(py::module_& m);
void bind_solver(py::module_& m);
void bind_kernels(py::module_& m);
void bind_walls(py::module_& m);

PYBIND11_MODULE(SPHFLUID_MODULE, m) {
  m.doc() = "sphfluid native core: the 2D SPH solver and its kernels";
  m.attr("__version__") = SPHFLUID_VERSION;
#ifdef _OPENMP
  m.attr("has_openmp") = true;
#else
  m.attr("has_openmp") = false;
#endif
  py::dict info;
  info["compiler"] = SPHFLUID_COMPILER;
  info["build_type"] = SPHFLUID_BUILD_TYPE;
#ifdef SPHFLUID_MARCH_NATIVE
  info["march_native"] = true;
#else
  info["march_native"] = false;
#endif
#ifdef _OPENMP
  info["openmp"] = _OPENMP;
#else
  info["openmp"] = py::none();
#endif
  info["simd"] = SPHFLUID_SIMD_PATH;  // native, baseline, avx2 or avx512
  info["real"] = sizeof(sphfluid::Real) == 8 ? "double" : "float";
#ifdef SPHFLUID_SANITIZE
  info["sanitize"] = SPHFLUID_SANITIZE;  // the checking build's -fsanitize= list
#else
  info["sanitize"] = "";
#endif
  m.attr("build_info") = info;
  bind_params(m);
  bind_solver(m);
  py::module_ k = m.def_submodule("kernels", "2D SPH kernels, vectorised, for tests");
  bind_kernels(k);
  py::module_ w = m.def_submodule("walls", "Wall geometry (ghosts, reflection), for tests");
  bind_walls(w);
}
