// Wall geometry for tests: the ghosts of a point and the reflection of a
// path (boundary/walls.hpp), on numpy arrays.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <stdexcept>

#include "bind/arrays.hpp"
#include "boundary/walls.hpp"

namespace py = pybind11;
using namespace sphfluid;
using bind::InArray;

namespace {

void check_h(double h) {
  if (!(h > 0 && std::isfinite(h))) throw std::invalid_argument("h must be > 0");
}

}  // namespace

void bind_walls(py::module_& m) {
  m.def("ghosts", [](const InArray& walls, const InArray& point, double h, bool nearest_only) {
    check_h(h);
    if (point.size() != 2) throw std::invalid_argument("point: expected [x, y]");
    const Vec2 p(point.data()[0], point.data()[1]);
    const WallSet set(bind::to_segments(walls), h);
    std::vector<Vec2> ghosts;
    set.for_each_ghost(p, [&](const Vec2& r, bool nearest) {
      if (nearest || !nearest_only) ghosts.push_back(p - r);
    });
    py::array_t<double> out({py::ssize_t(ghosts.size()), py::ssize_t(2)});
    auto o = out.mutable_unchecked<2>();
    for (std::size_t i = 0; i < ghosts.size(); ++i) {
      o(i, 0) = ghosts[i].x();
      o(i, 1) = ghosts[i].y();
    }
    return out;
  }, py::arg("walls"), py::arg("point"), py::arg("h"), py::arg("nearest_only") = false,
     "Positions of the wall ghosts of a particle at point (seed 4.1); with "
     "nearest_only, only those at the walls' nearest point (wcsph and dfsph: none at "
     "a joint another segment comes nearer than, nor where three segments meet)");
  m.def("collide", [](const InArray& walls, const InArray& x_old, const InArray& x_new,
                      const InArray& v, double restitution, double h) {
    check_h(h);
    if (x_old.size() != 2 || x_new.size() != 2 || v.size() != 2)
      throw std::invalid_argument("x_old, x_new, v: expected [x, y]");
    const WallSet set(bind::to_segments(walls), h);
    const Vec2 xo(x_old.data()[0], x_old.data()[1]);
    Vec2 xn(x_new.data()[0], x_new.data()[1]);
    Vec2 vv(v.data()[0], v.data()[1]);
    set.collide(xo, xn, vv, restitution);
    return py::make_tuple(py::make_tuple(xn.x(), xn.y()), py::make_tuple(vv.x(), vv.y()));
  }, py::arg("walls"), py::arg("x_old"), py::arg("x_new"), py::arg("v"),
     py::arg("restitution") = 1.0, py::arg("h") = 1.0,
     "Move from x_old towards x_new with velocity v, reflecting off walls (seed 4.2); "
     "returns (x, v). A bounce leaves the particle 1e-6 h in front of the wall.");
}
