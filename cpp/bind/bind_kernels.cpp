// Vectorised kernels, wcsph's corner tables and the lattice mass for tests and
// the Python layer: thin loops over numpy arrays around terms/.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <string>

#include "bind/arrays.hpp"
#include "terms/kernels.hpp"
#include "terms/lattice.hpp"
#include "terms/wall_tables.hpp"
#include "terms/wendland.hpp"

namespace py = pybind11;
using namespace sphfluid;
using bind::InArray;

namespace {

template <class Fn>
py::array_t<double> radial(const InArray& r, double h, Fn fn) {
  const Kernels k(h);
  py::array_t<double> out(r.request().shape);
  const double* in = r.data();
  double* o = out.mutable_data();
  for (py::ssize_t i = 0; i < r.size(); ++i) o[i] = fn(k, in[i]);
  return out;
}

template <class Fn>
py::array_t<double> vector_valued(const InArray& r, double h, Fn fn) {
  const auto rs = bind::to_vec2(r, "r");
  const Kernels k(h);
  py::array_t<double> out({py::ssize_t(rs.size()), py::ssize_t(2)});
  auto o = out.mutable_unchecked<2>();
  for (std::size_t i = 0; i < rs.size(); ++i) {
    const Vec2 g = fn(k, rs[i]);
    o(i, 0) = g.x();
    o(i, 1) = g.y();
  }
  return out;
}

void check_h(double h) {
  if (!(h > 0 && std::isfinite(h))) throw std::invalid_argument("h must be > 0");
}

}  // namespace

void bind_kernels(py::module_& m) {
  m.def("w_poly6", [](const InArray& r, double h) {
    check_h(h);
    return radial(r, h, [](const Kernels& k, double x) { return k.w_poly6(x * x); });
  }, py::arg("r"), py::arg("h"), "poly6 W(r) = 4/(pi h^8) (h^2 - r^2)^3, r >= 0");
  m.def("lap_poly6", [](const InArray& r, double h) {
    check_h(h);
    return radial(r, h, [](const Kernels& k, double x) { return k.lap_poly6(x * x); });
  }, py::arg("r"), py::arg("h"), "poly6 Laplacian -48/(pi h^8) (h^2 - r^2)(h^2 - 3 r^2)");
  m.def("w_spiky", [](const InArray& r, double h) {
    check_h(h);
    return radial(r, h, [](const Kernels& k, double x) { return k.w_spiky(x); });
  }, py::arg("r"), py::arg("h"), "spiky W(r) = 10/(pi h^5) (h - r)^3");
  m.def("lap_visc", [](const InArray& r, double h) {
    check_h(h);
    return radial(r, h, [](const Kernels& k, double x) { return k.lap_visc(x); });
  }, py::arg("r"), py::arg("h"), "viscosity Laplacian 40/(pi h^5) (h - r)");
  m.def("grad_poly6", [](const InArray& r, double h) {
    check_h(h);
    return vector_valued(r, h, [](const Kernels& k, const Vec2& x) {
      return k.grad_poly6(x, x.squaredNorm());
    });
  }, py::arg("r_ij"), py::arg("h"), "poly6 gradient for offsets r_ij of shape (n, 2)");
  m.def("grad_spiky", [](const InArray& r, double h) {
    check_h(h);
    return vector_valued(r, h, [](const Kernels& k, const Vec2& x) {
      return k.grad_spiky(x, x.norm());
    });
  }, py::arg("r_ij"), py::arg("h"), "spiky gradient for offsets r_ij of shape (n, 2)");
  m.def("wendland_w", [](const InArray& r, double h) {
    check_h(h);
    const Wendland w(h);
    return radial(r, h, [&](const Kernels&, double x) { return w.value(x); });
  }, py::arg("r"), py::arg("h"), "Wendland C2 W(r) = 7/(pi h^2) (1 - q)^4 (1 + 4q), support h");
  m.def("wendland_lap", [](const InArray& r, double h) {
    check_h(h);
    const Wendland w(h);
    return radial(r, h, [&](const Kernels&, double x) { return w.laplacian(x); });
  }, py::arg("r"), py::arg("h"), "Wendland C2 Laplacian -140/(pi h^4) (1 - q)^2 (2 - 5q)");
  m.def("wendland_grad", [](const InArray& r, double h) {
    check_h(h);
    const Wendland w(h);
    return vector_valued(r, h, [&](const Kernels&, const Vec2& x) {
      return w.gradient(x, x.norm());
    });
  }, py::arg("r_ij"), py::arg("h"), "Wendland C2 gradient for offsets r_ij of shape (n, 2)");
  m.def("wendland_corner", [](double d1, double d2, double h, double dx, double m_over_rho0) {
    check_h(h);
    if (!(d1 >= 0 && d2 >= 0 && dx >= 0 && m_over_rho0 >= 0))
      throw std::invalid_argument("distances, dx and m / rho0 must be >= 0");
    WallTables t{Wendland(h)};
    t.build_corner_tables(dx, m_over_rho0);
    return py::make_tuple(t.corner_half(d1, d2), t.corner_line(d1, d2), t.corner_line(d2, d1));
  }, py::arg("d1"), py::arg("d2"), py::arg("h"), py::arg("dx") = 0.0, py::arg("m_over_rho0") = 0.0,
     "wcsph's share of the quadrant beyond a right-angled corner, at distances d1 and d2 from "
     "its walls: (density / rho0, push along wall 1's normal, push along wall 2's normal), per "
     "unit 2 p rho0 / rho^2; from the mirrored lattice of spacing dx (dx > 0, particle mass "
     "m_over_rho0 * rho0) or the continuum (dx = 0)");
  m.def("lattice_mass", [](double rho0, double dx, double h, const std::string& kernel) {
    if (kernel != "poly6" && kernel != "wendland")
      throw std::invalid_argument("kernel: expected poly6 or wendland, got " + kernel);
    return lattice_mass(rho0, dx, h,
                        kernel == "poly6" ? LatticeKernel::kPoly6 : LatticeKernel::kWendland);
  }, py::arg("rho0"), py::arg("dx"), py::arg("h"), py::arg("kernel") = "poly6",
     "Particle mass giving density rho0 inside a filled square lattice of spacing dx "
     "for the seed's poly6 or wcsph's Wendland kernel");
}
