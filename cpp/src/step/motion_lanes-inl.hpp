// The loops of motion_lanes.hpp (the kicks and the drift), compiled for each SIMD target
// lane_kernels.cpp names (foreach_target.h includes this file once per target): the compiler
// moves several particles in the lanes of one instruction of that target. Every operation is
// the scalar one, in the same order and unfused (-ffp-contract=off), so every target gives
// the same bits. Not for other files.

// Per-target include guard: Highway toggles HWY_TARGET_TOGGLE for each target it compiles.
#if defined(MILLSCOPE_MOTION_LANES_INL_) == defined(HWY_TARGET_TOGGLE)
#ifdef MILLSCOPE_MOTION_LANES_INL_
#undef MILLSCOPE_MOTION_LANES_INL_
#else
#define MILLSCOPE_MOTION_LANES_INL_
#endif

#include <hwy/highway.h>

#include <cmath>
#include <cstddef>

#include "step/motion_lanes.hpp"

HWY_BEFORE_NAMESPACE();
namespace millscope::engine::HWY_NAMESPACE {

/// KickDriftInLanes: the first half kick, v += (F / m) dt/2 (and w += (T / I) dt/2), then
/// the drift x += v dt; with Periodic, z wraps into [0, period) and the move since the list
/// build is taken to the nearest image. Returns the largest squared move, the largest squared
/// speed of the drift (a NaN speed is passed over) and, with Guard, whether every new state
/// passes the guard (speed^2 <= max_speed2, x^2 + y^2 <= radius2; NaN passes neither). The
/// maxima are exact in any order (a maximum rounds nothing).
template <bool Friction, bool Periodic, bool Guard>
DriftFound kick_drift_in_lanes(const MotionArrays& a, std::size_t lo, std::size_t hi,
                               const DriftSettings& s) {
  // A copy: the loop's stores (doubles) cannot move its pointers, so they stay in registers;
  // `omp simd` says that the arrays' lanes do not depend on one another.
  const MotionArrays m = a;
  const double half_dt = s.half_dt, dt = s.dt, period = s.period;
  const double max_speed2 = s.max_speed2, radius2 = s.radius2;
  double move2 = 0.0, speed2 = 0.0;
  int sound = 1;  // an int, which the lanes reduce with &
#pragma omp simd reduction(max : move2) reduction(max : speed2) reduction(& : sound)
  for (std::size_t i = lo; i < hi; ++i) {
    const double vxi = m.vx[i] + m.fx[i] * m.inv_m[i] * half_dt;
    const double vyi = m.vy[i] + m.fy[i] * m.inv_m[i] * half_dt;
    const double vzi = m.vz[i] + m.fz[i] * m.inv_m[i] * half_dt;
    m.vx[i] = vxi;
    m.vy[i] = vyi;
    m.vz[i] = vzi;
    if constexpr (Friction) {
      m.wx[i] += m.tx[i] * m.inv_i[i] * half_dt;
      m.wy[i] += m.ty[i] * m.inv_i[i] * half_dt;
      m.wz[i] += m.tz[i] * m.inv_i[i] * half_dt;
    }
    const double xi = m.x[i] + vxi * dt, yi = m.y[i] + vyi * dt;
    double zi = m.z[i] + vzi * dt;
    double dz = zi - static_cast<double>(m.z_ref[i]);
    if constexpr (Periodic) {
      zi -= period * std::floor(zi / period);
      dz -= period * std::nearbyint(dz / period);
    }
    m.x[i] = xi;
    m.y[i] = yi;
    m.z[i] = zi;
    const double dx = xi - static_cast<double>(m.x_ref[i]);
    const double dy = yi - static_cast<double>(m.y_ref[i]);
    const double d2 = dx * dx + dy * dy + dz * dz;
    move2 = move2 < d2 ? d2 : move2;
    const double v2 = vxi * vxi + vyi * vyi + vzi * vzi;
    speed2 = speed2 < v2 ? v2 : speed2;
    if constexpr (Guard)
      sound &= static_cast<int>(v2 <= max_speed2) & static_cast<int>(xi * xi + yi * yi <= radius2);
  }
  return DriftFound{move2, speed2, sound != 0};
}

/// HalfKickInLanes: the second half kick, v += F (dt/2 / m) (and w += T (dt/2 / I)).
template <bool Friction>
void half_kick_in_lanes(const MotionArrays& a, std::size_t lo, std::size_t hi, double half_dt) {
  const MotionArrays m = a;  // as in kick_drift_in_lanes
#pragma omp simd
  for (std::size_t i = lo; i < hi; ++i) {
    const double kv = m.inv_m[i] * half_dt;
    m.vx[i] += m.fx[i] * kv;
    m.vy[i] += m.fy[i] * kv;
    m.vz[i] += m.fz[i] * kv;
    if constexpr (Friction) {
      const double kw = m.inv_i[i] * half_dt;
      m.wx[i] += m.tx[i] * kw;
      m.wy[i] += m.ty[i] * kw;
      m.wz[i] += m.tz[i] * kw;
    }
  }
}

/// This target's builds of the loops, indexed as LaneKernels holds them.
inline constexpr KickDriftInLanes kick_drift_loop[2][2][2] = {
    {{&kick_drift_in_lanes<false, false, false>, &kick_drift_in_lanes<false, false, true>},
     {&kick_drift_in_lanes<false, true, false>, &kick_drift_in_lanes<false, true, true>}},
    {{&kick_drift_in_lanes<true, false, false>, &kick_drift_in_lanes<true, false, true>},
     {&kick_drift_in_lanes<true, true, false>, &kick_drift_in_lanes<true, true, true>}}};
inline constexpr HalfKickInLanes half_kick_loop[2] = {&half_kick_in_lanes<false>,
                                                      &half_kick_in_lanes<true>};

}  // namespace millscope::engine::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // per-target include guard
