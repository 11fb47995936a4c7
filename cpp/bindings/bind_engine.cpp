// pybind11 glue for the DEM engine (millscope::engine). The GIL is released while it steps.
#include <pybind11/stl.h>

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>

#include "millscope/engine.hpp"
#include "numpy_view.hpp"

namespace millscope::bindings {

namespace {

namespace en = millscope::engine;

// An (n, 3) float64 array read in place.
const double* data_n3(const InArray& a, std::size_t n, const char* name) {
  if (a.ndim() != 2 || static_cast<std::size_t>(a.shape(0)) != n || a.shape(1) != 3) {
    throw std::invalid_argument(std::string(name) + " must have shape (" + std::to_string(n) +
                                ", 3)");
  }
  return a.data();
}

template <class T>
py::array_t<T> as_n3(std::vector<T>&& v) {
  const auto rows = static_cast<py::ssize_t>(v.size() / 3);
  auto flat = to_numpy(std::move(v));
  return flat.reshape({rows, static_cast<py::ssize_t>(3)});
}

template <class T>
struct is_vector : std::false_type {};
template <class T>
struct is_vector<std::vector<T>> : std::true_type {};

template <class T>
std::vector<T> vector_of(const py::dict& d, const char* key) {
  if (!d.contains(key)) throw std::invalid_argument(std::string("the snapshot has no '") + key + "'");
  auto a = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(d[key]);
  if (!a) throw std::invalid_argument(std::string("the snapshot's '") + key + "' is not an array");
  return std::vector<T>(a.data(), a.data() + a.size());
}

template <class T>
T scalar_of(const py::dict& d, const char* key) {
  if (!d.contains(key)) throw std::invalid_argument(std::string("the snapshot has no '") + key + "'");
  return py::cast<T>(d[key]);
}

// A snapshot's fields into a dict: arrays as numpy arrays, the torque and ledger as tuples.
struct SnapshotToPython {
  py::dict& d;
  template <class T>
  void operator()(const char* key, std::vector<T>& v) const {
    d[key] = to_numpy(std::move(v));
  }
  template <class T>
  void operator()(const char* key, const T& value) const {
    d[key] = value;
  }
  void operator()(const char* key, const en::Torque& t) const {
    d[key] = py::make_tuple(t.total, t.shell, t.lifters, t.ends);
  }
  void operator()(const char* key, const en::Ledger& l) const {
    d[key] = py::make_tuple(l.drive_work, l.damping_loss, l.friction_loss, l.dissipated,
                            l.spring_work);
  }
};

// ... and back; the restore checks the values against the engine.
struct SnapshotFromPython {
  const py::dict& d;
  template <class T>
  void operator()(const char* key, std::vector<T>& v) const {
    v = vector_of<T>(d, key);
  }
  template <class T>
  void operator()(const char* key, T& value) const {
    value = scalar_of<T>(d, key);
  }
  void operator()(const char* key, en::Torque& t) const {
    const auto v = scalar_of<std::vector<double>>(d, key);
    if (v.size() != 4)
      throw std::invalid_argument("the snapshot's torque or ledger has the wrong length");
    t = en::Torque{v[0], v[1], v[2], v[3]};
  }
  void operator()(const char* key, en::Ledger& l) const {
    const auto v = scalar_of<std::vector<double>>(d, key);
    // a ledger of 4 is a checkpoint from before spring_work was booked
    if (v.size() != 4 && v.size() != 5)
      throw std::invalid_argument("the snapshot's torque or ledger has the wrong length");
    l = en::Ledger{v[0], v[1], v[2], v[3], v.size() == 5 ? v[4] : 0.0};
  }
};

// The keys of the snapshot's arrays (Engine::Snapshot::for_each_field), in its order.
py::tuple snapshot_arrays() {
  py::list keys;
  en::Engine::Snapshot s;
  en::Engine::Snapshot::for_each_field(s, [&](const char* key, const auto& field) {
    if constexpr (is_vector<std::decay_t<decltype(field)>>::value) keys.append(key);
  });
  return py::tuple(keys);
}

py::dict torque_dict(const en::Torque& t) {
  py::dict d;
  d["total"] = t.total;
  d["shell"] = t.shell;
  d["lifters"] = t.lifters;
  d["ends"] = t.ends;
  return d;
}

}  // namespace

void register_engine(py::module_& m) {
  using py::arg;
  using IntArray = py::array_t<int, py::array::c_style | py::array::forcecast>;

  m.attr("GUARD_INTERVAL") = en::guard_interval;  // steps between the state guards' looks
  m.attr("WIDE_BLOCK_LISTED") = en::wide_block_listed;  // listed pairs in a wide-search block
  m.def("simd_paths", &en::simd_paths,
        "The SIMD paths of the engine's vector kernels this build runs on this CPU, widest "
        "first; 'portable' (one listed pair at a time) last");
  m.def(
      "simd_path",
      [](const std::string& name) {
        const en::SimdPath p = en::simd_path(name);
        return py::make_tuple(p.name, p.pair_lanes);
      },
      arg("name") = "",
      "(name, listed pairs the pair search tests at once) of a SIMD path; '' for the default: "
      "the environment's MILLSCOPE_SIMD where set, else the widest");
  m.attr("SNAPSHOT_ARRAYS") = snapshot_arrays();  // Engine.snapshot()'s arrays, by key
  py::class_<en::Engine>(m, "Engine", "The DEM engine: state, step loop, torque (engine.hpp).")
      .def(py::init([](std::vector<materials::Material> materials, const InArray& restitution,
                       const InArray& friction, int drum_material, const drum::Geometry& geometry,
                       const InArray& radius, const IntArray& material, double dt, double gravity,
                       double skin, bool clamp_normal, int threads, bool reorder,
                       bool track_energy, double max_speed, double max_overlap,
                       std::string simd, std::optional<bool> prefetch_partners) {
             en::Config c;
             c.materials = std::move(materials);
             c.restitution.assign(restitution.data(), restitution.data() + restitution.size());
             c.friction.assign(friction.data(), friction.data() + friction.size());
             c.drum_material = drum_material;
             c.geometry = geometry;
             const double* r = data_1d(radius, "radius");
             c.radius.assign(r, r + radius.size());
             if (material.ndim() != 1) throw std::invalid_argument("material must be 1-D");
             c.material.assign(material.data(), material.data() + material.size());
             c.dt = dt;
             c.gravity = gravity;
             c.skin = skin;
             c.clamp_normal = clamp_normal;
             c.reorder = reorder;
             c.track_energy = track_energy;
             c.threads = threads;
             c.max_speed = max_speed;
             c.max_overlap = max_overlap;
             c.simd = std::move(simd);
             c.prefetch_partners = prefetch_partners;
             return en::Engine(std::move(c));
           }),
           arg("materials"), arg("restitution"), arg("friction"), arg("drum_material"),
           arg("geometry"), arg("radius"), arg("material"), arg("dt"), arg("gravity") = 9.81,
           arg("skin") = 0.0, arg("clamp_normal") = false, arg("threads") = 1,
           arg("reorder") = true, arg("track_energy") = true,
           arg("max_speed") = std::numeric_limits<double>::infinity(), arg("max_overlap") = 0.5,
           arg("simd") = "", arg("prefetch_partners") = py::none())
      .def_property_readonly("size", &en::Engine::size)
      .def_property_readonly("dt", &en::Engine::dt)
      .def_property_readonly("threads", &en::Engine::threads)
      .def_property("running_threads", &en::Engine::running_threads,
                    &en::Engine::set_running_threads,
                    "The threads that run the threads' shares of each step, in [1, threads]; "
                    "the results are the same to the bit whatever it is")
      .def_property_readonly("variant", [](const en::Engine& e) { return e.variant().describe(); })
      .def_property_readonly("track_energy",
                             [](const en::Engine& e) { return e.variant().track_energy; },
                             "Whether the step books the dissipated energy (a law that dissipates)")
      .def_property_readonly("history_size", &en::Engine::history_size,
                             "Doubles of contact history per pair and per wall slot (the law's)")
      .def_property_readonly("skin", &en::Engine::skin)
      .def_property_readonly("max_speed", &en::Engine::max_speed,
                             "Guard: the speed no particle may exceed, m/s")
      .def_property_readonly("max_overlap", &en::Engine::max_overlap,
                             "Guard: the deepest contact allowed, a fraction of the smaller radius")
      .def_property_readonly("simd", [](const en::Engine& e) { return e.simd().name; },
                             "The SIMD path of the vector kernels (simd_paths()): asked for, or "
                             "the environment's MILLSCOPE_SIMD, or the widest; the results are "
                             "the same on every path")
      .def_property_readonly("wide_pair_search", &en::Engine::wide_pair_search,
                             "Whether the pair pass finds its touching pairs a vector at a time "
                             "(a SIMD path other than 'portable', and the paper's law without "
                             "the energy ledger); the results are the same either way")
      .def_property_readonly("prefetch_partners", &en::Engine::prefetch_partners,
                             "Whether the wide search asks ahead for the partners' state: asked "
                             "for, or (prefetch_partners=None) while the engine holds more bytes "
                             "than the CPU's last-level cache; the results are the same either "
                             "way")
      .def_property_readonly("list_builds", &en::Engine::list_builds)
      .def_property_readonly("list_pairs", &en::Engine::list_pairs)
      .def_property_readonly("thread_rows", &en::Engine::thread_rows,
                             "Thread t's list rows in the pair pass: [thread_rows[t], "
                             "thread_rows[t+1]), in storage order")
      .def_property_readonly("thread_particles", &en::Engine::thread_particles,
                             "Thread t's particles in the particle pass and the kick and drift: "
                             "[thread_particles[t], thread_particles[t+1]), in storage order")
      .def_property_readonly("bytes_per_particle", &en::Engine::bytes_per_particle)
      .def_property_readonly("step_count", &en::Engine::step_count)
      .def_property_readonly("time", &en::Engine::time)
      .def_property_readonly("drum_angle", &en::Engine::drum_angle)
      .def_property_readonly("omega", &en::Engine::omega)
      .def_property_readonly("rotation_start_step", &en::Engine::rotation_start_step)
      .def("start_rotation", &en::Engine::start_rotation, arg("omega"))
      .def_property(
          "positions", [](const en::Engine& e) { return as_n3(e.positions()); },
          [](en::Engine& e, const InArray& a) { e.set_positions(data_n3(a, e.size(), "positions")); })
      .def_property(
          "velocities", [](const en::Engine& e) { return as_n3(e.velocities()); },
          [](en::Engine& e, const InArray& a) { e.set_velocities(data_n3(a, e.size(), "velocities")); })
      .def_property(
          "spins", [](const en::Engine& e) { return as_n3(e.spins()); },
          [](en::Engine& e, const InArray& a) { e.set_spins(data_n3(a, e.size(), "spins")); })
      .def_property_readonly("radius", [](const en::Engine& e) { return to_numpy(std::vector<double>(e.radius())); })
      .def_property_readonly("mass", [](const en::Engine& e) { return to_numpy(std::vector<double>(e.mass())); })
      .def("advance", &en::Engine::advance, arg("steps"), py::call_guard<py::gil_scoped_release>())
      .def(
          "advance_sampled",
          [](en::Engine& e, double sample_dt, bool mean, long count, long max_steps,
             bool resume) {
            std::vector<double> rows;
            {
              py::gil_scoped_release release;
              rows = e.advance_sampled(sample_dt, mean, count, max_steps, resume);
            }
            const auto n = static_cast<py::ssize_t>(rows.size() / 9);
            return to_numpy(std::move(rows)).reshape({n, static_cast<py::ssize_t>(9)});
          },
          arg("sample_dt"), arg("mean"), arg("count"),
          arg("max_steps") = std::numeric_limits<long>::max(), arg("resume") = false,
          "Steps until `count` torque samples are taken or `max_steps` steps were run; with "
          "`resume`, goes on with the sample under way of the previous call. Rows (t, total, "
          "shell, lifters, ends) in the mode asked for (`mean`: the interval means, else the "
          "torque of the step nearest t), then (total, shell, lifters, ends) in the other mode.")
      .def("torque", [](const en::Engine& e) { return torque_dict(e.torque()); })
      .def("ledger",
           [](const en::Engine& e) {
             py::dict d;
             d["drive_work"] = e.ledger().drive_work;
             d["damping_loss"] = e.ledger().damping_loss;
             d["friction_loss"] = e.ledger().friction_loss;
             d["dissipated"] = e.ledger().dissipated;
             d["spring_work"] = e.ledger().spring_work;
             return d;
           })
      .def("kinetic_energy", &en::Engine::kinetic_energy)
      .def("potential_energy", &en::Engine::potential_energy)
      .def("elastic_energy", &en::Engine::elastic_energy)
      .def("max_overlap_ratio", &en::Engine::max_overlap_ratio)
      .def("snapshot",
           [](const en::Engine& e) {
             en::Engine::Snapshot s = e.snapshot();
             py::dict d;
             en::Engine::Snapshot::for_each_field(s, SnapshotToPython{d});
             return d;
           },
           "Every array and scalar needed to continue the run bit for bit (a checkpoint).")
      .def(
          "restore",
          [](en::Engine& e, const py::dict& d) {
            en::Engine::Snapshot s;
            en::Engine::Snapshot::for_each_field(s, SnapshotFromPython{d});
            e.restore(s);
          },
          arg("snapshot"));
}

}  // namespace millscope::bindings
