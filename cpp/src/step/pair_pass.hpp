// Stage: the pair pass, contact forces between particles (Engine::Access::Step). This file:
// which path a kernel takes, and the path of every law but the paper's without the ledger
// (contact::pair_force per listed pair); pair_pass_lanes.hpp: the paper's law in SIMD lanes.
#pragma once

#include "step/context.hpp"
#include "step/pair_pass_lanes.hpp"

namespace millscope::engine {

// Pair forces of the rows [row_split[t], row_split[t+1]) ("own" particles of thread t). The
// list is a half list (j > i), so every write of thread t goes to a particle at or after its
// first row: own particles are summed straight into the shared arrays (forces into fx.., the
// dissipating parts into e.dissipative_), later ones into thread t's buffer, which holds only
// the particles after its rows up to its last partner (buffer_end). No two threads write the
// same place.
template <class S>
void Engine::Access::Step<S>::pair_pass(int t, double history_dt, const NearLook& look,
                                        StepPartial& part) {
  const std::size_t row_begin = e.row_split_[static_cast<std::size_t>(t)];
  const std::size_t own_end = e.row_split_[static_cast<std::size_t>(t) + 1];
  const std::size_t later = e.buffer_end_[static_cast<std::size_t>(t)] - own_end;  // buffered
  double* const buf = e.buffers_[static_cast<std::size_t>(t)].data();
  std::fill(buf, buf + width * later, 0.0);
  // quantity c of particle k: own[c][k] for k < own_end, buffered[c][k - own_end] after
  double* buffered[12];
  for (std::size_t c = 0; c < 12; ++c) buffered[c] = c < width ? buf + c * later : nullptr;
  for (std::size_t c = 0; c < width; ++c) std::fill(own[c] + row_begin, own[c] + own_end, 0.0);
  if constexpr (in_lanes) {
    pair_pass_in_lanes(t, history_dt, look, part, row_begin, own_end, buffered);
    return;
  }

  (void)look;  // the wide search's alone
  const std::uint32_t* const start = e.list_.start().data();
  const std::uint32_t* const partner = e.list_.partner().data();
  double* const history = e.list_.history().data();
  for (std::size_t i = row_begin; i < own_end; ++i) {
    double sum_i[12] = {};  // this row's sums for i, in the layout of own[]
    for (std::uint32_t s = start[i]; s < start[i + 1]; ++s) {
      const std::size_t j = partner[s];
      double* const hist = hs > 0 ? history + static_cast<std::size_t>(s) * hs : nullptr;
      const double dx = x[i] - x[j], dy = y[i] - y[j];
      double dz = z[i] - z[j];
      if constexpr (!EndWalls) dz -= period * std::nearbyint(dz / period);
      const double r_sum = r[i] + r[j];
      const double d2 = dx * dx + dy * dy + dz * dz;
      if (!(d2 < r_sum * r_sum)) {
        if constexpr (dissipates && friction) {
          if (Law::holds(hist)) {  // a contact has ended
            part.spring_work -= ended_pair_energy(i, j, dx, dy, dz, history_dt, hist);
            Law::reset(hist);
          }
        } else if constexpr (hs > 0) {
          Law::clear(hist);
        }
        continue;
      }
      const double dist = std::sqrt(d2);
      const double r_min = std::min(r[i], r[j]);
      if (r_sum - dist > max_overlap * r_min) part.note_overlap(i, (r_sum - dist) / r_min, false);
      const double inv_dist = 1.0 / dist;
      const Vec3 nrm(dx * inv_dist, dy * inv_dist, dz * inv_dist);  // from j to i
      const Vec3 vi(vx[i], vy[i], vz[i]), vj(vx[j], vy[j], vz[j]);
      Vec3 v_rel = vi - vj;
      if constexpr (friction) {
        const Vec3 wi(wx[i], wy[i], wz[i]), wj(wx[j], wy[j], wz[j]);
        v_rel += wi.cross(-r[i] * nrm) - wj.cross(r[j] * nrm);
      }
      const double r_star = r[i] * r[j] / r_sum;
      const double m_star = 1.0 / (inv_m[i] + inv_m[j]);
      const contact::PairForce pf = contact::pair_force<Law, dissipates>(
          pair_of(i, j), nrm, r_sum - dist, r_star, m_star, v_rel, r[i], r[j], history_dt, hist);

      // What i and j receive, in the layout of own[].
      double to_j[12];
      auto put = [&](std::size_t c, const Vec3& on_i, const Vec3& on_j) {
        for (std::size_t k = 0; k < 3; ++k) {
          sum_i[c + k] += on_i[static_cast<Eigen::Index>(k)];
          to_j[c + k] = on_j[static_cast<Eigen::Index>(k)];
        }
      };
      put(0, pf.force_i, -pf.force_i);
      if constexpr (friction) {
        put(3, pf.torque_i, pf.torque_j);
        if constexpr (dissipates) {
          part.friction_loss += pf.friction_loss;
          part.spring_work += pf.spring_work;
        }
      }
      if constexpr (dissipates) {
        part.loss += pf.loss;
        put(6, pf.dissipative, -pf.dissipative);
        if constexpr (friction) {
          const Vec3 nxd = nrm.cross(pf.dissipative);  // (-r_i n) x d on i, (r_j n) x (-d) on j
          put(9, -r[i] * nxd, -r[j] * nxd);
        }
        part.damping_power += pf.damping_power;
      }
      const bool j_own = j < own_end;
      const std::size_t k = j_own ? j : j - own_end;
      double* const* const dst = j_own ? own : buffered;
      for (std::size_t c = 0; c < 3; ++c) dst[c][k] += to_j[c];
      if constexpr (friction)
        for (std::size_t c = 3; c < 6; ++c) dst[c][k] += to_j[c];
      if constexpr (dissipates)
        for (std::size_t c = 6; c < 9; ++c) dst[c][k] += to_j[c];
      if constexpr (dissipates && friction)
        for (std::size_t c = 9; c < 12; ++c) dst[c][k] += to_j[c];
    }
    for (std::size_t c = 0; c < width; ++c) own[c][i] += sum_i[c];
  }
}

}  // namespace millscope::engine
