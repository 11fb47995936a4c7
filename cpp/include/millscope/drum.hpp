// Drum geometry: cylindrical shell, flat end walls (or periodic ends) and lifters, rotating about
// +z (DESIGN.md section 2). Pure geometry: where a sphere touches the drum, with what overlap and
// normal, and how fast the drum's surface moves there. The contact law is applied elsewhere.
//
// Frames: the drum axis is the z axis, the drum occupies 0 <= z <= L, and the drum has turned by
// angle theta (rad) about +z. Lifter k is a straight prism along z whose cross-section, in the
// frame of its centre line at angle phi_k = theta + phase + 2 pi k / n, spans the radial coordinate
// a in [R - h, R + h] (the part beyond R lies inside the shell and is never reached from inside)
// and the tangential coordinate b in [-w/2, w/2]. Distances to a lifter are exact distances to
// that box (faces, edges along z, and, where the box ends at z = 0 or L, its corners).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <sstream>
#include <stdexcept>

namespace millscope::drum {

using Vec3 = Eigen::Vector3d;

/// Which part of the drum a contact is with.
enum class Part : int { shell = 0, end_low = 1, end_high = 2, lifter = 3 };

struct Geometry {
  double radius;         // R, inner radius of the shell, m
  double length;         // L, m
  bool end_walls;        // flat walls at z = 0 and z = L; false: periodic ends
  int lifters;           // n, 0 for a smooth shell
  double lifter_width;   // w, m
  double lifter_height;  // h, m
  double lifter_phase;   // angle of lifter 0 at theta = 0, rad

  void validate() const {
    auto fail = [](const char* field, double value, const char* range) {
      std::ostringstream msg;
      msg << "Drum." << field << " = " << value << " is not valid; it must be " << range;
      throw std::invalid_argument(msg.str());
    };
    if (!(radius > 0.0) || !std::isfinite(radius)) fail("radius", radius, "> 0 m");
    if (!(length > 0.0) || !std::isfinite(length)) fail("length", length, "> 0 m");
    if (lifters < 0) fail("lifters", lifters, ">= 0");
    if (lifters > 0) {
      if (!(lifter_height > 0.0 && lifter_height < radius))
        fail("lifter_height", lifter_height, "in (0, radius) m");
      const double spacing = 2.0 * 3.14159265358979323846 * (radius - lifter_height) / lifters;
      if (!(lifter_width > 0.0 && lifter_width < spacing))
        fail("lifter_width", lifter_width, "> 0 m and narrower than the lifter spacing");
    }
  }
};

/// One contact of a sphere with the drum.
struct WallContact {
  Part part;
  int index;       // lifter index for Part::lifter, else 0
  double overlap;  // m, > 0
  Vec3 normal;     // unit, from the wall into the sphere
  Vec3 point;      // contact point on the wall surface, m
};

/// At most: shell, two end walls, two lifters.
struct WallContacts {
  std::array<WallContact, 5> items;
  int count = 0;
  void add(const WallContact& c) { items[static_cast<std::size_t>(count++)] = c; }
};

/// Velocity of the drum's material point at x, omega x x for rotation about +z, m/s.
inline Vec3 surface_velocity(double omega, const Vec3& x) {
  return Vec3(-omega * x.y(), omega * x.x(), 0.0);
}

/// The point of a lifter nearest to x; when x lies inside the lifter, the nearest point of a face
/// reachable from the drum's interior and that face's outward normal.
struct LifterProximity {
  Vec3 point;
  bool inside;
  Vec3 outward;  // set when inside
};

/// Closest point of the lifter whose centre line is at angle phi to x.
inline LifterProximity closest_on_lifter(const Geometry& g, double phi, const Vec3& x) {
  const double c = std::cos(phi), s = std::sin(phi);
  // local coordinates: a along the lifter's centre line (radial), b across it (tangential)
  const double a = c * x.x() + s * x.y();
  const double b = -s * x.x() + c * x.y();
  const double a_lo = g.radius - g.lifter_height, a_hi = g.radius + g.lifter_height;
  const double half_w = 0.5 * g.lifter_width;
  const double ca = std::clamp(a, a_lo, a_hi);
  const double cb = std::clamp(b, -half_w, half_w);
  const double cz = std::clamp(x.z(), 0.0, g.length);
  const Vec3 e_a(c, s, 0.0), e_b(-s, c, 0.0);
  if (ca != a || cb != b || cz != x.z())
    return {ca * e_a + cb * e_b + Vec3(0, 0, cz), false, Vec3::Zero()};
  // Inside (a guard case: overlap above the radius). Leave through the nearest face that the
  // drum's interior can reach: the top (towards the axis) or a side.
  const double to_top = a - a_lo, to_low_side = b + half_w, to_high_side = half_w - b;
  if (to_top <= to_low_side && to_top <= to_high_side)
    return {a_lo * e_a + b * e_b + Vec3(0, 0, x.z()), true, -e_a};
  const double side = to_low_side < to_high_side ? -1.0 : 1.0;
  return {a * e_a + side * half_w * e_b + Vec3(0, 0, x.z()), true, side * e_b};
}

/// All contacts of a sphere (centre x, radius r) with the drum turned by theta.
inline WallContacts find_contacts(const Geometry& g, double theta, const Vec3& x, double r) {
  WallContacts out;
  const double rho = std::hypot(x.x(), x.y());
  // Shell: the inside of the cylinder rho = R.
  const double shell_overlap = rho + r - g.radius;
  if (shell_overlap > 0.0 && rho > 0.0) {
    const Vec3 radial(x.x() / rho, x.y() / rho, 0.0);
    out.add({Part::shell, 0, shell_overlap, -radial,
             Vec3(g.radius * radial.x(), g.radius * radial.y(), x.z())});
  }
  if (g.end_walls) {
    if (r - x.z() > 0.0) out.add({Part::end_low, 0, r - x.z(), Vec3(0, 0, 1), Vec3(x.x(), x.y(), 0)});
    if (x.z() + r - g.length > 0.0)
      out.add({Part::end_high, 0, x.z() + r - g.length, Vec3(0, 0, -1),
               Vec3(x.x(), x.y(), g.length)});
  }
  // Lifters: only a sphere reaching below the lifter tops can touch one, and then only the two
  // lifters whose centre lines are angularly nearest.
  if (g.lifters > 0 && rho + r > g.radius - g.lifter_height) {
    const double spacing = 2.0 * 3.14159265358979323846 / g.lifters;
    const double rel = (std::atan2(x.y(), x.x()) - theta - g.lifter_phase) / spacing;
    const double nearest = std::floor(rel);
    for (double kk : {nearest, nearest + 1.0}) {
      int k = static_cast<int>(kk) % g.lifters;
      if (k < 0) k += g.lifters;
      const double phi = theta + g.lifter_phase + spacing * kk;
      const LifterProximity p = closest_on_lifter(g, phi, x);
      const Vec3 d = x - p.point;
      const double dist = d.norm();
      if (p.inside) {
        out.add({Part::lifter, k, r + dist, p.outward, p.point});
      } else if (dist < r) {
        out.add({Part::lifter, k, r - dist, d / dist, p.point});
      }
    }
  }
  return out;
}

}  // namespace millscope::drum
