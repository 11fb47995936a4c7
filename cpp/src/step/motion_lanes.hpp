// The velocity-Verlet kicks and the drift over a range of particles, as the step's stages call
// them (step/kick_drift.hpp, step/particle_pass.hpp), and the signatures of the loops that
// compute them in SIMD lanes (motion_lanes-inl.hpp, compiled once per SIMD target in
// lane_kernels.cpp). Private to the library.
#pragma once

#include <cstddef>

namespace millscope::engine {

/// The engine's per-particle arrays the kicks and the drift read and write: position, m;
/// velocity, m/s; spin, rad/s; force, N; torque, N m; inverse mass, 1/kg; inverse moment of
/// inertia, 1/(kg m^2); the positions at the last list build (floats), m.
struct MotionArrays {
  double *x, *y, *z, *vx, *vy, *vz, *wx, *wy, *wz;
  const double *fx, *fy, *fz, *tx, *ty, *tz, *inv_m, *inv_i;
  const float *x_ref, *y_ref, *z_ref;
};

/// What the drift needs besides the arrays: the time step's half and whole, s; the period
/// along z, m (periodic scenes: positions wrap into [0, period), moves by the nearest image);
/// the guard's bounds, the largest squared speed, m^2/s^2, and the shell's radius squared, m^2.
struct DriftSettings {
  double half_dt, dt, period, max_speed2, radius2;
};

/// What a drift found: the largest squared move since the list build, m^2; the largest
/// squared speed it moved at, m^2/s^2; and, where the guard looked, whether every particle
/// passed it (Engine::Access::Step::sound).
struct DriftFound {
  double move2;
  double speed2;
  bool sound;
};

/// The first half kick and the drift of particles [lo, hi) (step/kick_drift.hpp), indexed
/// [friction][periodic][guard] in LaneKernels: v += (F / m) dt/2, w += (T / I) dt/2 with
/// friction, x += v dt.
using KickDriftInLanes = DriftFound (*)(const MotionArrays& a, std::size_t lo, std::size_t hi,
                                        const DriftSettings& s);

/// The second half kick of particles [lo, hi) (step/particle_pass.hpp), [friction]:
/// v += F (dt/2 / m), w += T (dt/2 / I) with friction.
using HalfKickInLanes = void (*)(const MotionArrays& a, std::size_t lo, std::size_t hi,
                                 double half_dt);

}  // namespace millscope::engine
