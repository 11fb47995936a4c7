// A single contact integrated on its own: two spheres, or a sphere and a flat wall, collide under
// the engine's contact law (contact.hpp) and integrator (velocity Verlet, the contact evaluated
// with half-step velocities). A public diagnostic: it checks the law against theory
// (tests/physics/test_contact.py) and tells how many steps an impact spans at a given dt (the
// stiffness advisor).
//
// Set-up: b (a sphere at the origin, or the wall plane y = 0) is at rest; a starts just touching
// b, above it, so the normal n (from b to a) is +y, and moves with velocity
// (tangential_speed, -speed, 0) and angular velocity (0, 0, spin). The tangent is t = +x.
// Right-handed signs: a's contact point moves at tangential_speed + spin r_a along t, so a
// sphere rolling on the wall without slip has spin = -tangential_speed / r_a.
#pragma once

#include "millscope/contact.hpp"
#include "millscope/materials.hpp"

namespace millscope::contact {

struct ProbeSetup {
  materials::Material material_a;
  materials::Material material_b;  // the wall's material when `wall`
  bool wall = false;               // b is a flat wall (R_b, m_b -> infinity)
  double radius_a = 0.0;           // m, > 0
  double radius_b = 0.0;           // m, > 0 (ignored for a wall)
  double restitution = 1.0;        // pair value, (0, 1]
  double friction = 0.0;           // pair value, >= 0; 0 uses the frictionless law
  double speed = 0.0;              // normal approach speed, m/s, > 0
  double tangential_speed = 0.0;   // of a's centre along t, m/s
  double spin = 0.0;               // of a about +z, rad/s
  double dt = 0.0;                 // s, in (0, elastic Hertz contact time)
  NormalClamp clamp = NormalClamp::none;
};

struct ProbeResult {
  double restitution;          // separation speed / approach speed, normal relative velocities
  double contact_time;         // s, first touch (t = 0) to separation, interpolated in a step
  double max_overlap;          // m, vertex of the parabola through the largest sample and its
                               // neighbours
  double tangential_velocity;  // (v_a - v_b) . t after the contact, m/s
  double spin_a;               // angular velocity of a about +z after, rad/s
  double spin_b;               // of b (0 for a wall), rad/s
  double slip_velocity;        // contact-point relative velocity along t after, m/s
  double normal_impulse;       // sum of F_n dt on a, N s
  double normal_impulse_abs;   // sum of |F_n| dt, N s (the Coulomb bound is mu times this)
  double tangential_impulse;   // sum of F_t . t dt on a, N s
  double kinetic_energy_before;  // J, translation and rotation of both bodies
  double kinetic_energy_after;   // J
  long contact_steps;            // steps evaluated in contact
  long sliding_steps;            // of which at the Coulomb limit
  double dt;                     // s
  double r_star;                 // m
  double m_star;                 // kg
  double hertz_contact_time;     // elastic theory at `speed`, s
  double hertz_max_overlap;      // elastic theory at `speed`, m
};

/// Runs one impact; throws std::invalid_argument for bad input (naming parameter, value, range).
ProbeResult contact_probe(const ProbeSetup& setup);

}  // namespace millscope::contact
