// Drum geometry: cylindrical shell, flat end walls (or periodic ends) and lifters, rotating about
// +z (docs/architecture.md, Units and axes). Pure geometry: where a sphere touches the drum,
// with what overlap and normal, and how fast the drum's surface moves there. The contact law is
// applied elsewhere.
//
// Frames: the drum axis is the z axis, the drum occupies 0 <= z <= L, and the drum has turned by
// angle theta (rad) about +z. Lifter k is a straight prism along z whose cross-section lives in
// the frame of its centre line at angle phi_k = theta + phase + 2 pi k / n: a is the radial
// coordinate along the centre line, b the tangential one across it. The cross-section is the
// symmetric trapezoid with corners (R - h, +-t/2) at the tip (the face nearest the axis) and
// (R, +-w/2) at the shell, t the tip width and w the base width, continued along the same side
// lines to a = R + h (that part lies inside the shell and is never reached from the drum's
// interior; it keeps the prism convex and gives a sphere that has sunk into a lifter room to
// leave). Rectangular lifters, t = w, are the box a in [R - h, R + h], b in [-w/2, w/2].
// Distances to a lifter are exact distances to its prism (faces, edges along z, and, where the
// prism ends at z = 0 or L, its corners).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "millscope/hot_inline.hpp"

namespace millscope::drum {

using Vec3 = Eigen::Vector3d;

/// Which part of the drum a contact is with.
enum class Part : int { shell = 0, end_low = 1, end_high = 2, lifter = 3 };

/// Throws std::invalid_argument "Drum.<field> = <value> is not valid; it must be <range>".
[[noreturn]] inline void invalid_field(const char* field, double value, const std::string& range) {
  std::ostringstream msg;
  msg << "Drum." << field << " = " << value << " is not valid; it must be " << range;
  throw std::invalid_argument(msg.str());
}

struct Geometry {
  double radius;         // R, inner radius of the shell, m
  double length;         // L, m
  bool end_walls;        // flat walls at z = 0 and z = L; false: periodic ends
  int lifters;           // n, 0 for a smooth shell
  double lifter_width;   // w, width at the shell (radial coordinate R), m
  double lifter_height;  // h, m
  double lifter_phase;   // angle of lifter 0 at theta = 0, rad
  // t, width at the lifter's tip (radial coordinate R - h), m, in (0, w]. Last, and defaulted
  // to 0, so that the aggregate initialisation Geometry{R, L, ends, n, w, h, phase} still
  // compiles (without a -Wmissing-field-initializers warning) and leaves it 0: any value <= 0
  // means "as wide as the base", a rectangular lifter. Read it through tip_width().
  double lifter_top_width = 0.0;

  /// The tip width t in use, m: lifter_top_width when it is > 0, else lifter_width.
  double tip_width() const { return lifter_top_width > 0.0 ? lifter_top_width : lifter_width; }

  /// True when the lifters' cross-section is a rectangle (tip as wide as the base).
  bool rectangular_lifters() const { return tip_width() == lifter_width; }

  void validate() const {
    if (!(radius > 0.0) || !std::isfinite(radius)) invalid_field("radius", radius, "> 0 m");
    if (!(length > 0.0) || !std::isfinite(length)) invalid_field("length", length, "> 0 m");
    if (lifters < 0) invalid_field("lifters", lifters, ">= 0");
    if (lifters > 0) {
      if (!(lifter_height > 0.0 && lifter_height < radius))
        invalid_field("lifter_height", lifter_height, "in (0, radius) m");
      const double spacing = 2.0 * 3.14159265358979323846 * (radius - lifter_height) / lifters;
      if (!(lifter_width > 0.0 && lifter_width < spacing))
        invalid_field("lifter_width", lifter_width, "> 0 m and narrower than the lifter spacing");
      // NaN is not <= 0, so it lands here and is refused.
      if (!(lifter_top_width <= 0.0) && !(lifter_top_width <= lifter_width)) {
        std::ostringstream range;
        range << "in (0, lifter_width] m (lifter_width = " << lifter_width << " m)";
        invalid_field("lifter_top_width", lifter_top_width, range.str());
      }
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

/// A lifter's local frame: unit vectors e_a (radial, along its centre line) and e_b (tangential),
/// and the point's coordinates a, b in that frame (z is shared with the drum's frame).
struct LifterFrame {
  Vec3 e_a, e_b;
  double a, b;
};

/// The frame of the centre line at angle phi, given c = cos(phi) and s = sin(phi).
inline LifterFrame lifter_frame(double c, double s, const Vec3& x) {
  return {Vec3(c, s, 0.0), Vec3(-s, c, 0.0), c * x.x() + s * x.y(), -s * x.x() + c * x.y()};
}

inline LifterFrame lifter_frame(double phi, const Vec3& x) {
  return lifter_frame(std::cos(phi), std::sin(phi), x);
}

/// Where the lifters are at one drum angle: cos and sin of each centre line's angle
/// phi_k = theta + phase + 2 pi k / n, computed once per step instead of per particle.
struct LifterAngles {
  double theta = 0.0;
  std::vector<double> cos_phi, sin_phi;

  void update(const Geometry& g, double drum_theta) {
    theta = drum_theta;
    const auto n = static_cast<std::size_t>(std::max(g.lifters, 0));
    cos_phi.resize(n);
    sin_phi.resize(n);
    const double spacing = n > 0 ? 2.0 * 3.14159265358979323846 / static_cast<double>(n) : 0.0;
    for (std::size_t k = 0; k < n; ++k) {
      const double phi = drum_theta + g.lifter_phase + spacing * static_cast<double>(k);
      cos_phi[k] = std::cos(phi);
      sin_phi[k] = std::sin(phi);
    }
  }
};

// The prism is (cross-section) x [0, L], a Cartesian product of convex sets, and the projection
// onto such a product is the product of the projections: the closest point is (closest point of
// the 2D cross-section to (a, b), clamp(z, 0, L)). That is why z is handled by a clamp alone,
// for both profiles.

/// Rectangular cross-section: the box a in [R - h, R + h], b in [-w/2, w/2], so the closest point
/// is a clamp per coordinate.
inline LifterProximity closest_on_box(const Geometry& g, const LifterFrame& f, const Vec3& x) {
  const double a = f.a, b = f.b;
  const double a_lo = g.radius - g.lifter_height, a_hi = g.radius + g.lifter_height;
  const double half_w = 0.5 * g.lifter_width;
  const double ca = std::clamp(a, a_lo, a_hi);
  const double cb = std::clamp(b, -half_w, half_w);
  const double cz = std::clamp(x.z(), 0.0, g.length);
  if (ca != a || cb != b || cz != x.z())
    return {ca * f.e_a + cb * f.e_b + Vec3(0, 0, cz), false, Vec3::Zero()};
  // Inside (a guard case: overlap above the radius). Leave through the nearest face that the
  // drum's interior can reach: the top (towards the axis) or a side.
  const double to_top = a - a_lo, to_low_side = b + half_w, to_high_side = half_w - b;
  if (to_top <= to_low_side && to_top <= to_high_side)
    return {a_lo * f.e_a + b * f.e_b + Vec3(0, 0, x.z()), true, -f.e_a};
  const double side = to_low_side < to_high_side ? -1.0 : 1.0;
  return {a * f.e_a + side * half_w * f.e_b + Vec3(0, 0, x.z()), true, side * f.e_b};
}

/// Trapezoidal cross-section. By the mirror symmetry b -> -b it is enough to work with
/// beta = |b| >= 0 and put the sign back at the end. In the half-plane beta >= 0 the boundary is
/// three segments: the tip face a = R - h (beta in [0, t/2]), the side face from the tip corner
/// C1 = (R - h, t/2) to the far corner C2 = (R + h, t/2 + 2 h s), and the far face a = R + h,
/// where s = (w - t) / (2 h) is the side's slope d(half width)/da, >= 0 (wider at the shell).
/// Side face: unit tangent u = (1, s) / k from C1 to C2, outward unit normal n = (-s, 1) / k,
/// k = sqrt(1 + s^2), length 2 h k. With tau = (p - C1).u and sigma = (p - C1).n, a point p is
/// outside the cross-section when a < R - h, a > R + h or sigma > 0, and its nearest point is
/// the one of the feature whose Voronoi region holds p:
///   tip face   a <= R - h and beta <= t/2            -> (R - h, beta)
///   far face   a >= R + h and beta <= t/2 + 2 h s    -> (R + h, beta)
///   tip corner otherwise, tau <= 0                   -> C1
///   far corner otherwise, tau >= 2 h k               -> C2
///   side face  otherwise                             -> C1 + tau u
/// (the vertex regions are the cones between the neighbouring faces' outward normals; after the
/// two face regions are taken out, tau alone tells them from the side's region). Points on the
/// boundary count as inside, as for the box.
inline LifterProximity closest_on_trapezoid(const Geometry& g, const LifterFrame& f,
                                            const Vec3& x) {
  const double h = g.lifter_height;
  const double a_lo = g.radius - h, a_hi = g.radius + h;
  const double half_t = 0.5 * g.tip_width();
  const double slope = (g.lifter_width - g.tip_width()) / (2.0 * h);  // s
  const double half_far = half_t + 2.0 * h * slope;                   // half width at R + h
  const double k = std::sqrt(1.0 + slope * slope);
  const double ua = 1.0 / k, ub = slope / k;  // u = (ua, ub), n = (-ub, ua)
  const double side_len = 2.0 * h * k;

  const double sign = f.b < 0.0 ? -1.0 : 1.0;
  const double beta = std::abs(f.b);
  const double da = f.a - a_lo, dbeta = beta - half_t;  // p - C1
  const double tau = da * ua + dbeta * ub;
  const double sigma = -da * ub + dbeta * ua;
  const double cz = std::clamp(x.z(), 0.0, g.length);

  const bool outside_2d = f.a < a_lo || f.a > a_hi || sigma > 0.0;
  if (outside_2d || cz != x.z()) {
    double qa = f.a, qbeta = beta;  // inside the cross-section: only z is clamped
    if (outside_2d) {
      if (f.a <= a_lo && beta <= half_t) {  // tip face
        qa = a_lo;
      } else if (f.a >= a_hi && beta <= half_far) {  // far face
        qa = a_hi;
      } else if (tau <= 0.0) {  // tip corner C1
        qa = a_lo;
        qbeta = half_t;
      } else if (tau >= side_len) {  // far corner C2
        qa = a_hi;
        qbeta = half_far;
      } else {  // side face, C1 + tau u
        qa = a_lo + tau * ua;
        qbeta = half_t + tau * ub;
      }
    }
    return {qa * f.e_a + sign * qbeta * f.e_b + Vec3(0, 0, cz), false, Vec3::Zero()};
  }
  // Inside (a guard case: overlap above the radius). Leave through the nearest face the drum's
  // interior can reach: the tip (distance a - (R - h), outward normal -e_a) or the side on b's
  // side (distance -sigma to its line, outward normal n = (-s, +-1) / k, tilted towards the axis).
  // The foot of the perpendicular onto the nearer of the two lines always lies on that face: where
  // the foot on the side line would fall beyond C1 the tip is nearer, and where the foot on the
  // tip line would fall beyond C1 the side is nearer.
  const double to_tip = da, to_side = -sigma;
  if (to_tip <= to_side) return {a_lo * f.e_a + f.b * f.e_b + Vec3(0, 0, x.z()), true, -f.e_a};
  const double qa = f.a + sigma * ub, qbeta = beta - sigma * ua;  // p - sigma n
  return {qa * f.e_a + sign * qbeta * f.e_b + Vec3(0, 0, x.z()), true,
          -ub * f.e_a + sign * ua * f.e_b};
}

/// Closest point of the lifter whose centre line is at angle phi to x. Rectangular lifters take
/// the cheaper clamp path; the test is on the geometry alone, so the branch always goes the same
/// way in a run.
inline LifterProximity closest_on_lifter(const Geometry& g, const LifterFrame& f, const Vec3& x) {
  return g.rectangular_lifters() ? closest_on_box(g, f, x) : closest_on_trapezoid(g, f, x);
}

inline LifterProximity closest_on_lifter(const Geometry& g, double phi, const Vec3& x) {
  return closest_on_lifter(g, lifter_frame(phi, x), x);
}

/// Lifter k against a sphere (centre x, radius r): overlap > 0 when they touch (with the normal
/// from the lifter into the sphere and the contact point); otherwise -overlap is the gap, m.
MILLSCOPE_HOT_INLINE WallContact lifter_contact(const Geometry& g, const LifterAngles& at, int k,
                                                const Vec3& x, double r) {
  const auto slot = static_cast<std::size_t>(k);
  const LifterFrame f = lifter_frame(at.cos_phi[slot], at.sin_phi[slot], x);
  const LifterProximity p = closest_on_lifter(g, f, x);
  const Vec3 d = x - p.point;
  const double dist = d.norm();
  if (p.inside) return {Part::lifter, k, r + dist, p.outward, p.point};
  const double overlap = r - dist;
  return {Part::lifter, k, overlap, overlap > 0.0 ? Vec3(d / dist) : Vec3::Zero(), p.point};
}

/// The lifters a sphere may touch before its reach is next refreshed, packed in one integer:
/// no_lifter (-1), or 4 k + mask where k is the lower of the two lifters angularly nearest the
/// sphere and mask bit 0 / bit 1 stand for lifter k / lifter k + 1 (mod n). The step kernels
/// keep one per particle so that only spheres next to a lifter pay for the distance to it
/// (docs/architecture.md, What a scene pays for).
using LifterReach = std::int32_t;
inline constexpr LifterReach no_lifter = -1;

/// The lifters (at `at`) that come within `margin` (m) of the sphere's surface.
inline LifterReach lifter_reach(const Geometry& g, const LifterAngles& at, const Vec3& x, double r,
                                double margin) {
  if (g.lifters <= 0) return no_lifter;
  const double rho = std::hypot(x.x(), x.y());
  if (!(rho + r + margin > g.radius - g.lifter_height)) return no_lifter;
  const double spacing = 2.0 * 3.14159265358979323846 / g.lifters;
  const double rel = (std::atan2(x.y(), x.x()) - at.theta - g.lifter_phase) / spacing;
  int first = static_cast<int>(std::floor(rel)) % g.lifters;
  if (first < 0) first += g.lifters;
  int mask = 0;
  for (int b = 0; b < 2; ++b) {
    const int k = (first + b) % g.lifters;
    if (lifter_contact(g, at, k, x, r).overlap > -margin) mask |= 1 << b;
  }
  return mask == 0 ? no_lifter : 4 * first + mask;
}

/// All contacts of a sphere (centre x, radius r) with the drum whose lifters are at `at`, for a
/// drum whose shape is known when compiling: without lifters (Lifters false) or with periodic
/// ends (EndWalls false) those parts cost nothing (docs/architecture.md, What a scene pays
/// for). Only the lifters in `reach` are looked at. The step kernels call this; Lifters and
/// EndWalls must match g.lifters > 0 and g.end_walls. Inlined, with lifter_contact, so that
/// the drum pass pays no call and no copy of the result per particle near the drum.
template <bool Lifters, bool EndWalls>
MILLSCOPE_HOT_INLINE WallContacts find_contacts_of(const Geometry& g, const LifterAngles& at,
                                                   const Vec3& x, double r, LifterReach reach) {
  WallContacts out;
  const double rho2 = x.x() * x.x() + x.y() * x.y();
  // Away from the shell, from every lifter and (below) from the end walls: nothing to find.
  // The radial test uses squares, so a particle in the bulk costs no square root.
  const double inner = g.radius - r;
  const bool near_shell = !(inner > 0.0 && rho2 <= inner * inner);
  const bool near_lifter = Lifters && reach != no_lifter;
  if constexpr (EndWalls) {
    if (!near_shell && !near_lifter && x.z() > r && x.z() + r < g.length) return out;
  } else {
    if (!near_shell && !near_lifter) return out;
  }
  // Shell: the inside of the cylinder rho = R.
  if (near_shell) {
    const double rho = std::sqrt(rho2);
    const double shell_overlap = rho + r - g.radius;
    if (shell_overlap > 0.0 && rho > 0.0) {
      const Vec3 radial(x.x() / rho, x.y() / rho, 0.0);
      out.add({Part::shell, 0, shell_overlap, -radial,
               Vec3(g.radius * radial.x(), g.radius * radial.y(), x.z())});
    }
  }
  if constexpr (EndWalls) {
    if (r - x.z() > 0.0)
      out.add({Part::end_low, 0, r - x.z(), Vec3(0, 0, 1), Vec3(x.x(), x.y(), 0)});
    if (x.z() + r - g.length > 0.0)
      out.add(
          {Part::end_high, 0, x.z() + r - g.length, Vec3(0, 0, -1), Vec3(x.x(), x.y(), g.length)});
  }
  if constexpr (Lifters) {
    if (near_lifter) {
      const int first = reach >> 2;
      for (int b = 0; b < 2; ++b) {
        if (!(reach & (1 << b))) continue;
        const int k = first + b == g.lifters ? 0 : first + b;
        const WallContact c = lifter_contact(g, at, k, x, r);
        if (c.overlap > 0.0) out.add(c);
      }
    }
  }
  return out;
}

/// find_contacts_of for a drum whose shape is known only at run time (probes, tests,
/// energies), with the lifters at `at`.
inline WallContacts find_contacts(const Geometry& g, const LifterAngles& at, const Vec3& x,
                                  double r) {
  if (g.lifters > 0) {
    const LifterReach reach = lifter_reach(g, at, x, r, 0.0);
    return g.end_walls ? find_contacts_of<true, true>(g, at, x, r, reach)
                       : find_contacts_of<true, false>(g, at, x, r, reach);
  }
  return g.end_walls ? find_contacts_of<false, true>(g, at, x, r, no_lifter)
                     : find_contacts_of<false, false>(g, at, x, r, no_lifter);
}

/// find_contacts with the drum turned by theta, rad.
inline WallContacts find_contacts(const Geometry& g, double theta, const Vec3& x, double r) {
  LifterAngles at;
  at.update(g, theta);
  return find_contacts(g, at, x, r);
}

}  // namespace millscope::drum
