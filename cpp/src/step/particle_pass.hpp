// Stage: the particle pass (Engine::Access::Step), per particle of thread t: the pair sums
// completed, the drum's contacts, the second half kick.
#pragma once

#include "step/context.hpp"
#include "step/drum_pass.hpp"

namespace millscope::engine {

// In chunks that stay in the first-level cache, three loops: the pair sums completed
// (gravity, then what the threads whose rows come before the particle buffered for it, in
// thread order), the drum's contacts of the particles near the drum, then (kick) the second
// half kick. Each sum takes its terms in the order a loop per particle would, so the forces
// are the same to the bit; the bulk pays nothing for the drum. Particles [lo, hi) of
// particle_split_ belong to thread t, here and in the kick and drift that follows with no
// barrier between.
template <class S>
void Engine::Access::Step<S>::particle_pass(int t, double history_dt, bool kick,
                                            StepPartial& part) {
  const std::size_t lo = e.particle_split_[static_cast<std::size_t>(t)];
  const std::size_t hi = e.particle_split_[static_cast<std::size_t>(t) + 1];
  for (std::size_t c0 = lo; c0 < hi; c0 += particle_chunk) {
    const std::size_t c1 = std::min(c0 + particle_chunk, hi);
    for (std::size_t i = c0; i < c1; ++i) fy[i] -= m[i] * gravity;
    for (int b = 0; b < team; ++b) {
      const std::size_t own_end = e.row_split_[static_cast<std::size_t>(b) + 1];
      const std::size_t end = e.buffer_end_[static_cast<std::size_t>(b)];
      const std::size_t from = std::max(c0, own_end), to = std::min(c1, end);
      if (from >= to) continue;
      const double* const buf = e.buffers_[static_cast<std::size_t>(b)].data();
      const std::size_t later = end - own_end;  // particles in thread b's buffer
      for (std::size_t q = 0; q < width; ++q) {
        if (!friction && q % 6 >= 3) continue;  // no torques
        double* const sum = own[q];
        const double* const add = buf + q * later;  // particle i at add[i - own_end]
        for (std::size_t i = from; i < to; ++i) sum[i] += add[i - own_end];
      }
    }
    // A particle that refresh_walls gave no block of wall history cannot reach the drum before
    // the next refresh (its margin): it skips the drum. Without friction there are no
    // blocks, and every particle looks (find_contacts_of gives up early in the bulk). The
    // paper's law without the ledger computes the chunk's contacts in SIMD lanes.
    if constexpr (in_lanes) {
      WallBatch& b = *wall_batches[static_cast<std::size_t>(t)];
      b.size = 0;
      for (std::size_t i = c0; i < c1; ++i)
        if (e.wall_block_[i] >= 0) collect_drum_contacts(i, history_dt, part, b);
      if (b.size > 0) {
        lanes.wall_forces[OneMaterial](b, lane_pairs(), r, m, vx, vy, vz, wx, wy, wz, e.omega_,
                                       history_dt);
        add_drum_contacts(b, part);
      }
    } else {
      for (std::size_t i = c0; i < c1; ++i)
        if (!friction || e.wall_block_[i] >= 0) drum_contacts(i, history_dt, part);
    }
    if (!kick) {  // a step's kick_drift checks it otherwise
      for (std::size_t i = c0; i < c1; ++i)
        if (!sound(i)) part.bad = std::min(part.bad, i);
      continue;
    }
    // The dissipating forces worked against the half-step velocities; what the integrator
    // removes is their work with the full-step ones (Ledger::dissipated): booked with the
    // half kick's own increments, F (dt/2 / m) and T (dt/2 / I), before it.
    if constexpr (dissipates) {
      for (std::size_t i = c0; i < c1; ++i) {
        const double kv = inv_m[i] * half_dt;
        const Vec3 dv(fx[i] * kv, fy[i] * kv, fz[i] * kv);
        Vec3 dw(0.0, 0.0, 0.0);
        if constexpr (friction) {
          const double kw = inv_i[i] * half_dt;
          dw = Vec3(tx[i] * kw, ty[i] * kw, tz[i] * kw);
        }
        const Vec3 diss = sums_of(6, i);
        const Vec3 diss_tq = friction ? sums_of(9, i) : Vec3(0.0, 0.0, 0.0);
        part.dissipation_shift -= (diss.dot(dv) + diss_tq.dot(dw)) * dt;
      }
    }
    lanes.half_kick[friction](motion, c0, c1, half_dt);  // motion_lanes-inl.hpp
  }
}

}  // namespace millscope::engine
