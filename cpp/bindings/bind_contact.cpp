// pybind11 glue for materials, pair constants, time-step criteria and the contact probe.
// No physics here.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <array>

#include <string>
#include <vector>

#include "millscope/contact_probe.hpp"
#include "millscope/materials.hpp"
#include "millscope/timestep.hpp"
#include "numpy_view.hpp"

namespace millscope::bindings {

namespace {

// A list of n rows of n numbers, flattened row-major; throws naming the first bad row.
std::vector<double> square(const std::vector<std::vector<double>>& rows, std::size_t n,
                           const char* name) {
  if (rows.size() != n) {
    throw std::invalid_argument(std::string(name) + " has " + std::to_string(rows.size()) +
                                " rows; it must be " + std::to_string(n) + " x " +
                                std::to_string(n) + " (one per pair of materials)");
  }
  std::vector<double> flat;
  flat.reserve(n * n);
  for (std::size_t i = 0; i < n; ++i) {
    if (rows[i].size() != n) {
      throw std::invalid_argument(std::string(name) + "[" + std::to_string(i) + "] has " +
                                  std::to_string(rows[i].size()) + " entries; it must have " +
                                  std::to_string(n));
    }
    flat.insert(flat.end(), rows[i].begin(), rows[i].end());
  }
  return flat;
}

// One evaluation of the law, for checks: the force, torques and the updated history.
struct ContactEvaluation {
  contact::PairForce pair;
  std::array<double, 3> history;
};

template <class Law>
ContactEvaluation evaluate_pair(const materials::PairConstants& p, const contact::SphereState& i,
                                const contact::SphereState* j, const contact::Vec3& normal,
                                double overlap, const contact::Vec3& wall_velocity,
                                std::array<double, 3> history, double dt) {
  ContactEvaluation out{};
  out.pair = j != nullptr
                 ? contact::sphere_sphere<Law>(p, i, *j, dt, history.data())
                 : contact::sphere_wall<Law>(p, i, normal, overlap, wall_velocity, dt,
                                             history.data());
  out.history = history;
  return out;
}

// `friction`: whether the pair's friction acts (the law without a tangential part if not).
ContactEvaluation evaluate(const materials::PairConstants& p, const contact::SphereState& i,
                           const contact::SphereState* j, const contact::Vec3& normal,
                           double overlap, const contact::Vec3& wall_velocity,
                           const std::array<double, 3>& history, double dt, bool friction,
                           bool clamp) {
  const contact::Law law = contact::choose_law(friction, p.restitution < 1.0, clamp);
  return contact::with_law(law, [&](auto tag) {
    return evaluate_pair<typename decltype(tag)::type>(p, i, j, normal, overlap, wall_velocity,
                                                       history, dt);
  });
}

}  // namespace

void register_contact(py::module_& m) {
  namespace mat = millscope::materials;
  namespace ts = millscope::timestep;
  namespace c = millscope::contact;
  using py::arg;

  py::class_<mat::Material>(m, "Material", "An elastic material (SI); validated on creation.")
      .def(py::init([](double density, double shear_modulus, double poisson) {
             const mat::Material x{density, shear_modulus, poisson};
             mat::validate(x, "material");
             return x;
           }),
           arg("density"), arg("shear_modulus"), arg("poisson"))
      .def_readonly("density", &mat::Material::density, "kg/m^3")
      .def_readonly("shear_modulus", &mat::Material::shear_modulus, "Pa")
      .def_readonly("poisson", &mat::Material::poisson)
      .def_property_readonly("youngs", &mat::Material::youngs, "E = 2 G (1 + nu), Pa");

  py::class_<mat::PairConstants>(m, "PairConstants", "Constants of a pair of materials.")
      .def_readonly("e_star", &mat::PairConstants::e_star, "E*, Pa")
      .def_readonly("g_star", &mat::PairConstants::g_star, "G*, Pa")
      .def_readonly("restitution", &mat::PairConstants::restitution)
      .def_readonly("beta", &mat::PairConstants::beta, "eq. 3")
      .def_readonly("friction", &mat::PairConstants::friction)
      .def_readonly("damping_factor", &mat::PairConstants::damping_factor,
                    "-2 sqrt(5/6) beta");

  m.def("pair_constants", &mat::make_pair_constants, arg("material_a"), arg("material_b"),
        arg("restitution"), arg("friction"));

  py::class_<mat::PairTable>(m, "PairTable", "Symmetric table of pair constants.")
      .def(py::init([](const std::vector<mat::Material>& materials,
                       const std::vector<std::vector<double>>& restitution,
                       const std::vector<std::vector<double>>& friction) {
             const std::size_t n = materials.size();
             return mat::PairTable(materials, square(restitution, n, "restitution"),
                                   square(friction, n, "friction"));
           }),
           arg("materials"), arg("restitution"), arg("friction"))
      .def_property_readonly("size", &mat::PairTable::size)
      .def("material", &mat::PairTable::material, arg("i"))
      .def("get", &mat::PairTable::at, arg("i"), arg("j"));

  m.def("reduced", &mat::reduced, arg("x_i"), arg("x_j"),
        "1 / (1/x_i + 1/x_j); x_j = inf (a wall) gives x_i");
  m.def("sphere_mass", &mat::sphere_mass, arg("density"), arg("radius"));

  m.def("rayleigh_time", &ts::rayleigh_time, arg("radius"), arg("density"),
        arg("shear_modulus"), arg("poisson"));
  m.def("hertz_contact_time", &ts::hertz_contact_time, arg("m_star"), arg("r_star"),
        arg("e_star"), arg("speed"));
  m.def("hertz_max_overlap", &ts::hertz_max_overlap, arg("m_star"), arg("r_star"), arg("e_star"),
        arg("speed"));
  m.def("hertz_stability_dt", &ts::hertz_stability_dt, arg("m_star"), arg("r_star"),
        arg("e_star"), arg("speed"));
  m.def("default_dt", &ts::default_dt, arg("min_rayleigh_time"));
  m.def("stable_dt_limit", &ts::stable_dt_limit, arg("min_rayleigh_time"));
  m.def("require_stable_dt", &ts::require_stable_dt, arg("dt"), arg("min_rayleigh_time"));
  m.attr("DEFAULT_DT_FRACTION") = ts::default_dt_fraction;
  m.attr("MAX_DT_FRACTION") = ts::max_dt_fraction;

  py::class_<ContactEvaluation>(m, "ContactEvaluation", "One evaluation of the contact law.")
      .def_property_readonly("touching", [](const ContactEvaluation& e) { return e.pair.touching; })
      .def_property_readonly("overlap", [](const ContactEvaluation& e) { return e.pair.overlap; })
      .def_property_readonly("n", [](const ContactEvaluation& e) { return c::Vec3(e.pair.n); })
      .def_property_readonly("force_i",
                             [](const ContactEvaluation& e) { return c::Vec3(e.pair.force_i); })
      .def_property_readonly("torque_i",
                             [](const ContactEvaluation& e) { return c::Vec3(e.pair.torque_i); })
      .def_property_readonly("torque_j",
                             [](const ContactEvaluation& e) { return c::Vec3(e.pair.torque_j); })
      .def_property_readonly("normal", [](const ContactEvaluation& e) { return e.pair.normal; })
      .def_property_readonly(
          "tangential", [](const ContactEvaluation& e) { return c::Vec3(e.pair.tangential); })
      .def_property_readonly("sliding", [](const ContactEvaluation& e) { return e.pair.sliding; })
      .def_readonly("history", &ContactEvaluation::history);

  m.def(
      "sphere_contact",
      [](const mat::PairConstants& p, const c::Vec3& x_i, const c::Vec3& v_i, const c::Vec3& w_i,
         double radius_i, double mass_i, const c::Vec3& x_j, const c::Vec3& v_j,
         const c::Vec3& w_j, double radius_j, double mass_j, const std::array<double, 3>& history,
         double dt, bool friction, bool clamp_normal) {
        const c::SphereState i{x_i, v_i, w_i, radius_i, mass_i};
        const c::SphereState j{x_j, v_j, w_j, radius_j, mass_j};
        return evaluate(p, i, &j, c::Vec3::Zero(), 0.0, c::Vec3::Zero(), history, dt, friction,
                        clamp_normal);
      },
      arg("constants"), arg("x_i"), arg("v_i"), arg("w_i"), arg("radius_i"), arg("mass_i"),
      arg("x_j"), arg("v_j"), arg("w_j"), arg("radius_j"), arg("mass_j"), arg("history"),
      arg("dt"), arg("friction") = true, arg("clamp_normal") = false,
      "Sphere i against sphere j: one evaluation of the contact law (history: d_t).");

  m.def(
      "wall_contact",
      [](const mat::PairConstants& p, const c::Vec3& x_i, const c::Vec3& v_i, const c::Vec3& w_i,
         double radius_i, double mass_i, const c::Vec3& normal, double overlap,
         const c::Vec3& wall_velocity, const std::array<double, 3>& history, double dt,
         bool friction, bool clamp_normal) {
        const c::SphereState i{x_i, v_i, w_i, radius_i, mass_i};
        return evaluate(p, i, nullptr, normal, overlap, wall_velocity, history, dt, friction,
                        clamp_normal);
      },
      arg("constants"), arg("x_i"), arg("v_i"), arg("w_i"), arg("radius_i"), arg("mass_i"),
      arg("normal"), arg("overlap"), arg("wall_velocity"), arg("history"), arg("dt"),
      arg("friction") = true, arg("clamp_normal") = false,
      "Sphere i against a wall (normal from the wall into i, wall velocity at the contact).");

  py::class_<c::ProbeResult>(m, "ProbeResult", "One impact integrated on its own.")
      .def_readonly("restitution", &c::ProbeResult::restitution)
      .def_readonly("contact_time", &c::ProbeResult::contact_time)
      .def_readonly("max_overlap", &c::ProbeResult::max_overlap)
      .def_readonly("tangential_velocity", &c::ProbeResult::tangential_velocity)
      .def_readonly("spin_a", &c::ProbeResult::spin_a)
      .def_readonly("spin_b", &c::ProbeResult::spin_b)
      .def_readonly("slip_velocity", &c::ProbeResult::slip_velocity)
      .def_readonly("normal_impulse", &c::ProbeResult::normal_impulse)
      .def_readonly("normal_impulse_abs", &c::ProbeResult::normal_impulse_abs)
      .def_readonly("tangential_impulse", &c::ProbeResult::tangential_impulse)
      .def_readonly("kinetic_energy_before", &c::ProbeResult::kinetic_energy_before)
      .def_readonly("kinetic_energy_after", &c::ProbeResult::kinetic_energy_after)
      .def_readonly("contact_steps", &c::ProbeResult::contact_steps)
      .def_readonly("sliding_steps", &c::ProbeResult::sliding_steps)
      .def_readonly("dt", &c::ProbeResult::dt)
      .def_readonly("r_star", &c::ProbeResult::r_star)
      .def_readonly("m_star", &c::ProbeResult::m_star)
      .def_readonly("hertz_contact_time", &c::ProbeResult::hertz_contact_time)
      .def_readonly("hertz_max_overlap", &c::ProbeResult::hertz_max_overlap);

  m.def(
      "contact_probe",
      [](const mat::Material& material_a, const mat::Material& material_b, bool wall,
         double radius_a, double radius_b, double restitution, double friction, double speed,
         double tangential_speed, double spin, double dt, bool clamp_normal) {
        c::ProbeSetup s;
        s.material_a = material_a;
        s.material_b = material_b;
        s.wall = wall;
        s.radius_a = radius_a;
        s.radius_b = radius_b;
        s.restitution = restitution;
        s.friction = friction;
        s.speed = speed;
        s.tangential_speed = tangential_speed;
        s.spin = spin;
        s.dt = dt;
        s.clamp = clamp_normal ? c::NormalClamp::nonnegative : c::NormalClamp::none;
        py::gil_scoped_release release;
        return c::contact_probe(s);
      },
      arg("material_a"), arg("material_b"), arg("wall"), arg("radius_a"), arg("radius_b"),
      arg("restitution"), arg("friction"), arg("speed"), arg("tangential_speed"), arg("spin"),
      arg("dt"), arg("clamp_normal"));
}

}  // namespace millscope::bindings
