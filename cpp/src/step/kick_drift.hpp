// Stage: the first half kick and the drift of thread t's particles (Engine::Access::Step).
#pragma once

#include "step/context.hpp"

namespace millscope::engine {

// Particles [lo, hi) of particle_split_; tracks the largest move since the list build and,
// with Guard, guards the new state (see sound).
template <class S>
template <bool Guard>
void Engine::Access::Step<S>::kick_drift(int t, StepPartial& part) {
  const std::size_t lo = e.particle_split_[static_cast<std::size_t>(t)];
  const std::size_t hi = e.particle_split_[static_cast<std::size_t>(t) + 1];
  double move2 = 0.0;
  bool all_sound = true;  // a flag, not the index, in the loop
  for (std::size_t i = lo; i < hi; ++i) {
    // in locals, so that the guard reads them from registers (stores through the arrays
    // would make the compiler load them again)
    const double vxi = vx[i] + fx[i] * inv_m[i] * half_dt;
    const double vyi = vy[i] + fy[i] * inv_m[i] * half_dt;
    const double vzi = vz[i] + fz[i] * inv_m[i] * half_dt;
    vx[i] = vxi;
    vy[i] = vyi;
    vz[i] = vzi;
    if constexpr (friction) {
      wx[i] += tx[i] * inv_i[i] * half_dt;
      wy[i] += ty[i] * inv_i[i] * half_dt;
      wz[i] += tz[i] * inv_i[i] * half_dt;
    }
    const double xi = x[i] + vxi * dt, yi = y[i] + vyi * dt;
    double zi = z[i] + vzi * dt;
    double dz = zi - e.z_ref_[i];
    if constexpr (!EndWalls) {
      zi -= period * std::floor(zi / period);
      dz -= period * std::nearbyint(dz / period);
    }
    x[i] = xi;
    y[i] = yi;
    z[i] = zi;
    const double dx = xi - e.x_ref_[i], dy = yi - e.y_ref_[i];
    move2 = std::max(move2, dx * dx + dy * dy + dz * dz);
    // the guard (see sound), branch-free
    if constexpr (Guard)
      all_sound &= (vxi * vxi + vyi * vyi + vzi * vzi <= max_speed2) &
                   (xi * xi + yi * yi <= radius2);
  }
  part.displacement2 = move2;
  if (Guard && !all_sound) {  // rare: find the first particle that failed
    for (std::size_t i = lo; i < hi && part.bad == std::numeric_limits<std::size_t>::max(); ++i)
      if (!sound(i)) part.bad = i;
  }
}

}  // namespace millscope::engine
