// pybind11 glue for the drum geometry (millscope::drum): used by tests and diagnostics.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <optional>

#include "millscope/drum.hpp"
#include "numpy_view.hpp"

namespace millscope::bindings {

void register_drum(py::module_& m) {
  namespace dr = millscope::drum;
  using py::arg;

  py::class_<dr::Geometry>(m, "DrumGeometry")
      .def(py::init([](double radius, double length, bool end_walls, int lifters,
                       double lifter_width, double lifter_height, double lifter_phase,
                       std::optional<double> lifter_top_width) {
             // None: rectangular lifters. In C++ that is a top width <= 0, so a number given
             // here must be > 0 to mean what it says.
             if (lifters > 0 && lifter_top_width && !(*lifter_top_width > 0.0))
               dr::invalid_field("lifter_top_width", *lifter_top_width,
                                 "in (0, lifter_width] m, or None for rectangular lifters");
             dr::Geometry g{radius,       length,        end_walls,   lifters,
                            lifter_width, lifter_height, lifter_phase};
             g.lifter_top_width = lifter_top_width.value_or(0.0);
             g.validate();
             return g;
           }),
           arg("radius"), arg("length"), arg("end_walls"), arg("lifters"), arg("lifter_width"),
           arg("lifter_height"), arg("lifter_phase") = 0.0, arg("lifter_top_width") = py::none(),
           "Drum of inner radius and length (m) with `lifters` lifters of base width "
           "`lifter_width` (at the shell) and radial height `lifter_height` (m); "
           "`lifter_top_width` (m, at the tip) makes them trapezoidal, None rectangular.")
      .def_readonly("radius", &dr::Geometry::radius)
      .def_readonly("length", &dr::Geometry::length)
      .def_readonly("end_walls", &dr::Geometry::end_walls)
      .def_readonly("lifters", &dr::Geometry::lifters)
      .def_readonly("lifter_width", &dr::Geometry::lifter_width)
      .def_readonly("lifter_height", &dr::Geometry::lifter_height)
      .def_readonly("lifter_phase", &dr::Geometry::lifter_phase)
      .def_property_readonly("lifter_top_width", &dr::Geometry::tip_width,
                             "Width at the lifters' tip, m (lifter_width when rectangular).");

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
