// Time-step criteria (docs/physics.md, Time step): Rayleigh time, Hertz contact time and
// overlap, and the default and largest accepted time step.
//
// Why the Rayleigh time sets the limit, and why 0.5 T_R: velocity Verlet on a linear spring of
// angular frequency w is stable for dt < 2/w. A Hertz contact stiffens as it loads; at its largest
// overlap d_max its tangent stiffness S_n = 2 E* sqrt(R* d_max) gives w_max = sqrt(S_n / m*),
// and the impact lasts t_c ~ 4/w_max. Both scale like (c_s / v)^(1/5) Rayleigh times, c_s =
// sqrt(G/rho) the shear-wave speed, so the margin a fraction of T_R leaves depends only weakly on
// the impact speed v. For head-on impacts of like spheres (a wall contact: about 13 % less):
//     v / c_s     t_c / T_R    (2/w_max) / T_R      e.g.
//     0.0006      5.0          2.5                  steel 2 m/s (Table 2 moduli)
//     0.0066      3.2          1.6                  ceramic 5 m/s
//     0.04        2.2          1.1                  ceramic 30 m/s
//     0.14        1.7          0.83                 steel 5 m/s with G reduced to 10 MPa
// At dt = 0.5 T_R a single contact is stable with a margin of 2 or more and spans at least ~4
// steps for v < 0.05 c_s, which covers every impact in a ball mill with real moduli (a few m/s
// against c_s of 750-3200 m/s). A particle in a dense bed has several contacts at once, which
// raises its highest frequency by up to about sqrt(coordination) ~ 2-3: hence a margin of 2
// is the least to accept, and the default 0.2 T_R (10 or more steps per impact; EDEM's usual
// 20-40 %) is what results should be computed with. This cap covers the undamped normal mode
// only: damping and the tangential stick mode coupled with rotation (about sqrt(3.5) faster,
// damped by the pair's restitution) lower the bound, and with a reduced shear modulus they set
// it below 0.5 T_R. The Python layer derives the limit from those modes for each scene
// (millscope.stiffness.time_step_limit) and refuses a step above it before the engine is made;
// this cap is the engine's last line.
#pragma once

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "millscope/materials.hpp"

namespace millscope::timestep {

/// Default time step as a fraction of the smallest Rayleigh time of the charge.
inline constexpr double default_dt_fraction = 0.2;
/// Largest accepted time step as a fraction of the smallest Rayleigh time (see above).
inline constexpr double max_dt_fraction = 0.5;

namespace detail {
inline void require_positive(double x, const char* name, const char* unit) {
  if (!(std::isfinite(x) && x > 0.0)) {
    std::ostringstream msg;
    msg << name << " = " << x << unit << " is not valid; it must be finite and > 0";
    throw std::invalid_argument(msg.str());
  }
}
}  // namespace detail

/// Rayleigh time T_R = pi r sqrt(rho/G) / (0.1631 nu + 0.8766), s, of a sphere of radius r (m).
inline double rayleigh_time(double radius, double density, double shear_modulus, double poisson) {
  detail::require_positive(radius, "radius", " m");
  materials::validate(materials::Material{density, shear_modulus, poisson}, "material");
  return materials::pi * radius * std::sqrt(density / shear_modulus) /
         (0.1631 * poisson + 0.8766);
}

/// Largest overlap of an elastic head-on Hertz impact at approach speed v:
/// d_max = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5), m.
inline double hertz_max_overlap(double m_star, double r_star, double e_star, double speed) {
  detail::require_positive(m_star, "m_star", " kg");
  detail::require_positive(r_star, "r_star", " m");
  detail::require_positive(e_star, "e_star", " Pa");
  detail::require_positive(speed, "speed", " m/s");
  return std::pow(15.0 * m_star * speed * speed / (16.0 * e_star * std::sqrt(r_star)), 0.4);
}

/// Duration of an elastic head-on Hertz impact at approach speed v:
/// t_c = 2.87 (m*^2 / (R* E*^2 v))^(1/5), s. (The exact factor is 2.8683 = 2.9432 (15/16)^(2/5);
/// 2.87 is the rounded value the literature quotes, 0.06 % higher.)
inline double hertz_contact_time(double m_star, double r_star, double e_star, double speed) {
  detail::require_positive(m_star, "m_star", " kg");
  detail::require_positive(r_star, "r_star", " m");
  detail::require_positive(e_star, "e_star", " Pa");
  detail::require_positive(speed, "speed", " m/s");
  return 2.87 * std::pow(m_star * m_star / (r_star * e_star * e_star * speed), 0.2);
}

/// The velocity-Verlet stability limit 2 / w_max of an elastic head-on Hertz impact at speed v,
/// w_max^2 = S_n(d_max) / m* = 2 E* sqrt(R* d_max) / m*, s.
inline double hertz_stability_dt(double m_star, double r_star, double e_star, double speed) {
  const double d_max = hertz_max_overlap(m_star, r_star, e_star, speed);
  return 2.0 / std::sqrt(2.0 * e_star * std::sqrt(r_star * d_max) / m_star);
}

/// The default time step, default_dt_fraction x the smallest Rayleigh time, s.
inline double default_dt(double min_rayleigh_time) {
  detail::require_positive(min_rayleigh_time, "min_rayleigh_time", " s");
  return default_dt_fraction * min_rayleigh_time;
}

/// The largest accepted time step, max_dt_fraction x the smallest Rayleigh time, s.
inline double stable_dt_limit(double min_rayleigh_time) {
  detail::require_positive(min_rayleigh_time, "min_rayleigh_time", " s");
  return max_dt_fraction * min_rayleigh_time;
}

/// Throws std::invalid_argument, with the limit in the message, unless 0 < dt <= the limit.
inline void require_stable_dt(double dt, double min_rayleigh_time) {
  const double limit = stable_dt_limit(min_rayleigh_time);
  if (!(std::isfinite(dt) && dt > 0.0 && dt <= limit)) {
    std::ostringstream msg;
    msg << "dt = " << dt << " s is not valid; it must be in (0, " << limit << "] s, "
        << max_dt_fraction << " x the smallest Rayleigh time " << min_rayleigh_time << " s";
    throw std::invalid_argument(msg.str());
  }
}

}  // namespace millscope::timestep
