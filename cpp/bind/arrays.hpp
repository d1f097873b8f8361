// Conversions between numpy arrays and the core's containers for the bindings:
// (n, 2) float64 arrays in, read-only views of shared native buffers out.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/particles.hpp"
#include "core/types.hpp"
#include "boundary/walls.hpp"

namespace sphfluid::bind {

namespace py = pybind11;
using InArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

inline std::vector<Vec2> to_vec2(const InArray& a, const char* name) {
  if (a.ndim() != 2 || a.shape(1) != 2)
    throw std::invalid_argument(std::string(name) + ": expected an array of shape (n, 2)");
  std::vector<Vec2> out(static_cast<std::size_t>(a.shape(0)));
  auto r = a.unchecked<2>();
  for (py::ssize_t i = 0; i < a.shape(0); ++i) out[i] = Vec2(r(i, 0), r(i, 1));
  return out;
}

inline std::vector<Segment> to_segments(const InArray& a) {
  if (a.size() == 0) return {};
  if (a.ndim() != 3 || a.shape(1) != 2 || a.shape(2) != 2)
    throw std::invalid_argument("walls: expected an array of shape (n, 2, 2)");
  std::vector<Segment> out;
  auto r = a.unchecked<3>();
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    try {
      out.push_back(make_segment(Vec2(r(i, 0, 0), r(i, 0, 1)), Vec2(r(i, 1, 0), r(i, 1, 1))));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("walls[" + std::to_string(i) + "]: " + e.what());
    }
  }
  return out;
}

// A read-only numpy view of a field's buffer; the view keeps the buffer alive.
template <class T, int Cols>
py::array view(const Field<T>& f) {
  using Buffer = typename Field<T>::Buffer;
  if (f.size() == 0) {
    py::array empty;
    if constexpr (Cols == 2)
      empty = py::array_t<Real>(std::vector<py::ssize_t>{0, 2});
    else
      empty = py::array_t<T>(std::vector<py::ssize_t>{0});
    empty.attr("flags").attr("writeable") = false;
    return empty;
  }
  auto* holder = new std::shared_ptr<Buffer>(f.share());
  py::capsule owner(holder, [](void* p) { delete static_cast<std::shared_ptr<Buffer>*>(p); });
  const py::ssize_t n = static_cast<py::ssize_t>((*holder)->size());
  py::array out;
  if constexpr (Cols == 2) {
    out = py::array_t<Real>({n, py::ssize_t(2)},
                            {py::ssize_t(sizeof(T)), py::ssize_t(sizeof(Real))},
                            reinterpret_cast<const Real*>((*holder)->data()), owner);
  } else {
    out = py::array_t<T>({n}, {py::ssize_t(sizeof(T))}, (*holder)->data(), owner);
  }
  out.attr("flags").attr("writeable") = false;
  return out;
}

}  // namespace sphfluid::bind
