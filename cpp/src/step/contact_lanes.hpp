// The block of contacts the pair pass computes in SIMD lanes (src/step/pair_pass_lanes.hpp),
// and the signature of the loop that computes them (contact_lanes-inl.hpp, compiled once per
// SIMD target in lane_kernels.cpp). Private to the library.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "millscope/engine.hpp"  // wide_block_listed
#include "millscope/materials.hpp"
#include "touching_pairs.hpp"

namespace millscope::engine {

/// One thread's touching pairs of a block of list rows, in list order, as arrays: the pair
/// pass finds them, computes their forces in SIMD lanes (contact_forces_in_lanes), then sums
/// them into the particles in list order.
struct ContactBatch {
  static constexpr std::size_t max_contacts = 64;  // a block closes once it holds this many
  static constexpr std::size_t max_rows = 128;     // ... or this many rows
  std::size_t size = 0;
  std::vector<std::uint32_t> i, j, slot, pair;  // rows, partners, list slots, pair constants
                                                // (pair: not set with one material)
  std::vector<double> dx, dy, dz;               // x_i - x_j, m
  std::vector<double> sx, sy, sz;               // tangential spring d_t, m: in, then out
  std::vector<double> overlap;                  // d_n = r_i + r_j - |x_i - x_j|, m
  std::vector<double> fx, fy, fz;               // force on i, N
  std::vector<double> tix, tiy, tiz, tjx, tjy, tjz;  // torques on i and on j, N m

  // The wide search's scratch (touching_pairs.hpp): each listed pair's row.
  std::vector<std::uint32_t> slot_row;

  ContactBatch() {
    reserve(4 * max_contacts);
    reserve_listed(wide_block_listed);
  }
  /// Room for `more` contacts beyond size (one row may hold many).
  void reserve(std::size_t more) {
    const std::size_t need = size + more;
    if (need <= overlap.size()) return;
    for (auto* v : {&i, &j, &slot, &pair}) v->resize(need);
    for (auto* v : {&dx, &dy, &dz, &sx, &sy, &sz, &overlap, &fx, &fy, &fz, &tix, &tiy, &tiz, &tjx,
                    &tjy, &tjz})
      v->resize(need);
  }
  /// Room for a block of `listed` listed pairs in the wide search, which stores whole
  /// vectors past its last entry.
  void reserve_listed(std::size_t listed) {
    const std::size_t need = listed + max_search_lanes;
    if (need > slot_row.size()) slot_row.resize(need);
    if (need > overlap.size()) reserve(need - size);
  }
};

/// The paper's law (contact::HertzMindlin: Hertz (1), viscous damping (2), Mindlin no-slip
/// spring (5)-(7) with the Coulomb limit (8), unclamped) for every contact of a block, in SIMD
/// lanes (contact_lanes-inl.hpp), the same to the bit as contact::pair_force. Particles are
/// read through the pairs' indices (radius r, m; inverse mass, 1/kg; velocity, m/s; spin,
/// rad/s); `pairs` holds the pair constants; dt, s, advances the springs.
using ContactForcesInLanes = void (*)(ContactBatch& b, const materials::PairConstants* pairs,
                                      const double* r, const double* inv_m, const double* vx,
                                      const double* vy, const double* vz, const double* wx,
                                      const double* wy, const double* wz, double dt);

/// One thread's contacts with the drum of a chunk of particles, in particle order and, per
/// particle, in the order drum::find_contacts_of gives them, as arrays: the particle pass finds
/// them (step/drum_pass.hpp), computes their forces in SIMD lanes (wall_forces_in_lanes), then
/// adds them to the particles and to the drive torque in the same order.
struct WallBatch {
  static constexpr std::size_t per_particle = 5;  // shell, two end walls, two lifters
  std::size_t size = 0;
  std::vector<std::uint32_t> i, pair;           // particles, pair constants
  std::vector<std::uint8_t> part;               // drum::Part
  std::vector<double*> spring;                  // each contact's history slot
  std::vector<double> nx, ny, nz;               // normal from the wall into the sphere
  std::vector<double> overlap;                  // d_n, m
  std::vector<double> px, py;                   // contact point on the wall, m (z unused)
  std::vector<double> sx, sy, sz;               // tangential spring d_t, m: in, then out
  std::vector<double> fx, fy, fz;               // force on the particle, N
  std::vector<double> tx, ty, tz;               // torque on the particle, N m

  /// Room for the contacts of `particles` particles.
  explicit WallBatch(std::size_t particles) {
    const std::size_t room = per_particle * particles;
    for (auto* v : {&i, &pair}) v->resize(room);
    part.resize(room);
    spring.resize(room);
    for (auto* v : {&nx, &ny, &nz, &overlap, &px, &py, &sx, &sy, &sz, &fx, &fy, &fz, &tx, &ty,
                    &tz})
      v->resize(room);
  }
};

/// The paper's law for every contact of a WallBatch, in SIMD lanes (contact_lanes-inl.hpp),
/// the same to the bit as contact::pair_force with R* = r_i and m* = m_i as the drum pass
/// calls it. The drum turns at omega, rad/s, about +z; particles are read through the
/// contacts' indices (radius r, m; mass m, kg; velocity, m/s; spin, rad/s); dt, s, advances
/// the springs.
using WallForcesInLanes = void (*)(WallBatch& b, const materials::PairConstants* pairs,
                                   const double* r, const double* m, const double* vx,
                                   const double* vy, const double* vz, const double* wx,
                                   const double* wy, const double* wz, double omega, double dt);

}  // namespace millscope::engine
