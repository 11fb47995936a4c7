// millscope._core: the private extension module. Each area registers itself from its own file.
#include <omp.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <Eigen/Core>
#include <string>

#include "millscope/dsp.hpp"
#include "millscope/engine.hpp"

namespace py = pybind11;

namespace millscope::bindings {
void register_dsp(py::module_& m);
void register_contact(py::module_& m);
void register_drum(py::module_& m);
void register_neighbors(py::module_& m);
void register_engine(py::module_& m);
}

PYBIND11_MODULE(_core, m) {
  m.doc() = "millscope C++ core (private; use the millscope package)";
  millscope::bindings::register_dsp(m);
  millscope::bindings::register_contact(m);
  millscope::bindings::register_drum(m);
  millscope::bindings::register_neighbors(m);
  millscope::bindings::register_engine(m);

  m.def("build_info", [] {
    py::dict info;
    info["version"] = MILLSCOPE_VERSION;
    info["compiler"] = MILLSCOPE_CXX_COMPILER;
    info["flags"] = MILLSCOPE_CXX_FLAGS;
    info["build_type"] = MILLSCOPE_BUILD_TYPE;
    info["cxx_standard"] = static_cast<long>(__cplusplus);
    info["openmp_version"] = static_cast<long>(_OPENMP);
    info["openmp_max_threads"] = omp_get_max_threads();
    info["fftw_version"] = millscope::dsp::fftw_version();
    info["eigen_version"] = std::to_string(EIGEN_WORLD_VERSION) + "." +
                            std::to_string(EIGEN_MAJOR_VERSION) + "." +
                            std::to_string(EIGEN_MINOR_VERSION);
    // the SIMD paths of the vector kernels this CPU runs, widest first
    info["simd_paths"] = millscope::engine::simd_paths();
    return info;
  }, "Facts about how this extension was built.");
}
