// Hertz-Mindlin no-slip contact with damping (paper section 3.1, eqs. 1-8; docs/physics.md, The
// law). Pure, inline functions of (overlap, relative velocity, history); no allocation, no
// virtual calls. The engine's hot loop calls these once per touching pair per step.
//
// ---------------------------------------------------------------------------------------------
// Sign conventions (body i against body j; a wall is j with R_j, m_j -> infinity)
// ---------------------------------------------------------------------------------------------
//   n      unit normal from j to i: n = (x_i - x_j) / |x_i - x_j|; for a wall, from the wall
//          surface into the sphere.
//   d_n    overlap, r_i + r_j - |x_i - x_j| (r_i - distance to the wall); in contact iff d_n > 0.
//   v_rel  velocity of i's material point at the contact relative to j's:
//            v_rel = v_i + w_i x (-r_i n) - (v_j + w_j x (r_j n))        (wall: - v_wall(x_c))
//   v_n    = v_rel . n, NEGATIVE while the bodies approach, positive while they separate.
//   v_t    = v_rel - v_n n, the tangential slip velocity.
//   F      force on i, F = F_n n + F_t; j receives -F. F_n > 0 pushes i away from j.
//   torque on i about its centre: (-r_i n) x F_t; on j: (r_j n) x (-F_t) (F_n n has no arm).
//
// The paper writes the damping forces as F_nd = -2 sqrt(5/6) beta sqrt(S_n m*) v_n (2) and
// F_td = -2 sqrt(5/6) beta sqrt(S_t m*) v_t (7), with beta = ln(e)/sqrt(ln^2 e + pi^2) <= 0 (3).
// The coefficient gamma = -2 sqrt(5/6) beta sqrt(S m*) is therefore >= 0, and a damper must
// dissipate: F_d . v <= 0. With v_n, v_t the velocity of i relative to j (as above) that requires
//   F_nd = -gamma_n v_n,   F_td = -gamma_t v_t,
// i.e. eqs. (2) and (7) with their v^rel read as the velocity of i relative to j and the sign of
// the whole term being that of a dashpot (-gamma v). Approaching (v_n < 0), the damping pushes i
// away from j (F_nd > 0); separating, it pulls (F_nd < 0). Power: F_nd v_n = -gamma_n v_n^2 <= 0.
// (Taken literally with beta < 0 and v_n < 0 on approach, eq. (2) would feed energy in. With the
// dashpot reading, the unclamped law returns exactly e for any impact speed: integrated
// accurately, e = 0.2, 0.3, 0.5 come back to 1e-9; at dt = t_c/50 within 1.5 %.)
// The elastic tangential force F_te = -S_t d_t (5) needs no reinterpretation: d_t is the
// accumulated displacement of i relative to j, d_t = integral of v_t dt, and the spring pulls it
// back.
//
// ---------------------------------------------------------------------------------------------
// Structure (docs/architecture.md, What a scene pays for)
// ---------------------------------------------------------------------------------------------
// ContactLaw<Normal, Damping, Tangential, Rolling, Clamp>: each part is stateless, reads its
// parameters from materials::PairConstants (one struct per pair of materials) and declares its
// history size as a constexpr. The geometry shared by all parts (n, d_n, sqrt(R* d_n), m*, v_n,
// v_t) is computed once per contact in Kinematics. A part a scene does not need is a "none" part
// (NoDamping, NoFriction, NoRolling) compiled out by `if constexpr`.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products (declared in Core, defined here)
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "millscope/hot_inline.hpp"
#include "millscope/materials.hpp"

// The hot loop's calls into the law are inlined (MILLSCOPE_HOT_INLINE): GCC otherwise keeps
// the law's evaluate() out of line (it is large and called from the pair and wall passes),
// and a call per contact costs the hot loop a large share of its time.

namespace millscope::contact {

using Vec3 = Eigen::Vector3d;
using materials::PairConstants;

/// What every part of the law sees of one contact, computed once per contact and step.
struct Kinematics {
  Vec3 n;          // unit normal, from j to i
  double d_n;      // overlap, m (> 0)
  double sqrt_rd;  // sqrt(R* d_n), m: shared by S_n (4), S_t (6) and F_ne (1)
  double m_star;   // equivalent mass, kg
  double v_n;      // v_rel . n, m/s (< 0 approaching)
  Vec3 v_t;        // v_rel - v_n n, m/s
};

/// Builds the kinematics from the normal, overlap, R*, m* and the contact-point relative velocity.
MILLSCOPE_HOT_INLINE Kinematics make_kinematics(const Vec3& n, double d_n, double r_star, double m_star,
                                  const Vec3& v_rel) {
  const double v_n = v_rel.dot(n);
  return Kinematics{n, d_n, std::sqrt(r_star * d_n), m_star, v_n, v_rel - v_n * n};
}

// ---------------------------------------------------------------------------------------------
// Normal elastic parts
// ---------------------------------------------------------------------------------------------

/// Hertz: S_n = 2 E* sqrt(R* d_n) (4); F_ne = 4/3 E* sqrt(R*) d_n^(3/2) = 2/3 S_n d_n (1).
struct HertzElastic {
  static constexpr std::size_t history_size = 0;
  struct Result {
    double force;      // F_ne, N, along n (>= 0)
    double stiffness;  // S_n, N/m
  };
  /// S_n (4), N/m, from sqrt(R* d_n), m.
  MILLSCOPE_HOT_INLINE static double stiffness(const PairConstants& p, double sqrt_rd) {
    return 2.0 * p.e_star * sqrt_rd;
  }
  /// F_ne (1), N, from S_n and d_n.
  MILLSCOPE_HOT_INLINE static double force(double s_n, double d_n) {
    return (2.0 / 3.0) * s_n * d_n;
  }
  MILLSCOPE_HOT_INLINE static Result evaluate(const PairConstants& p, const Kinematics& k) {
    const double s_n = stiffness(p, k.sqrt_rd);
    return Result{force(s_n, k.d_n), s_n};
  }
  /// Elastic energy stored at overlap d_n, the integral of (1): 8/15 E* sqrt(R*) d_n^(5/2), J.
  static double energy(const PairConstants& p, double sqrt_rd, double d_n) {
    return (8.0 / 15.0) * p.e_star * sqrt_rd * d_n * d_n;
  }
};

// ---------------------------------------------------------------------------------------------
// Damping parts: the viscous coefficient of a spring of stiffness S on the mass m*
// ---------------------------------------------------------------------------------------------

/// gamma(S) = -2 sqrt(5/6) beta sqrt(S m*) >= 0, used by F_nd (2) and F_td (7).
struct ViscousDamping {
  static constexpr std::size_t history_size = 0;
  static constexpr bool active = true;
  MILLSCOPE_HOT_INLINE static double gamma(const PairConstants& p, double stiffness,
                                            double m_star) {
    return p.damping_factor * std::sqrt(stiffness * m_star);
  }
};

/// No damping (elastic contact, e = 1 exactly, whatever the pair says).
struct NoDamping {
  static constexpr std::size_t history_size = 0;
  static constexpr bool active = false;
  static double gamma(const PairConstants&, double, double) { return 0.0; }
};

// ---------------------------------------------------------------------------------------------
// Tangential parts
// ---------------------------------------------------------------------------------------------

struct TangentialResult {
  Vec3 force;            // F_t on i, N (in the tangent plane)
  bool sliding;          // the Coulomb limit (8) was reached this step
  double damping_power;  // gamma_t |v_t|^2 while sticking, W (>= 0); 0 while sliding
  double friction_loss;  // energy lost to Coulomb sliding this step, J (0 while sticking):
                         // the tangential work -F_t . v_t dt less the change of the spring's
                         // energy
  Vec3 dissipative;      // the dissipating part of F_t, N: the dashpot -gamma_t v_t while
                         // sticking, all of F_t while sliding
  // For the energy ledger only (evaluate<..., Books = true>; zero otherwise):
  double loss;           // J this step: -F_t . v_t dt less the spring energy's change at the
                         // current S_t, S_t (|d_t|^2 - |d_t^prev|^2) / 2
  double spring_work;    // J this step: the energy the spring gained without work as S_t
                         // followed the overlap, (S_t - S_t^prev) |d_t^prev|^2 / 2
};

/// Mindlin no-slip spring with damping and Coulomb limit; history: d_t (3 doubles, m).
///   S_t = 8 G* sqrt(R* d_n) (6); F_te = -S_t d_t (5); F_td = -gamma(S_t) v_t (7);
///   |F_t| <= mu |F_n| (8).
/// Each step the stored d_t is first turned into the current tangent plane (its normal component
/// projected out, its length kept), then advanced by v_t dt. When the trial force
/// F_te + F_td exceeds mu |F_n|, F_t is scaled down to mu |F_n| along the trial force and d_t is
/// set to -F_t / S_t, so that the spring alone carries the Coulomb force (docs/physics.md,
/// The law).
/// The bound uses |F_n|, as LIGGGHTS and LAMMPS do: in the tensile tail of a damped, unclamped
/// contact friction still acts, so an impact that slides throughout gets a tangential impulse of
/// mu sum |F_n| dt, which is 7 % (e = 0.5) to 21 % (e = 0.2) above mu times the net normal
/// impulse. With NormalClamp::nonnegative the two agree (Coulomb's impact law).
struct MindlinFriction {
  static constexpr std::size_t history_size = 3;
  static constexpr bool active = true;

  // The law's steps, one function each, shared with the engine's lane kernel
  // (contact_forces_in_lanes): three doubles each rather than vectors, so that a loop over
  // contacts computes several in the lanes of one instruction.

  /// S_t (6), N/m, from sqrt(R* d_n), m.
  MILLSCOPE_HOT_INLINE static double stiffness(const PairConstants& p, double sqrt_rd) {
    return 8.0 * p.g_star * sqrt_rd;
  }
  /// Turns the spring d_t into the tangent plane of the unit normal n, its length kept (an
  /// empty or exactly normal spring becomes zero), and returns |d_t|^2, m^2, from before.
  MILLSCOPE_HOT_INLINE static double turn(double& sx, double& sy, double& sz, double nx,
                                          double ny, double nz) {
    const double before2 = sx * sx + sy * sy + sz * sz;
    const double along = sx * nx + sy * ny + sz * nz;
    sx -= along * nx, sy -= along * ny, sz -= along * nz;
    const double after2 = sx * sx + sy * sy + sz * sz;
    const double keep = after2 > 0.0 ? std::sqrt(before2 / after2) : 0.0;
    sx *= keep, sy *= keep, sz *= keep;
    return before2;
  }
  /// Advances the spring by the slip v_t over dt, s.
  MILLSCOPE_HOT_INLINE static void advance(double& sx, double& sy, double& sz, double vtx,
                                           double vty, double vtz, double dt) {
    sx += vtx * dt, sy += vty * dt, sz += vtz * dt;
  }
  /// The trial force F_te + F_td = -S_t d_t - gamma_t v_t, N ((5), (7)).
  MILLSCOPE_HOT_INLINE static void trial(double s_t, double gamma_t, double sx, double sy,
                                         double sz, double vtx, double vty, double vtz,
                                         double& fx, double& fy, double& fz) {
    fx = -s_t * sx + -gamma_t * vtx;
    fy = -s_t * sy + -gamma_t * vty;
    fz = -s_t * sz + -gamma_t * vtz;
  }
  /// The Coulomb limit (8): F_t scaled down to mu |F_n| along itself where it exceeds it
  /// (branch-free: a factor 1 otherwise); returns whether it did (sliding).
  MILLSCOPE_HOT_INLINE static bool limit(const PairConstants& p, double f_n, double& fx,
                                         double& fy, double& fz) {
    const double bound = p.friction * std::abs(f_n);
    const double f2 = fx * fx + fy * fy + fz * fz;
    const bool sliding = f2 > bound * bound;
    const double scale = sliding ? bound / std::sqrt(f2) : 1.0;  // f2 > bound^2 >= 0 if used
    fx *= scale, fy *= scale, fz *= scale;
    return sliding;
  }

  /// gamma_n: the normal dashpot's coefficient gamma(S_n) (0 without damping); the tangential
  /// one follows from it, gamma(S_t) = gamma_n sqrt(S_t / S_n) (PairConstants).
  /// Books: also the ledger's terms. The spring's energy S_t |d_t|^2 / 2 changes over a step by
  ///   S_t (|d_t|^2 - |d_t^prev|^2) / 2 + (S_t - S_t^prev) |d_t^prev|^2 / 2,
  /// the first part paid by the tangential force's work (what that work does not pay is
  /// `loss`: the dashpot's and the sliding's share, and velocity Verlet's O(dt^2) difference
  /// while sticking), the second (`spring_work`) by nothing: S_t follows the overlap (6).
  /// S_t^prev is (6) at the previous overlap d_n + v_n dt (exact to first order in dt; off by
  /// |v_t|^2 dt^2 / (2 |x_i - x_j|) between spheres). With the whole F_t booked as
  /// `dissipative` (its work with the full-step velocities is what the integrator applies),
  ///   work of F_t + change of the spring's energy = spring_work - (loss + the full-step share)
  /// holds step by step, sticking or sliding.
  template <class Damping, bool Books = false>
  MILLSCOPE_HOT_INLINE static TangentialResult evaluate(const PairConstants& p,
                                                        const Kinematics& k, double f_n,
                                                        double gamma_n, double dt,
                                                        double* history) {
    Eigen::Map<Vec3> d_t(history);
    const double s_t = stiffness(p, k.sqrt_rd);  // (6)
    const double before2 = turn(d_t.x(), d_t.y(), d_t.z(), k.n.x(), k.n.y(), k.n.z());
    advance(d_t.x(), d_t.y(), d_t.z(), k.v_t.x(), k.v_t.y(), k.v_t.z(), dt);

    // gamma(S_t), (7); 0 without damping, so that the trial force is the spring's (5) alone
    const double gamma_t = Damping::active ? gamma_n * p.tangential_damping_ratio : 0.0;
    Vec3 f_t;
    trial(s_t, gamma_t, d_t.x(), d_t.y(), d_t.z(), k.v_t.x(), k.v_t.y(), k.v_t.z(), f_t.x(),
          f_t.y(), f_t.z());
    double damping_power = 0.0;
    Vec3 dissipative = Vec3::Zero();
    if constexpr (Damping::active) {
      dissipative = -gamma_t * k.v_t;  // (7)
      damping_power = gamma_t * k.v_t.squaredNorm();
    }

    const bool sliding = limit(p, f_n, f_t.x(), f_t.y(), f_t.z());  // (8)
    if (sliding) {
      d_t = -f_t / s_t;  // s_t > 0 whenever d_n > 0
      damping_power = 0.0;
      dissipative = f_t;
    }
    // Energy lost to sliding this step: the tangential work -F_t . v_t dt less the change of
    // the spring's energy S_t |d_t|^2 / 2 (both at the current S_t). While sticking there is
    // none: velocity Verlet moves the spring energy back and forth without loss (the work
    // over a step, with the force averaged over its ends, equals the energy change exactly),
    // and the dashpot's share is damping_power.
    double friction_loss = 0.0;
    if (sliding) {
      friction_loss = -f_t.dot(k.v_t) * dt - 0.5 * s_t * (d_t.squaredNorm() - before2);
    }
    double loss = 0.0, spring_work = 0.0;
    if constexpr (Books) {
      dissipative = f_t;
      loss = -f_t.dot(k.v_t) * dt - 0.5 * s_t * (d_t.squaredNorm() - before2);
      const double d_prev = std::max(k.d_n + k.v_n * dt, 0.0);  // the overlap a step ago
      const double s_prev = s_t * std::sqrt(d_prev / k.d_n);    // (6) at d_prev
      spring_work = 0.5 * (s_t - s_prev) * before2;
    }
    return TangentialResult{f_t,         sliding, damping_power, friction_loss,
                            dissipative, loss,    spring_work};
  }
  /// Energy held by the tangential spring, S_t |d_t|^2 / 2, J (S_t at the current overlap).
  static double energy(const PairConstants& p, double sqrt_rd, const double* history) {
    const double s_t = stiffness(p, sqrt_rd);  // (6)
    return 0.5 * s_t * Eigen::Map<const Vec3>(history).squaredNorm();
  }
};

/// No friction: no tangential force, no history, no torque.
struct NoFriction {
  static constexpr std::size_t history_size = 0;
  static constexpr bool active = false;
};

/// No rolling resistance (the only rolling part; docs/physics.md, The law).
struct NoRolling {
  static constexpr std::size_t history_size = 0;
  static constexpr bool active = false;
};

/// Whether the total normal force may pull the bodies together at the end of a damped contact.
enum class NormalClamp {
  none,         // F_n = F_ne + F_nd as it comes (default; as EDEM and LIGGGHTS)
  nonnegative,  // F_n = max(F_ne + F_nd, 0)
};

/// The force on i of one contact.
struct ContactForce {
  Vec3 force;            // F_n n + F_t, N
  Vec3 tangential;       // F_t, N (zero without friction)
  double normal;         // F_n, N (after the optional clamp)
  bool sliding;          // the Coulomb limit was reached this step
  double damping_power;  // power the dashpots take out of the motion, W (>= 0): normal
                         // (F_ne - F_n) v_n, which is gamma_n v_n^2 unclamped, plus the
                         // tangential gamma_t |v_t|^2 while sticking
  double friction_loss;  // J this step, see TangentialResult (0 without friction)
  Vec3 dissipative;      // the dissipating part of the force on i, N: the normal dashpot
                         // (F_n - F_ne) n plus TangentialResult::dissipative. Its work with
                         // the full-step velocity is what the integrator really removes
                         // (engine.hpp, Ledger::dissipated). Booked (Books): the normal
                         // dashpot plus all of F_t
  // For the energy ledger only (Books; zero otherwise):
  double loss;           // J this step: the normal dashpot's (F_ne - F_n) v_n dt plus
                         // TangentialResult::loss
  double spring_work;    // J this step, see TangentialResult
};

/// A contact law composed of parts. history_size doubles per contact hold the state of the
/// parts that have one (the tangential part's d_t first).
template <class Normal, class Damping, class Tangential, class Rolling = NoRolling,
          NormalClamp Clamp = NormalClamp::none>
struct ContactLaw {
  static_assert(!Rolling::active, "rolling resistance is not implemented yet");
  using normal_part = Normal;
  using damping_part = Damping;
  using tangential_part = Tangential;
  using rolling_part = Rolling;
  static constexpr NormalClamp clamp = Clamp;
  static constexpr bool has_friction = Tangential::active;
  static constexpr bool dissipates = Damping::active || Tangential::active;
  static constexpr std::size_t tangential_offset = Normal::history_size + Damping::history_size;
  static constexpr std::size_t history_size =
      tangential_offset + Tangential::history_size + Rolling::history_size;

  /// The force on i given the contact kinematics (d_n > 0); dt is the step over which the
  /// tangential history advances. `history` points at history_size doubles (may be null when 0).
  /// Books: compute ContactForce::spring_work (the engine's energy ledger).
  template <bool Books = false>
  MILLSCOPE_HOT_INLINE static ContactForce evaluate(const PairConstants& p, const Kinematics& k, double dt,
                               double* history) {
    const auto elastic = Normal::evaluate(p, k);
    double f_n = elastic.force;
    double gamma_n = 0.0;
    if constexpr (Damping::active) {
      gamma_n = Damping::gamma(p, elastic.stiffness, k.m_star);
      f_n -= gamma_n * k.v_n;  // (2)
    }
    if constexpr (Clamp == NormalClamp::nonnegative) f_n = std::max(f_n, 0.0);

    ContactForce c{f_n * k.n,
                   Vec3::Zero(),
                   f_n,
                   false,
                   (elastic.force - f_n) * k.v_n,
                   0.0,
                   (f_n - elastic.force) * k.n,
                   Books ? (elastic.force - f_n) * k.v_n * dt : 0.0,
                   0.0};
    if constexpr (Tangential::active) {
      const TangentialResult t =
          Tangential::template evaluate<Damping, Books>(p, k, f_n, gamma_n, dt,
                                                        history + tangential_offset);
      c.force += t.force;
      c.tangential = t.force;
      c.sliding = t.sliding;
      c.damping_power += t.damping_power;
      c.friction_loss = t.friction_loss;
      c.dissipative += t.dissipative;
      c.loss += t.loss;
      c.spring_work = t.spring_work;
    } else {
      (void)dt;
      (void)history;
    }
    return c;
  }

  /// Elastic energy stored in a contact of overlap d_n > 0 and its history, J.
  static double stored_energy(const PairConstants& p, double d_n, double r_star,
                              const double* history) {
    const double sqrt_rd = std::sqrt(r_star * d_n);
    double u = Normal::energy(p, sqrt_rd, d_n);
    if constexpr (Tangential::active) u += Tangential::energy(p, sqrt_rd, history + tangential_offset);
    (void)history;
    return u;
  }

  /// Clears the history of a contact that has ended.
  static void reset(double* history) {
    for (std::size_t i = 0; i < history_size; ++i) history[i] = 0.0;
  }

  /// Whether the history holds anything (a contact under way, or one that has just ended).
  static bool holds(const double* history) {
    bool held = false;
    for (std::size_t i = 0; i < history_size; ++i) held |= history[i] != 0.0;
    return held;
  }

  /// reset() for a pair that may long have been apart: writes only when something is held, so
  /// the hot loop does not dirty the history of every listed pair that does not touch.
  static void clear(double* history) {
    if (holds(history)) reset(history);
  }
};

/// The paper's law: Hertz-Mindlin no-slip with damping, unclamped.
using HertzMindlin = ContactLaw<HertzElastic, ViscousDamping, MindlinFriction>;
/// The same without friction (mu = 0 for every pair): no tangential history or torque.
using HertzMindlinFrictionless = ContactLaw<HertzElastic, ViscousDamping, NoFriction>;
/// Elastic and frictionless (every restitution 1, every friction 0): no damping, no history.
using HertzElasticFrictionless = ContactLaw<HertzElastic, NoDamping, NoFriction>;
/// Clamped variants.
using HertzMindlinClamped =
    ContactLaw<HertzElastic, ViscousDamping, MindlinFriction, NoRolling, NormalClamp::nonnegative>;
using HertzMindlinFrictionlessClamped =
    ContactLaw<HertzElastic, ViscousDamping, NoFriction, NoRolling, NormalClamp::nonnegative>;

// ---------------------------------------------------------------------------------------------
// The choice of a law: made once, here, for the engine, the impact probe and the bindings
// ---------------------------------------------------------------------------------------------

/// The laws above as a value.
enum class Law : int {
  hertz_mindlin = 0,         // HertzMindlin
  frictionless = 1,          // HertzMindlinFrictionless
  elastic = 2,               // HertzElasticFrictionless
  clamped = 3,               // HertzMindlinClamped
  frictionless_clamped = 4,  // HertzMindlinFrictionlessClamped
};

/// The law for contacts of which some have friction (mu > 0) and some damping (e < 1), with
/// the normal force clamped at zero or not: the cheapest law that computes them.
constexpr Law choose_law(bool friction, bool damping, bool clamp) {
  if (clamp) return friction ? Law::clamped : Law::frictionless_clamped;
  if (friction) return Law::hertz_mindlin;
  return damping ? Law::frictionless : Law::elastic;
}

/// A law's type as a value, for with_law.
template <class L>
struct LawTag {
  using type = L;
};

/// Calls f(LawTag<the law's type>{}) and returns what it returns.
template <class F>
auto with_law(Law law, F&& f) {
  switch (law) {
    case Law::hertz_mindlin:
      return f(LawTag<HertzMindlin>{});
    case Law::frictionless:
      return f(LawTag<HertzMindlinFrictionless>{});
    case Law::elastic:
      return f(LawTag<HertzElasticFrictionless>{});
    case Law::clamped:
      return f(LawTag<HertzMindlinClamped>{});
    case Law::frictionless_clamped:
      break;
  }
  return f(LawTag<HertzMindlinFrictionlessClamped>{});
}

/// Whether the law has a tangential part (and so torques).
inline bool has_friction(Law law) {
  return with_law(law, [](auto tag) { return decltype(tag)::type::has_friction; });
}

/// Doubles of history per contact the law keeps (ContactLaw::history_size).
inline std::size_t history_size(Law law) {
  return with_law(law, [](auto tag) { return decltype(tag)::type::history_size; });
}

// ---------------------------------------------------------------------------------------------
// Whole-pair evaluation: geometry, contact-point velocity, force and torques
// ---------------------------------------------------------------------------------------------

/// A sphere as the pair functions see it (position, velocity, angular velocity, radius, mass).
struct SphereState {
  Vec3 x;
  Vec3 v;
  Vec3 w;
  double radius;
  double mass;
};

/// Force and torque contributions of one pair.
struct PairForce {
  bool touching;    // d_n > 0; when false every other field is zero and the history was reset
  double overlap;   // d_n, m
  Vec3 n;           // unit normal from j to i
  Vec3 force_i;     // force on i, N (on j: -force_i)
  Vec3 torque_i;    // torque on i about its centre, N m
  Vec3 torque_j;    // torque on j about its centre, N m (walls: ignore)
  double normal;    // F_n, N
  Vec3 tangential;  // F_t on i, N
  bool sliding;
  double damping_power;  // W, see ContactForce
  double friction_loss;  // J this step, see ContactForce
  Vec3 dissipative;      // N, on i, see ContactForce (on j: -dissipative)
  double loss;           // J this step, see ContactForce
  double spring_work;    // J this step, see ContactForce
};

/// One touching contact (d_n > 0) given its geometry: normal n (from j to i), overlap, R*, m*,
/// the contact-point velocity of i relative to j and the radii (r_j = 0 for a wall).
template <class Law, bool Books = false>
MILLSCOPE_HOT_INLINE PairForce pair_force(const PairConstants& p, const Vec3& n, double d_n, double r_star,
                            double m_star, const Vec3& v_rel, double r_i, double r_j, double dt,
                            double* history) {
  const Kinematics k = make_kinematics(n, d_n, r_star, m_star, v_rel);
  const ContactForce c = Law::template evaluate<Books>(p, k, dt, history);
  PairForce out{true,          d_n,        n,         c.force,      Vec3::Zero(),
                Vec3::Zero(),  c.normal,   c.tangential, c.sliding, c.damping_power,
                c.friction_loss, c.dissipative, c.loss, c.spring_work};
  if constexpr (Law::has_friction) {
    const Vec3 nxf = n.cross(c.tangential);
    out.torque_i = -r_i * nxf;  // (-r_i n) x F_t
    out.torque_j = -r_j * nxf;  // (r_j n) x (-F_t)
  }
  return out;
}

namespace detail {

inline PairForce apart(const Vec3& n, double d_n) {
  return PairForce{false, d_n,          n,     Vec3::Zero(), Vec3::Zero(), Vec3::Zero(),
                   0.0,   Vec3::Zero(), false, 0.0,          0.0,          Vec3::Zero(), 0.0, 0.0};
}

}  // namespace detail

/// Two spheres i and j. R* and m* are computed from the states; dt is the step over which the
/// tangential history advances (the engine passes its half-step velocities in the states).
/// When the spheres do not touch, the history is reset and a zero force returned.
template <class Law>
inline PairForce sphere_sphere(const PairConstants& p, const SphereState& i, const SphereState& j,
                               double dt, double* history) {
  const Vec3 d = i.x - j.x;
  const double dist = d.norm();
  const double d_n = i.radius + j.radius - dist;
  if (!(d_n > 0.0) || !(dist > 0.0)) {
    Law::reset(history);
    return detail::apart(Vec3::Zero(), d_n);
  }
  const Vec3 n = d / dist;
  const Vec3 v_rel = i.v + i.w.cross(-i.radius * n) - (j.v + j.w.cross(j.radius * n));
  return pair_force<Law>(p, n, d_n, materials::reduced(i.radius, j.radius),
                             materials::reduced(i.mass, j.mass), v_rel, i.radius, j.radius, dt,
                             history);
}

/// Sphere i against a wall. The wall's geometry gives n (unit, from the wall into the sphere)
/// and the overlap d_n = r_i - (distance from the centre to the wall); `wall_velocity` is the
/// velocity of the wall's material point at the contact (w_drum x r_c for a rotating drum).
/// R* = r_i and m* = m_i. torque_j is zero. When d_n <= 0 the history is reset.
template <class Law>
inline PairForce sphere_wall(const PairConstants& p, const SphereState& i, const Vec3& n,
                             double d_n, const Vec3& wall_velocity, double dt, double* history) {
  if (!(d_n > 0.0)) {
    Law::reset(history);
    return detail::apart(n, d_n);
  }
  const Vec3 v_rel = i.v + i.w.cross(-i.radius * n) - wall_velocity;
  PairForce out = pair_force<Law>(p, n, d_n, i.radius, i.mass, v_rel, i.radius, 0.0, dt,
                                      history);
  out.torque_j = Vec3::Zero();
  return out;
}

}  // namespace millscope::contact
