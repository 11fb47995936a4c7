// Helpers at the numpy boundary: read 1-D float64 arrays in place, hand vectors out without copies.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace millscope::bindings {

namespace py = pybind11;

// c_style | forcecast: a contiguous float64 array is used as it is; anything else is converted once.
using InArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

inline const double* data_1d(const InArray& a, const char* name) {
  if (a.ndim() != 1) {
    throw std::invalid_argument(std::string(name) + " must be 1-D; got " +
                                std::to_string(a.ndim()) + " dimensions");
  }
  return a.data();
}

// Moves the vector into a capsule that the returned array owns: no copy.
template <class T>
py::array_t<T> to_numpy(std::vector<T>&& v) {
  auto* owned = new std::vector<T>(std::move(v));
  py::capsule free_when_done(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>({static_cast<py::ssize_t>(owned->size())}, {sizeof(T)}, owned->data(),
                        free_when_done);
}

}  // namespace millscope::bindings
