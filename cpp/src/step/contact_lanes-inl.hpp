// The loop of contact_lanes.hpp (ContactForcesInLanes), compiled for each SIMD target
// lane_kernels.cpp names (foreach_target.h includes this file once per target): the compiler
// computes several contacts in the lanes of one instruction of that target. Not for other files.

// Per-target include guard: Highway toggles HWY_TARGET_TOGGLE for each target it compiles.
#if defined(MILLSCOPE_CONTACT_LANES_INL_) == defined(HWY_TARGET_TOGGLE)
#ifdef MILLSCOPE_CONTACT_LANES_INL_
#undef MILLSCOPE_CONTACT_LANES_INL_
#else
#define MILLSCOPE_CONTACT_LANES_INL_
#endif

#include <hwy/highway.h>

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "millscope/contact.hpp"
#include "step/contact_lanes.hpp"

HWY_BEFORE_NAMESPACE();
namespace millscope::engine::HWY_NAMESPACE {

// AVX-512 has no build of its own: with 8 contacts to a vector the loop's indexed loads (no
// gathers under generic tuning) and the rest of each block of about 70 contacts weigh more,
// and AVX-512 lanes did not beat AVX2 lanes in the engine (docs/performance.md, SIMD paths);
// the AVX-512 path takes the AVX2 build (lane_kernels.cpp), as the engine did before it
// dispatched through Highway, and the build is spared a target.
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
/// This target's builds of the loops: none.
inline constexpr ContactForcesInLanes contact_loop[2] = {nullptr, nullptr};
inline constexpr WallForcesInLanes wall_loop[2] = {nullptr, nullptr};
#else

/// The paper's law (contact::HertzMindlin: Hertz (1), viscous damping (2), Mindlin no-slip
/// spring (5)-(7) with the Coulomb limit (8), unclamped) for one contact in one lane: unit
/// normal n (into the particle i the force acts on), overlap d_n, m, R*, m; m*, kg; the
/// contact point's velocity relative to the other body v_r, m/s; dt, s. Advances the spring
/// s (m) and gives the force F on i (N) and c = n x F_t (N), whose torque on a body at
/// -r n from the contact is -r c. Every operation is the one contact::pair_force does, in the
/// same order and unfused (-ffp-contract=off), so the forces are the same to the bit on every
/// target; branch-free, so that the loops that call it keep their lanes (the sliding select
/// needs -fno-trapping-math).
HWY_INLINE void law_in_lane(const materials::PairConstants& p, double nx, double ny, double nz,
                            double d_n, double r_star, double m_star, double vrx, double vry,
                            double vrz, double dt, double& sx, double& sy, double& sz,
                            double& fx, double& fy, double& fz, double& cx, double& cy,
                            double& cz) {
  using Normal = contact::HertzMindlin::normal_part;
  using Damping = contact::HertzMindlin::damping_part;
  using Tangential = contact::HertzMindlin::tangential_part;
  const double v_n = vrx * nx + vry * ny + vrz * nz;
  const double vtx = vrx - v_n * nx, vty = vry - v_n * ny, vtz = vrz - v_n * nz;
  const double sqrt_rd = std::sqrt(r_star * d_n);
  const double s_n = Normal::stiffness(p, sqrt_rd);            // (4)
  const double gamma_n = Damping::gamma(p, s_n, m_star);       // (2)
  const double f_n = Normal::force(s_n, d_n) - gamma_n * v_n;  // (1), (2)
  const double s_t = Tangential::stiffness(p, sqrt_rd);        // (6)
  double tsx = sx, tsy = sy, tsz = sz;
  Tangential::turn(tsx, tsy, tsz, nx, ny, nz);
  Tangential::advance(tsx, tsy, tsz, vtx, vty, vtz, dt);
  const double gamma_t = gamma_n * p.tangential_damping_ratio;  // (7)
  double ftx, fty, ftz;
  Tangential::trial(s_t, gamma_t, tsx, tsy, tsz, vtx, vty, vtz, ftx, fty, ftz);  // (5), (7)
  const bool sliding = Tangential::limit(p, f_n, ftx, fty, ftz);                 // (8)
  sx = sliding ? -ftx / s_t : tsx;
  sy = sliding ? -fty / s_t : tsy;
  sz = sliding ? -ftz / s_t : tsz;
  fx = f_n * nx + ftx, fy = f_n * ny + fty, fz = f_n * nz + ftz;
  cx = ny * ftz - nz * fty, cy = nz * ftx - nx * ftz, cz = nx * fty - ny * ftx;
}

/// The pair constants of contact c: `pairs[pair[c]]`, or, with one pair for all (Uniform),
/// `one`, which the loop holds in registers (a vector loop reads an indexed constant lane by
/// lane).
template <bool Uniform>
HWY_INLINE const materials::PairConstants& pair_in_lane(const materials::PairConstants& one,
                                                         const materials::PairConstants* pairs,
                                                         const std::uint32_t* pair,
                                                         std::size_t c) {
  if constexpr (Uniform) {
    return one;
  } else {
    return pairs[pair[c]];
  }
}

/// The law for every contact of a block (law_in_lane), several contacts in the lanes of one
/// instruction (`omp simd`). Particles are read through the pairs' indices (radius r, m;
/// inverse mass, 1/kg; velocity, m/s; spin, rad/s); `pairs` holds the pair constants (with
/// Uniform, every contact's are pairs[0]); dt, s, advances the springs.
template <bool Uniform>
void contact_forces_in_lanes(
    ContactBatch& b, const materials::PairConstants* pairs, const double* r, const double* inv_m,
    const double* vx, const double* vy, const double* vz, const double* wx, const double* wy,
    const double* wz, double dt) {
  const std::size_t n = b.size;
  const materials::PairConstants one = pairs[0];
  const std::uint32_t* __restrict bi = b.i.data();
  const std::uint32_t* __restrict bj = b.j.data();
  const std::uint32_t* __restrict bp = b.pair.data();
  const double* __restrict dxs = b.dx.data();
  const double* __restrict dys = b.dy.data();
  const double* __restrict dzs = b.dz.data();
  double* __restrict sxs = b.sx.data();
  double* __restrict sys = b.sy.data();
  double* __restrict szs = b.sz.data();
  double* __restrict overlaps = b.overlap.data();
  double* __restrict fxs = b.fx.data();
  double* __restrict fys = b.fy.data();
  double* __restrict fzs = b.fz.data();
  double* __restrict tixs = b.tix.data();
  double* __restrict tiys = b.tiy.data();
  double* __restrict tizs = b.tiz.data();
  double* __restrict tjxs = b.tjx.data();
  double* __restrict tjys = b.tjy.data();
  double* __restrict tjzs = b.tjz.data();
#pragma omp simd
  for (std::size_t c = 0; c < n; ++c) {
    const std::uint32_t i = bi[c], j = bj[c];
    const double dx = dxs[c], dy = dys[c], dz = dzs[c];
    const double ri = r[i], rj = r[j], r_sum = ri + rj;
    const double dist = std::sqrt(dx * dx + dy * dy + dz * dz);
    const double inv_dist = 1.0 / dist;
    const double nx = dx * inv_dist, ny = dy * inv_dist, nz = dz * inv_dist;  // j to i
    // contact-point velocity of i relative to j: (v_i - v_j) + (w_i x (-r_i n) - w_j x (r_j n))
    const double ax = -ri * nx, ay = -ri * ny, az = -ri * nz;
    const double bx = rj * nx, by = rj * ny, bz = rj * nz;
    const double vrx = (vx[i] - vx[j]) + ((wy[i] * az - wz[i] * ay) - (wy[j] * bz - wz[j] * by));
    const double vry = (vy[i] - vy[j]) + ((wz[i] * ax - wx[i] * az) - (wz[j] * bx - wx[j] * bz));
    const double vrz = (vz[i] - vz[j]) + ((wx[i] * ay - wy[i] * ax) - (wx[j] * by - wy[j] * bx));
    const double r_star = ri * rj / r_sum;
    const double m_star = 1.0 / (inv_m[i] + inv_m[j]);
    const double d_n = r_sum - dist;
    double cx, cy, cz;
    law_in_lane(pair_in_lane<Uniform>(one, pairs, bp, c), nx, ny, nz, d_n, r_star, m_star, vrx,
                vry, vrz, dt, sxs[c], sys[c], szs[c], fxs[c], fys[c], fzs[c], cx, cy, cz);
    overlaps[c] = d_n;
    tixs[c] = -ri * cx, tiys[c] = -ri * cy, tizs[c] = -ri * cz;  // (-r_i n) x F_t
    tjxs[c] = -rj * cx, tjys[c] = -rj * cy, tjzs[c] = -rj * cz;  // (r_j n) x (-F_t)
  }
}

/// The law for every contact of a WallBatch (law_in_lane with R* = r_i and m* = m_i, as
/// contact::pair_force is called by the drum pass), several contacts in the lanes of one
/// instruction. The drum turns at omega, rad/s, about +z; particles are read through the
/// contacts' indices (radius r, m; mass m, kg; velocity, m/s; spin, rad/s); dt, s, advances
/// the springs; with Uniform, every contact's pair constants are pairs[0].
template <bool Uniform>
void wall_forces_in_lanes(WallBatch& b, const materials::PairConstants* pairs, const double* r,
                          const double* m, const double* vx, const double* vy, const double* vz,
                          const double* wx, const double* wy, const double* wz, double omega,
                          double dt) {
  const std::size_t n = b.size;
  const materials::PairConstants one = pairs[0];
  const std::uint32_t* __restrict bi = b.i.data();
  const std::uint32_t* __restrict bp = b.pair.data();
  const double* __restrict nxs = b.nx.data();
  const double* __restrict nys = b.ny.data();
  const double* __restrict nzs = b.nz.data();
  const double* __restrict overlaps = b.overlap.data();
  const double* __restrict pxs = b.px.data();
  const double* __restrict pys = b.py.data();
  double* __restrict sxs = b.sx.data();
  double* __restrict sys = b.sy.data();
  double* __restrict szs = b.sz.data();
  double* __restrict fxs = b.fx.data();
  double* __restrict fys = b.fy.data();
  double* __restrict fzs = b.fz.data();
  double* __restrict txs = b.tx.data();
  double* __restrict tys = b.ty.data();
  double* __restrict tzs = b.tz.data();
#pragma omp simd
  for (std::size_t c = 0; c < n; ++c) {
    const std::uint32_t i = bi[c];
    const double nx = nxs[c], ny = nys[c], nz = nzs[c];
    const double ri = r[i];
    // the contact point's velocity relative to the drum's surface there (drum::
    // surface_velocity, omega x p): (v_i - omega x p) + w_i x (-r_i n)
    const double ax = -ri * nx, ay = -ri * ny, az = -ri * nz;
    const double vrx = (vx[i] - -omega * pys[c]) + (wy[i] * az - wz[i] * ay);
    const double vry = (vy[i] - omega * pxs[c]) + (wz[i] * ax - wx[i] * az);
    const double vrz = (vz[i] - 0.0) + (wx[i] * ay - wy[i] * ax);
    double cx, cy, cz;
    law_in_lane(pair_in_lane<Uniform>(one, pairs, bp, c), nx, ny, nz, overlaps[c], ri, m[i], vrx,
                vry, vrz, dt, sxs[c], sys[c], szs[c], fxs[c], fys[c], fzs[c], cx, cy, cz);
    txs[c] = -ri * cx, tys[c] = -ri * cy, tzs[c] = -ri * cz;  // (-r_i n) x F_t
  }
}

/// This target's builds of the loops, [uniform] as LaneKernels holds them.
inline constexpr ContactForcesInLanes contact_loop[2] = {&contact_forces_in_lanes<false>,
                                                         &contact_forces_in_lanes<true>};
inline constexpr WallForcesInLanes wall_loop[2] = {&wall_forces_in_lanes<false>,
                                                   &wall_forces_in_lanes<true>};
#endif  // a build of the loop

}  // namespace millscope::engine::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // per-target include guard
