// Stage: the drum's contacts of one particle (Engine::Access::Step), called by the particle
// pass for the particles near the drum (those that may touch it before the next
// refresh_walls): shell, end walls and lifters, added to the particle's sums (force, N;
// torque, N m; with the ledger, the dissipating force and its torque), and the drive torque.
#pragma once

#include "step/context.hpp"

namespace millscope::engine {

template <class S>
void Engine::Access::Step<S>::drum_contacts(std::size_t i, double history_dt, StepPartial& part) {
  const Vec3 xi(x[i], y[i], z[i]);
  drum::WallContacts found = drum::find_contacts_of<Lifters, EndWalls>(
      geom, e.lifter_angles_, xi, r[i], Lifters ? e.lifter_reach_[i] : drum::no_lifter);
  if (found.count == 0 && (!friction || e.wall_held_[i] == 0)) return;  // nothing to do
  const double omega = e.omega_;
  Vec3 f = sums_of(0, i);
  Vec3 tq = friction ? sums_of(3, i) : Vec3(0.0, 0.0, 0.0);
  [[maybe_unused]] Vec3 diss(0.0, 0.0, 0.0), diss_tq(0.0, 0.0, 0.0);
  if constexpr (dissipates) {
    diss = sums_of(6, i);
    if constexpr (friction) diss_tq = sums_of(9, i);
  }
  const Vec3 vi(vx[i], vy[i], vz[i]), wi(wx[i], wy[i], wz[i]);
  [[maybe_unused]] unsigned used = 0;  // wall history slots touched this step
  [[maybe_unused]] std::int32_t* lifter_of_slot = nullptr;
  [[maybe_unused]] double* wall_hist = nullptr;
  if constexpr (friction) {  // a particle near the drum has a block (see particle_pass)
    const auto block = static_cast<std::size_t>(e.wall_block_[i]);
    lifter_of_slot = &e.wall_lifter_[2 * block];
    wall_hist = &e.wall_history_[block * wall_slots * hs];
  }
  for (int c = 0; c < found.count; ++c) {
    const drum::WallContact& wc = found.items[static_cast<std::size_t>(c)];
    double* hist = nullptr;
    if constexpr (friction) {
      std::size_t slot = 0;
      if (wc.part == drum::Part::lifter) {
        if (lifter_of_slot[0] == wc.index) {
          slot = 3;
        } else if (lifter_of_slot[1] == wc.index) {
          slot = 4;
        } else {
          // A new lifter contact takes a slot no current contact holds.
          const bool slot3_held = [&] {
            for (int o = 0; o < found.count; ++o) {
              const auto& other = found.items[static_cast<std::size_t>(o)];
              if (other.part == drum::Part::lifter && other.index == lifter_of_slot[0])
                return true;
            }
            return false;
          }();
          slot = slot3_held ? 4 : 3;
          if constexpr (dissipates)  // the slot's last holder has left it
            part.spring_work -= ended_wall_energy(i, slot, lifter_of_slot[slot - 3], history_dt,
                                                  wall_hist + slot * hs);
          lifter_of_slot[slot - 3] = wc.index;
          Law::reset(wall_hist + slot * hs);
        }
      } else {
        slot = static_cast<std::size_t>(wc.part);  // shell 0, end_low 1, end_high 2
      }
      used |= 1u << slot;
      hist = wall_hist + slot * hs;
    }
    if (wc.overlap > max_overlap * r[i]) part.note_overlap(i, wc.overlap / r[i], true);
    const Vec3 v_wall = drum::surface_velocity(omega, wc.point);
    Vec3 v_rel = vi - v_wall;
    if constexpr (friction) v_rel += wi.cross(-r[i] * wc.normal);
    const contact::PairForce pf = contact::pair_force<Law, dissipates>(
        wall_pair_of(i), wc.normal, wc.overlap, r[i], m[i], v_rel, r[i], 0.0, history_dt, hist);
    f += pf.force_i;
    // Drive torque: ((x_c - axis) x F_drum_on_particle) . z (docs/architecture.md, Torque).
    const double arm_torque = wc.point.x() * pf.force_i.y() - wc.point.y() * pf.force_i.x();
    if (wc.part == drum::Part::shell) {
      part.shell += arm_torque;
    } else if (wc.part == drum::Part::lifter) {
      part.lifters += arm_torque;
    } else {
      part.ends += arm_torque;
    }
    if constexpr (dissipates) {
      part.damping_power += pf.damping_power;
      part.loss += pf.loss;
      diss += pf.dissipative;
      if constexpr (friction) diss_tq += wc.normal.cross(pf.dissipative) * -r[i];
    }
    if constexpr (friction) {
      tq += pf.torque_i;
      if constexpr (dissipates) {
        part.friction_loss += pf.friction_loss;
        part.spring_work += pf.spring_work;
      }
    }
  }
  if constexpr (friction) {
    // Contacts that ended: clear their history and free their lifter slot.
    const unsigned ended = e.wall_held_[i] & ~used;
    if (ended != 0) {
      for (std::size_t slot = 0; slot < wall_slots; ++slot) {
        if (!(ended & (1u << slot))) continue;
        if constexpr (dissipates)
          part.spring_work -= ended_wall_energy(i, slot, slot >= 3 ? lifter_of_slot[slot - 3] : -1,
                                                history_dt, wall_hist + slot * hs);
        if (slot >= 3) lifter_of_slot[slot - 3] = -1;
        Law::reset(wall_hist + slot * hs);
      }
    }
    e.wall_held_[i] = static_cast<std::uint8_t>(used);
  }
  put_sums(0, i, f);
  if constexpr (friction) put_sums(3, i, tq);
  if constexpr (dissipates) {
    put_sums(6, i, diss);
    if constexpr (friction) put_sums(9, i, diss_tq);
  }
}

}  // namespace millscope::engine
