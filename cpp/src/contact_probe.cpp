#include "millscope/contact_probe.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "millscope/timestep.hpp"

namespace millscope::contact {
namespace {

void require(bool ok, const char* name, double value, const char* range) {
  if (!ok) {
    std::ostringstream msg;
    msg << name << " = " << value << " is not valid; it must be " << range;
    throw std::invalid_argument(msg.str());
  }
}

struct Body {
  SphereState s;
  double inertia;  // 2/5 m r^2
};

Body sphere(const materials::Material& m, double radius) {
  const double mass = materials::sphere_mass(m.density, radius);
  return Body{SphereState{Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), radius, mass},
              0.4 * mass * radius * radius};
}

double kinetic_energy(const Body& b) {
  return 0.5 * b.s.mass * b.s.v.squaredNorm() + 0.5 * b.inertia * b.s.w.squaredNorm();
}

// Half a velocity-Verlet kick.
void kick(Body& b, const Vec3& force, const Vec3& torque, double half_dt) {
  b.s.v += (half_dt / b.s.mass) * force;
  b.s.w += (half_dt / b.inertia) * torque;
}

template <class Law>
ProbeResult run(const ProbeSetup& su, const materials::PairConstants& p, ProbeResult r) {
  const Vec3 ey = Vec3::UnitY();
  const Vec3 ex = Vec3::UnitX();
  Body a = sphere(su.material_a, su.radius_a);
  Body b = sphere(su.material_b, su.wall ? 1.0 : su.radius_b);  // b is not moved for a wall
  a.s.x = Vec3(0.0, su.radius_a + (su.wall ? 0.0 : su.radius_b), 0.0);  // just touching
  a.s.v = Vec3(su.tangential_speed, -su.speed, 0.0);
  a.s.w = Vec3(0.0, 0.0, su.spin);
  r.kinetic_energy_before = kinetic_energy(a) + (su.wall ? 0.0 : kinetic_energy(b));

  const double dt = su.dt;
  const double half = 0.5 * dt;
  double history[Law::history_size > 0 ? Law::history_size : 1] = {};
  Vec3 force = Vec3::Zero(), torque_a = Vec3::Zero(), torque_b = Vec3::Zero();
  Vec3 normal = ey;
  double o_prev = 0.0;  // overlap of the previous step (0 at t = 0: just touching)
  double o_best = -1.0, o_before = 0.0, o_after = 0.0;
  bool best_is_last = false;
  const long max_steps = static_cast<long>(100.0 * r.hertz_contact_time / dt) + 1000;
  long step = 0;
  for (;;) {
    if (++step > max_steps) {
      throw std::runtime_error("contact probe: the contact did not end within " +
                               std::to_string(max_steps) + " steps");
    }
    kick(a, force, torque_a, half);
    if (!su.wall) kick(b, -force, torque_b, half);
    a.s.x += dt * a.s.v;
    if (!su.wall) b.s.x += dt * b.s.v;

    PairForce c;
    if (su.wall) {
      c = sphere_wall<Law>(p, a.s, ey, su.radius_a - a.s.x.y(), Vec3::Zero(), dt, history);
    } else {
      c = sphere_sphere<Law>(p, a.s, b.s, dt, history);
    }
    force = c.force_i;
    torque_a = c.torque_i;
    torque_b = c.torque_j;
    kick(a, force, torque_a, half);
    if (!su.wall) kick(b, -force, torque_b, half);

    const double o = c.overlap;
    if (best_is_last) {
      o_after = o;
      best_is_last = false;
    }
    if (!c.touching) {
      // Separation between the previous step (overlap o_prev > 0) and this one (o <= 0).
      r.contact_time = dt * (static_cast<double>(step - 1) + o_prev / (o_prev - o));
      break;
    }
    normal = c.n;
    ++r.contact_steps;
    if (c.sliding) ++r.sliding_steps;
    r.normal_impulse += c.normal * dt;
    r.normal_impulse_abs += std::abs(c.normal) * dt;
    r.tangential_impulse += c.tangential.dot(ex) * dt;
    if (o > o_best) {
      o_best = o;
      o_before = o_prev;
      best_is_last = true;
    }
    o_prev = o;
  }
  // Parabola through (o_before, o_best, o_after) at consecutive steps; its vertex.
  const double curvature = o_before - 2.0 * o_best + o_after;
  r.max_overlap = curvature < 0.0
                      ? o_best - (o_after - o_before) * (o_after - o_before) / (8.0 * curvature)
                      : o_best;

  const Vec3 v_rel = a.s.v - b.s.v;
  const Vec3 cp_rel = v_rel + a.s.w.cross(-su.radius_a * normal) -
                      (su.wall ? Vec3::Zero() : Vec3(b.s.w.cross(su.radius_b * normal)));
  r.restitution = v_rel.dot(normal) / su.speed;
  const Vec3 t = normal.cross(Vec3::UnitZ());
  r.tangential_velocity = v_rel.dot(t);
  r.slip_velocity = cp_rel.dot(t);
  r.spin_a = a.s.w.z();
  r.spin_b = su.wall ? 0.0 : b.s.w.z();
  r.kinetic_energy_after = kinetic_energy(a) + (su.wall ? 0.0 : kinetic_energy(b));
  return r;
}

}  // namespace

ProbeResult contact_probe(const ProbeSetup& su) {
  materials::validate(su.material_a, "material_a");
  materials::validate(su.material_b, "material_b");
  require(std::isfinite(su.radius_a) && su.radius_a > 0.0, "radius_a", su.radius_a,
          "finite and > 0 m");
  if (!su.wall) {
    require(std::isfinite(su.radius_b) && su.radius_b > 0.0, "radius_b", su.radius_b,
            "finite and > 0 m");
  }
  require(std::isfinite(su.speed) && su.speed > 0.0, "speed", su.speed, "finite and > 0 m/s");
  require(std::isfinite(su.tangential_speed), "tangential_speed", su.tangential_speed,
          "finite (m/s)");
  require(std::isfinite(su.spin), "spin", su.spin, "finite (rad/s)");
  const materials::PairConstants p =
      materials::make_pair_constants(su.material_a, su.material_b, su.restitution, su.friction);

  ProbeResult r{};
  const double m_a = materials::sphere_mass(su.material_a.density, su.radius_a);
  const materials::ContactScales sc =
      su.wall ? materials::wall_scales(su.radius_a, m_a)
              : materials::sphere_scales(su.radius_a, m_a, su.radius_b,
                                         materials::sphere_mass(su.material_b.density,
                                                                su.radius_b));
  r.r_star = sc.r_star;
  r.m_star = sc.m_star;
  r.hertz_contact_time = timestep::hertz_contact_time(sc.m_star, sc.r_star, p.e_star, su.speed);
  r.hertz_max_overlap = timestep::hertz_max_overlap(sc.m_star, sc.r_star, p.e_star, su.speed);
  if (!(std::isfinite(su.dt) && su.dt > 0.0 && su.dt < r.hertz_contact_time)) {
    std::ostringstream msg;
    msg << "dt = " << su.dt << " s is not valid; it must be > 0 and below the elastic Hertz "
        << "contact time " << r.hertz_contact_time << " s of this impact";
    throw std::invalid_argument(msg.str());
  }
  if (r.hertz_contact_time / su.dt > 1e8) {
    std::ostringstream msg;
    msg << "dt = " << su.dt << " s is not valid; the contact would take about "
        << r.hertz_contact_time / su.dt << " steps, more than 1e8";
    throw std::invalid_argument(msg.str());
  }
  r.dt = su.dt;

  const Law law = choose_law(p.friction > 0.0, p.restitution < 1.0,
                            su.clamp == NormalClamp::nonnegative);
  return with_law(law, [&](auto tag) { return run<typename decltype(tag)::type>(su, p, r); });
}

}  // namespace millscope::contact
