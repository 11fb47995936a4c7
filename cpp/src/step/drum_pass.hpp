// Stage: the drum's contacts of a particle (Engine::Access::Step), called by the particle pass
// for the particles near the drum (those that may touch it before the next refresh_walls):
// shell, end walls and lifters, added to the particle's sums (force, N; torque, N m; with the
// ledger, the dissipating force and its torque), and the drive torque.
// - each_drum_contact finds them and keeps each one's slot of wall history;
// - drum_contacts computes them one at a time (contact::pair_force);
// - collect_drum_contacts and add_drum_contacts, for the paper's law without the ledger, put a
//   chunk's contacts in a WallBatch, whose forces the SIMD path computes in lanes
//   (wall_forces_in_lanes), and then add them up in the same order, to the same bits.
#pragma once

#include "step/context.hpp"

namespace millscope::engine {

// Drive torque: ((x_c - axis) x F_drum_on_particle) . z (docs/architecture.md, Torque), from
// the contact point (px, py), m, and the force on the particle (fx, fy), N; booked by the part
// of the drum it acts on.
template <class S>
void Engine::Access::Step<S>::add_drive_torque(StepPartial& part, drum::Part where, double px,
                                               double py, double fx, double fy) {
  const double arm_torque = px * fy - py * fx;
  if (where == drum::Part::shell) {
    part.shell += arm_torque;
  } else if (where == drum::Part::lifter) {
    part.lifters += arm_torque;
  } else {
    part.ends += arm_torque;
  }
}

template <class S>
template <class Visit>
void Engine::Access::Step<S>::each_drum_contact(std::size_t i, double history_dt,
                                                StepPartial& part, Visit&& visit) {
  const Vec3 xi(x[i], y[i], z[i]);
  drum::WallContacts found = drum::find_contacts_of<Lifters, EndWalls>(
      geom, e.lifter_angles_, xi, r[i], Lifters ? e.lifter_reach_[i] : drum::no_lifter);
  if (found.count == 0 && (!friction || e.wall_held_[i] == 0)) return;  // nothing to do
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
    visit(wc, hist);
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
}

template <class S>
void Engine::Access::Step<S>::drum_contacts(std::size_t i, double history_dt, StepPartial& part) {
  const double omega = e.omega_;
  const Vec3 vi(vx[i], vy[i], vz[i]), wi(wx[i], wy[i], wz[i]);
  // The particle's sums, taken at its first contact and put back once (each_drum_contact
  // visits its contacts in order, and the sums add them in that order); a particle that
  // touches nothing does not read them.
  Vec3 f(0.0, 0.0, 0.0), tq(0.0, 0.0, 0.0);
  [[maybe_unused]] Vec3 diss(0.0, 0.0, 0.0), diss_tq(0.0, 0.0, 0.0);
  bool touched = false;
  each_drum_contact(i, history_dt, part, [&](const drum::WallContact& wc, double* hist) {
    if (!touched) {
      touched = true;
      f = sums_of(0, i);
      if constexpr (friction) tq = sums_of(3, i);
      if constexpr (dissipates) {
        diss = sums_of(6, i);
        if constexpr (friction) diss_tq = sums_of(9, i);
      }
    }
    const Vec3 v_wall = drum::surface_velocity(omega, wc.point);
    Vec3 v_rel = vi - v_wall;
    if constexpr (friction) v_rel += wi.cross(-r[i] * wc.normal);
    const contact::PairForce pf = contact::pair_force<Law, dissipates>(
        wall_pair_of(i), wc.normal, wc.overlap, r[i], m[i], v_rel, r[i], 0.0, history_dt, hist);
    f += pf.force_i;
    add_drive_torque(part, wc.part, wc.point.x(), wc.point.y(), pf.force_i.x(),
                     pf.force_i.y());
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
  });
  if (!touched) return;
  put_sums(0, i, f);
  if constexpr (friction) put_sums(3, i, tq);
  if constexpr (dissipates) {
    put_sums(6, i, diss);
    if constexpr (friction) put_sums(9, i, diss_tq);
  }
}

template <class S>
void Engine::Access::Step<S>::collect_drum_contacts(std::size_t i, double history_dt,
                                                    StepPartial& part, WallBatch& b) {
  static_assert(in_lanes && hs == 3, "the lanes carry the spring d_t, 3 doubles");
  each_drum_contact(i, history_dt, part, [&](const drum::WallContact& wc, double* hist) {
    const std::size_t c = b.size++;
    b.i[c] = static_cast<std::uint32_t>(i);
    b.pair[c] = lane_pair(mat[i], drum_mat);
    b.part[c] = static_cast<std::uint8_t>(wc.part);
    b.spring[c] = hist;
    b.nx[c] = wc.normal.x(), b.ny[c] = wc.normal.y(), b.nz[c] = wc.normal.z();
    b.overlap[c] = wc.overlap;
    b.px[c] = wc.point.x(), b.py[c] = wc.point.y();
    b.sx[c] = hist[0], b.sy[c] = hist[1], b.sz[c] = hist[2];
  });
}

template <class S>
void Engine::Access::Step<S>::add_drum_contacts(const WallBatch& b, StepPartial& part) {
  for (std::size_t c = 0; c < b.size; ++c) {
    const std::size_t i = b.i[c];
    own[0][i] += b.fx[c], own[1][i] += b.fy[c], own[2][i] += b.fz[c];
    own[3][i] += b.tx[c], own[4][i] += b.ty[c], own[5][i] += b.tz[c];
    add_drive_torque(part, static_cast<drum::Part>(b.part[c]), b.px[c], b.py[c], b.fx[c],
                     b.fy[c]);
    double* const hist = b.spring[c];
    hist[0] = b.sx[c], hist[1] = b.sy[c], hist[2] = b.sz[c];
  }
}

}  // namespace millscope::engine
