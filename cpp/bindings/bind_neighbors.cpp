// pybind11 glue for the neighbour list (tests and diagnostics; the engine uses it directly).
#include "millscope/neighbors.hpp"
#include "numpy_view.hpp"

namespace millscope::bindings {

namespace {
/// The count of spheres given as centres x, y, z and radii r, which must be 1-D and alike.
std::size_t spheres_count(const InArray& x, const InArray& y, const InArray& z,
                          const InArray& r) {
  const auto n = static_cast<std::size_t>(x.ndim() == 1 ? x.shape(0) : 0);
  for (const auto* a : {&x, &y, &z, &r})
    if (a->ndim() != 1 || static_cast<std::size_t>(a->shape(0)) != n)
      throw std::invalid_argument("x, y, z and r must be 1-D arrays of equal length");
  return n;
}
}  // namespace

void register_neighbors(py::module_& m) {
  namespace nb = millscope::neighbors;
  using py::arg;

  py::class_<nb::VerletList>(m, "VerletList",
                             "Half Verlet list with a skin over a cell grid; history per pair.")
      .def(py::init<double, std::size_t, double>(), arg("skin"), arg("history_size"),
           arg("period_z") = 0.0)
      .def(
          "build",
          [](nb::VerletList& self, const InArray& x, const InArray& y, const InArray& z,
             const InArray& r, int team) {
            const std::size_t n = spheres_count(x, y, z, r);
            if (team < 1)
              throw std::invalid_argument("team = " + std::to_string(team) +
                                          " is not valid; it must be >= 1");
            const double *px = data_1d(x, "x"), *py_ = y.data(), *pz = z.data(), *pr = r.data();
            py::gil_scoped_release release;
            // the phases of the engine's parallel build, its threads' blocks taken in turn
            self.build(px, py_, pz, pr, n, nullptr, team);
          },
          arg("x"), arg("y"), arg("z"), arg("r"), arg("team") = 1,
          "Rebuilds the list; `team` > 1 builds it in that many blocks of rows, in the phases "
          "the engine's threads run in parallel (the list is the same).")
      .def(
          "spatial_order",
          [](nb::VerletList& self, const InArray& x, const InArray& y, const InArray& z,
             const InArray& r) {
            const std::size_t n = spheres_count(x, y, z, r);
            return to_numpy(
                self.spatial_order(data_1d(x, "x"), y.data(), z.data(), r.data(), n));
          },
          arg("x"), arg("y"), arg("z"), arg("r"),
          "The particles cell by cell (the order the engine stores them in at a list build): "
          "order[k] is the particle to store at k.")
      .def("pairs",
           [](const nb::VerletList& self) {
             const auto& start = self.start();
             py::array_t<std::int64_t> out({static_cast<py::ssize_t>(self.pairs()),
                                            static_cast<py::ssize_t>(2)});
             auto v = out.mutable_unchecked<2>();
             py::ssize_t row = 0;
             for (std::size_t i = 0; i + 1 < start.size(); ++i)
               for (auto s = start[i]; s < start[i + 1]; ++s, ++row) {
                 v(row, 0) = static_cast<std::int64_t>(i);
                 v(row, 1) = static_cast<std::int64_t>(self.partner()[s]);
               }
             return out;
           },
           "(M, 2) array of the listed pairs i < j, row by row")
      .def_property(
          "history",
          [](const nb::VerletList& self) {
            py::array_t<double> out({static_cast<py::ssize_t>(self.pairs()),
                                     static_cast<py::ssize_t>(self.history_size())});
            std::copy(self.history().begin(), self.history().end(), out.mutable_data());
            return out;
          },
          [](nb::VerletList& self, const py::array_t<double, py::array::c_style |
                                                                 py::array::forcecast>& h) {
            if (static_cast<std::size_t>(h.size()) != self.history().size())
              throw std::invalid_argument("history must have pairs x history_size values");
            std::copy(h.data(), h.data() + h.size(), self.history().begin());
          })
      .def_property_readonly("builds", &nb::VerletList::builds)
      .def_property_readonly("skin", &nb::VerletList::skin);
}

}  // namespace millscope::bindings
