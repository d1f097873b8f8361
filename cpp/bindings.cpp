// The extension module sphfluid._core: only calls the bind_* functions.
#include <pybind11/pybind11.h>

namespace py = pybind11;

void bind_solver(py::module_& m);
void bind_kernels(py::module_& m);
void bind_walls(py::module_& m);

PYBIND11_MODULE(_core, m) {
  m.doc() = "sphfluid native core: the 2D SPH solver and its kernels";
  m.attr("__version__") = SPHFLUID_VERSION;
#ifdef _OPENMP
  m.attr("has_openmp") = true;
#else
  m.attr("has_openmp") = false;
#endif
  bind_solver(m);
  py::module_ k = m.def_submodule("kernels", "2D SPH kernels, vectorised, for tests");
  bind_kernels(k);
  py::module_ w = m.def_submodule("walls", "Wall geometry (ghosts, reflection), for tests");
  bind_walls(w);
}
