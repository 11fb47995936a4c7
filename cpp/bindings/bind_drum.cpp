// pybind11 glue for the drum geometry (millscope::drum): used by tests and diagnostics.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "millscope/drum.hpp"
#include "numpy_view.hpp"

namespace millscope::bindings {

void register_drum(py::module_& m) {
  namespace dr = millscope::drum;
  using py::arg;

  py::class_<dr::Geometry>(m, "DrumGeometry")
      .def(py::init([](double radius, double length, bool end_walls, int lifters,
                       double lifter_width, double lifter_height, double lifter_phase) {
             dr::Geometry g{radius, length, end_walls, lifters, lifter_width, lifter_height,
                            lifter_phase};
             g.validate();
             return g;
           }),
           arg("radius"), arg("length"), arg("end_walls"), arg("lifters"), arg("lifter_width"),
           arg("lifter_height"), arg("lifter_phase") = 0.0)
      .def_readonly("radius", &dr::Geometry::radius)
      .def_readonly("length", &dr::Geometry::length)
      .def_readonly("lifters", &dr::Geometry::lifters);

  m.def(
      "drum_contacts",
      [](const dr::Geometry& g, double theta, const Eigen::Vector3d& x, double r) {
        const auto found = dr::find_contacts(g, theta, x, r);
        static const char* names[] = {"shell", "end_low", "end_high", "lifter"};
        py::list out;
        for (int i = 0; i < found.count; ++i) {
          const auto& c = found.items[static_cast<std::size_t>(i)];
          py::dict d;
          d["part"] = names[static_cast<int>(c.part)];
          d["index"] = c.index;
          d["overlap"] = c.overlap;
          d["normal"] = c.normal;
          d["point"] = c.point;
          out.append(d);
        }
        return out;
      },
      arg("geometry"), arg("theta"), arg("x"), arg("radius"),
      "Contacts of a sphere (centre x, m; radius, m) with the drum turned by theta (rad).");
}

}  // namespace millscope::bindings
