// The context of one call of a step kernel (Engine::Access::Step): what the stages read, named
// once, and the stages' declarations. Each stage is in a file of its own under src/step/;
// run.hpp holds the step loop that calls them. Private to the library.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "engine_access.hpp"
#include "millscope/contact.hpp"
#include "millscope/drum.hpp"
#include "millscope/engine.hpp"
#include "lane_kernels.hpp"

namespace millscope::engine {

/// Per-thread sums of one step, padded to a cache line so threads do not share one.
struct alignas(64) StepPartial {
  double shell = 0.0, lifters = 0.0, ends = 0.0;  // drive torque, N m
  double damping_power = 0.0;                     // W
  double friction_loss = 0.0;                     // J
  double dissipation_shift = 0.0;                 // J: see Ledger::dissipated
  double loss = 0.0;                              // J: contact::ContactForce::loss
  double spring_work = 0.0;                       // J: see Ledger::spring_work
  double displacement2 = 0.0;                     // largest squared move since the list build
  double speed2 = 0.0;                            // largest squared speed of the drift, m^2/s^2
  std::size_t bad = std::numeric_limits<std::size_t>::max();  // first particle in a bad state
  std::size_t deepest = std::numeric_limits<std::size_t>::max();   // a contact beyond max_overlap
  double deepest_ratio = 0.0;                                       // its overlap / radius
  bool deepest_at_wall = false;

  /// Guard: a contact deeper than max_overlap x the smaller radius (rare: a predictable branch).
  void note_overlap(std::size_t i, double ratio, bool wall) {
    if (ratio > deepest_ratio) {
      deepest = i;
      deepest_ratio = ratio;
      deepest_at_wall = wall;
    }
  }
};

struct NearPairs;  // step/near_pairs.hpp

/// Whether the wide search looks again for its near pairs at a step, and for those within
/// which gap of touching, m (step/near_pairs.hpp).
struct NearLook {
  bool renew;
  double gap;
};

/// What the step loop follows of the near pairs, alike in every thread (run.hpp,
/// Step::near_renewal): this step's look; the list build they were found in (-1: not yet in
/// this call); how far any particle may have moved since, m, and in how many steps.
struct NearWatch {
  NearLook look;
  long build = -1;
  double travel = 0.0;
  long steps = 0;
};

/// What a step kernel is specialised for: the law and the scene's shape.
template <class L, bool OneMaterial, bool Lifters, bool EndWalls, bool Tally>
struct Shape {
  using Law = L;
  static constexpr bool one_material = OneMaterial;
  static constexpr bool lifters = Lifters;
  static constexpr bool end_walls = EndWalls;
  static constexpr bool tally = Tally;
};

template <class S>
struct Engine::Access::Step {
  using Law = typename S::Law;
  using Vec3 = contact::Vec3;
  static constexpr bool OneMaterial = S::one_material;
  static constexpr bool Lifters = S::lifters;
  static constexpr bool EndWalls = S::end_walls;
  static constexpr bool Tally = S::tally;
  static constexpr std::size_t hs = Law::history_size;  // per pair-contact history, doubles
  static constexpr bool friction = Law::has_friction;
  // Whether the step books the dissipated energy (Ledger): the dissipating forces summed per
  // particle, the dashpots' power and the sliding losses. Without it (Config::track_energy)
  // the forces are the same to the bit and only the drive work is booked.
  static constexpr bool dissipates = Law::dissipates && Tally;
  static constexpr std::size_t width = buffer_width(dissipates);  // per-thread buffer, x n doubles
  // The paper's law without the ledger computes its pair contacts in SIMD lanes
  // (contact_lanes.hpp); the ledger's kernels and the other laws take pair_force.
  static constexpr bool in_lanes = std::is_same_v<Law, contact::HertzMindlin> && !Tally;
  static_assert(hs == Law::tangential_part::history_size,
                "the pair history is the tangential spring alone, odd under swapping the pair "
                "(neighbors::VerletList negates it when a reorder swaps the pair's ranks)");

  Engine& e;
  StepObserver* observer;
  std::size_t n;
  int team;
  double dt, half_dt, gravity;
  const drum::Geometry& geom;
  double period;  // periodic ends: the drum length is the period
  std::size_t drum_mat;
  // One material in use: the drum's (used_materials counts the drum), whatever its index in
  // the table; the table may list materials the scene does not use.
  materials::PairConstants pc_one;
  const materials::PairTable& table;
  double skin_half2;    // a rebuild is due once a particle moved more than sqrt of this
  double lifter_drift;  // see refresh_walls
  double max_speed2;    // finite, so that an infinite speed fails the guard
  double max_overlap;
  double radius2;  // the shell's radius squared, m^2 (the guard)
  double *x, *y, *z, *vx, *vy, *vz, *wx, *wy, *wz, *fx, *fy, *fz, *tx, *ty, *tz;
  const double *r, *m, *inv_m, *inv_i;
  const std::uint8_t* mat;
  // The sums of each particle, in the layout of a thread's pair buffer: force, N; torque, N m;
  // with the ledger, the dissipating force and its torque (e.dissipative_).
  double* own[12];
  // The SIMD path's kernels (Engine::simd): the wide search where the path has it
  // (Engine::wide_pair_search), asking ahead for the state of the partners where the data
  // exceed the caches.
  const LaneKernels& lanes;
  // What the kicks and the drift read and write, for the SIMD path's loops.
  MotionArrays motion;
  DriftSettings drift;
  bool wide, prefetch;
  PartnerPrefetch ahead;
  // Two sets of per-thread partials, by step parity: step s writes set s % 2 while the threads
  // still read set (s - 1) % 2 to close the step before (see run.hpp).
  std::vector<StepPartial> partial;
  // One per share, made by the thread that runs it (see run.hpp), so that its arrays come
  // from that thread's allocator arena and share no cache line with another thread's.
  std::vector<std::unique_ptr<ContactBatch>> batches;
  std::vector<std::unique_ptr<WallBatch>> wall_batches;  // likewise, for the drum's contacts
  std::vector<std::unique_ptr<NearPairs>> near_pairs;    // likewise, with the wide search
  // The particle pass works in chunks of this many particles, which stay in the first-level
  // cache: 1 KiB of each of the ~20 arrays it reads.
  static constexpr std::size_t particle_chunk = 128;
  std::string error;  // written by the master thread; a run stops when it is set

  Step(Engine& engine, StepObserver* obs);
  void run(long steps);  // run.hpp

  StepPartial* partials_of(long s) {
    return partial.data() + static_cast<std::size_t>(s & 1) * static_cast<std::size_t>(team);
  }
  /// Sums q, q + 1, q + 2 of particle i (a vector: q = 0 force, 3 torque, 6 and 9 with the
  /// ledger), read and written.
  Vec3 sums_of(std::size_t q, std::size_t i) const {
    return Vec3(own[q][i], own[q + 1][i], own[q + 2][i]);
  }
  void put_sums(std::size_t q, std::size_t i, const Vec3& v) const {
    own[q][i] = v.x(), own[q + 1][i] = v.y(), own[q + 2][i] = v.z();
  }
  /// Guard: no speed above the bound, no centre beyond the shell. Called after a kick and a
  /// drift: a non-finite force makes the velocity non-finite (NaN fails every comparison, and
  /// an infinite speed exceeds max_speed2, which is finite), a non-finite torque the spin and
  /// through it the next step's forces.
  bool sound(std::size_t i) const {
    const double speed2 = vx[i] * vx[i] + vy[i] * vy[i] + vz[i] * vz[i];
    return speed2 <= max_speed2 && x[i] * x[i] + y[i] * y[i] <= radius2;
  }
  const materials::PairConstants& pair_of(std::size_t i, std::size_t j) const {
    return OneMaterial ? pc_one
                       : table(static_cast<std::size_t>(mat[i]), static_cast<std::size_t>(mat[j]));
  }
  const materials::PairConstants& wall_pair_of(std::size_t i) const {
    return OneMaterial ? pc_one : table(static_cast<std::size_t>(mat[i]), drum_mat);
  }
  /// The pair constants the lane kernels index (ContactBatch::pair, WallBatch::pair), and
  /// the index of the pair of materials a and b in them.
  const materials::PairConstants* lane_pairs() const {
    return OneMaterial ? &pc_one : &table(0, 0);
  }
  std::uint32_t lane_pair(std::size_t a, std::size_t b) const {
    return OneMaterial ? 0u : static_cast<std::uint32_t>(table.index(a, b));
  }

  // The stages, each in its own file.
  template <bool Guard>
  void kick_drift(int t, StepPartial& part);  // kick_drift.hpp
  // The wide search looks again for its near pairs where `look` says so (near_pairs.hpp).
  void pair_pass(int t, double history_dt, const NearLook& look,
                 StepPartial& part);  // pair_pass.hpp
  void pair_pass_in_lanes(int t, double history_dt, const NearLook& look, StepPartial& part,
                          std::size_t row_begin, std::size_t own_end,
                          double* const* buffered);  // pair_pass_lanes.hpp
  void find_near_pairs(NearPairs& near, ContactBatch& b, std::size_t row_begin,
                       std::size_t own_end, double gap);  // near_pairs.hpp
  template <class Visit>
  void each_drum_contact(std::size_t i, double history_dt, StepPartial& part,
                         Visit&& visit);                                      // drum_pass.hpp
  void drum_contacts(std::size_t i, double history_dt, StepPartial& part);  // drum_pass.hpp
  void collect_drum_contacts(std::size_t i, double history_dt, StepPartial& part,
                             WallBatch& b);                                   // drum_pass.hpp
  void add_drum_contacts(const WallBatch& b, StepPartial& part);            // drum_pass.hpp
  static void add_drive_torque(StepPartial& part, drum::Part where, double px, double py,
                               double fx, double fy);                         // drum_pass.hpp
  void particle_pass(int t, double history_dt, bool kick, StepPartial& part);  // particle_pass.hpp
  bool close_step(const StepPartial* parts, double ledger_dt, bool master, long step);  // close.hpp
  bool list_upkeep(int w, int workers, const StepPartial* parts, bool guarded, long step,
                   double theta, double& reach_theta);  // list_upkeep.hpp
  void near_renewal(const StepPartial* parts, NearWatch& near) const;  // run.hpp

  // Ledger: a contact that ends drops what its spring held after the step before (spring.hpp).
  static double spring_energy_at(const materials::PairConstants& pc, double r_star,
                                 double d_prev, const double* hist);
  double ended_pair_energy(std::size_t i, std::size_t j, double dx, double dy, double dz,
                           double history_dt, const double* hist) const;
  double ended_wall_energy(std::size_t i, std::size_t slot, int lifter, double history_dt,
                           const double* hist) const;
};

template <class S>
Engine::Access::Step<S>::Step(Engine& engine, StepObserver* obs)
    : e(engine),
      observer(obs),
      n(engine.n_),
      team(engine.threads_),
      dt(engine.dt_),
      half_dt(0.5 * engine.dt_),
      gravity(engine.config_.gravity),
      geom(engine.config_.geometry),
      period(engine.config_.geometry.length),
      drum_mat(static_cast<std::size_t>(engine.config_.drum_material)),
      pc_one(engine.pairs_(drum_mat, drum_mat)),
      table(engine.pairs_),
      lifter_drift(0.5 * engine.list_.skin()),
      max_speed2(std::min(engine.config_.max_speed * engine.config_.max_speed,
                          std::numeric_limits<double>::max())),
      max_overlap(engine.config_.max_overlap),
      radius2(geom.radius * geom.radius),
      x(engine.x_.data()), y(engine.y_.data()), z(engine.z_.data()),
      vx(engine.vx_.data()), vy(engine.vy_.data()), vz(engine.vz_.data()),
      wx(engine.wx_.data()), wy(engine.wy_.data()), wz(engine.wz_.data()),
      fx(engine.fx_.data()), fy(engine.fy_.data()), fz(engine.fz_.data()),
      tx(engine.tx_.data()), ty(engine.ty_.data()), tz(engine.tz_.data()),
      r(engine.r_.data()), m(engine.m_.data()), inv_m(engine.inv_m_.data()),
      inv_i(engine.inv_i_.data()), mat(engine.mat_.data()),
      own{fx, fy, fz, tx, ty, tz, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr},
      lanes(*engine.lanes_),
      motion{x, y, z, vx, vy, vz, wx, wy, wz, fx, fy, fz, tx, ty, tz, inv_m, inv_i,
             engine.x_ref_.data(), engine.y_ref_.data(), engine.z_ref_.data()},
      drift{half_dt, dt, period, max_speed2, radius2},
      wide(in_lanes && engine.wide_pair_search()),
      prefetch(wide && engine.prefetch_partners()),
      ahead{{x, y, z, r, vx, vy, vz, wx, wy, wz, inv_m}},
      partial(2 * static_cast<std::size_t>(team)),
      batches(static_cast<std::size_t>(team)),
      wall_batches(static_cast<std::size_t>(team)),
      near_pairs(static_cast<std::size_t>(team)) {
  // A rebuild is due once a particle may have moved skin/2 since the last build. The
  // reference positions are floats: each coordinate is off by at most half an ulp of the
  // drum's largest extent, so the test moves the threshold in by that much (x sqrt(3), and
  // twice over).
  const double ref_rounding = 2.0 * std::sqrt(3.0) * 0.5 *
                              std::numeric_limits<float>::epsilon() *
                              std::max(geom.radius, geom.length);
  const double skin_half = 0.5 * e.list_.skin() - ref_rounding;
  skin_half2 = skin_half * skin_half;
  double* const dissip = e.dissipative_.data();
  for (std::size_t q = 0; q < 6; ++q) own[6 + q] = dissip + q * n;
}

}  // namespace millscope::engine
