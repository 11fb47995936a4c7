// The energy ledger's share of a contact that ends (Engine::Access::Step): it drops what its
// spring held after the step before, S_t |d_t|^2 / 2 with S_t (6) at the overlap of then
// (Ledger::spring_work). The damped contact leaves in tension and slides out, so that energy
// does not vanish with the overlap: it scales as mu^2 (F_n, S_t and the dashpot all go as
// d_n^(1/4) to d_n^(1/2)).
#pragma once

#include "step/context.hpp"

namespace millscope::engine {

template <class S>
double Engine::Access::Step<S>::spring_energy_at(const materials::PairConstants& pc,
                                                 double r_star, double d_prev,
                                                 const double* hist) {
  if constexpr (friction) {
    if (!(d_prev > 0.0)) return 0.0;
    return Law::tangential_part::energy(pc, std::sqrt(r_star * d_prev),
                                        hist + Law::tangential_offset);
  } else {
    (void)pc, (void)r_star, (void)d_prev, (void)hist;
    return 0.0;
  }
}

// ... for a pair that has separated: its previous separation is d - (v_i - v_j) dt exactly.
template <class S>
double Engine::Access::Step<S>::ended_pair_energy(std::size_t i, std::size_t j, double dx,
                                                  double dy, double dz, double history_dt,
                                                  const double* hist) const {
  const double px = dx - (vx[i] - vx[j]) * history_dt, py = dy - (vy[i] - vy[j]) * history_dt,
               pz = dz - (vz[i] - vz[j]) * history_dt;
  const double r_sum = r[i] + r[j];
  return spring_energy_at(pair_of(i, j), r[i] * r[j] / r_sum,
                          r_sum - std::sqrt(px * px + py * py + pz * pz), hist);
}

// ... for a wall slot: the previous position x - v dt, turned by omega dt into the drum's
// frame of now (the lifters have turned since; the shell and the end walls look the same).
template <class S>
double Engine::Access::Step<S>::ended_wall_energy(std::size_t i, std::size_t slot, int lifter,
                                                  double history_dt, const double* hist) const {
  const double a = e.omega_ * history_dt, c = std::cos(a), sn = std::sin(a);
  const double px = x[i] - vx[i] * history_dt, py = y[i] - vy[i] * history_dt,
               pz = z[i] - vz[i] * history_dt;
  const Vec3 prev(c * px - sn * py, sn * px + c * py, pz);
  double d_prev = 0.0;
  if (slot == 0) {
    d_prev = std::hypot(prev.x(), prev.y()) + r[i] - geom.radius;
  } else if (slot == 1) {
    d_prev = r[i] - prev.z();
  } else if (slot == 2) {
    d_prev = prev.z() + r[i] - geom.length;
  } else if (lifter >= 0) {
    d_prev = drum::lifter_contact(geom, e.lifter_angles_, lifter, prev, r[i]).overlap;
  }
  return spring_energy_at(wall_pair_of(i), r[i], d_prev, hist);
}

}  // namespace millscope::engine
