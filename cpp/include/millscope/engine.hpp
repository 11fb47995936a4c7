// The DEM engine: state of the charge in structure-of-arrays storage, the step loop (velocity
// Verlet), contact forces with the charge and the drum, and the drive torque
// (docs/architecture.md, The engine; docs/physics.md; paper section 3.1).
//
// One step, from t to t + dt (kick-drift-kick velocity Verlet, for translation and rotation):
//   1. v += F/m dt/2, w += T/I dt/2          (half-step velocities v(t + dt/2))
//   2. x += v dt                              (positions at t + dt); drum angle += omega dt
//   3. the neighbour list is rebuilt when a particle has moved more than skin/2 since the last
//      build
//   4. forces and torques at t + dt from the positions at t + dt and the half-step velocities
//      (the damping and the tangential history use v(t + dt/2), as LAMMPS and LIGGGHTS do)
//   5. v += F/m dt/2, w += T/I dt/2          (full-step velocities v(t + dt))
// The drive torque of step 4 is the step's torque: the sum over particle-drum contacts of
// ((x_c - axis) x F_drum_on_particle) . z, split into shell, lifters and end walls.
//
// What a scene does not use costs nothing: the contact law (friction or none, damping or none,
// clamped or not), one material or a pair table, lifters or none, end walls or periodic ends
// are template parameters of the step kernel, chosen once when the engine is made
// (src/step/run.hpp, instantiated in the generated engine_law_*.cpp).
//
// Storage order: at every neighbour-list build the particles are re-stored in cell order
// (neighbors::VerletList::spatial_order; Config::reorder), so that contacting particles sit
// close in memory. order_ maps storage slots to the caller's particle indices; everything that
// goes in or out (positions, velocities, spins, radius, mass, messages) is in the caller's
// order. Reordering changes the order of floating-point sums, so a run differs from an
// unsorted one by round-off; it stays reproducible bit for bit at a given thread count.
//
// Threads: one OpenMP team runs a whole call of advance(); pair forces go to per-thread buffers
// (half neighbour list, no atomics) that are summed in a fixed order, so a run is reproducible
// bit for bit at a given thread count. A step has two barriers (after the drift, after the
// pair pass); list builds and lifter refreshes run on one thread between them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "millscope/contact.hpp"
#include "millscope/drum.hpp"
#include "millscope/materials.hpp"
#include "millscope/neighbors.hpp"

namespace millscope::engine {

/// Everything the engine needs to know about a scene. Validated by Engine's constructor.
struct Config {
  std::vector<materials::Material> materials;
  std::vector<double> restitution;  // n x n, row-major, symmetric
  std::vector<double> friction;     // n x n, row-major, symmetric
  int drum_material = 0;            // index into materials
  drum::Geometry geometry{};
  std::vector<double> radius;       // per particle, m
  std::vector<int> material;        // per particle, index into materials
  double dt = 0.0;                  // s
  double gravity = 9.81;            // m/s^2, acting along -y
  double skin = 0.0;                // m; 0: a default of 0.1 x the smallest radius... see Engine
  bool clamp_normal = false;        // F_n = max(F_n, 0)
  bool reorder = true;              // store the particles in cell order at each list build
  bool track_energy = true;         // book the dissipated energy (Ledger); off: only drive_work
  int threads = 1;
  // The SIMD path of the vector kernels (simd_path): "" for the environment's MILLSCOPE_SIMD
  // or else the widest the CPU runs; "portable" for the portable pair search. Every path
  // gives the same results to the bit.
  std::string simd;
  // Whether the wide search asks for the state of the partners it will read a few dozen rows
  // ahead (touching_pairs.hpp, PartnerPrefetch; same results to the bit). Unset: when the
  // engine's data exceed the last-level cache (Engine::prefetch_partners).
  std::optional<bool> prefetch_partners;
  // Guards: a step that breaks one stops the run with a message (step, particle, values, hint).
  double max_speed = std::numeric_limits<double>::infinity();  // m/s, > 0; a particle faster
  double max_overlap = 0.5;  // in (0, 1]: a contact deeper than this x the smaller radius (the
                             // particle's at a wall)
};

/// Drive torque about the drum axis, N m (positive: the drive pushes the drum forward).
struct Torque {
  double total = 0.0;
  double shell = 0.0;
  double lifters = 0.0;
  double ends = 0.0;
};

/// Torque sampling under way (Engine::advance_sampled): the interval and mode, the next
/// sample's index k and how many samples are still to take, the step the last call stopped at,
/// and for interval means the sums over the steps already run in sample k's interval.
struct SamplingState {
  double sample_dt = 0.0;
  bool mean = false;
  long next = 0, left = 0, step = -1;
  Torque sum;
  long terms = 0;
};

/// Running totals of work and losses since the engine was made, J. With the kinetic, potential
/// and elastic energies they close the energy balance:
///   drive_work + spring_work = change of (kinetic + potential + elastic) + dissipated.
/// `dissipated` is what the integrator removes: per step, the work of the dissipating forces
/// (contact::ContactForce::dissipative: the normal dashpot and, booked, all of F_t) with the
/// full-step velocities v(t + dt), less the change of the tangential springs' energy at their
/// current stiffness (contact::MindlinFriction::evaluate). `spring_work` is the energy the
/// Mindlin springs gain without work: their stiffness S_t follows the overlap (6), so
/// |d_t|^2 dS_t / 2 changes their energy, and a contact that ends drops what its spring holds
/// (a damped contact leaves in tension, sliding: its spring is not empty). It is a property of
/// the law, not an error: 0.7 % of the drive work at the paper's mu = 0.15, 13 % at mu = 1
/// (tiny slice). `damping_loss` and `friction_loss` split the loss by cause but take the
/// velocities the forces were computed from, v(t + dt/2); they are first-order estimates whose
/// sum exceeds `dissipated` by O(dt / contact time) (4.3 % at dt = 0.2 Rayleigh time in the
/// soft pilot mill): the velocity Verlet's second half kick, which the dashpots themselves
/// oppose, is missing from them.
struct Ledger {
  double drive_work = 0.0;     // integral of omega x torque dt: the work the drive did
  double damping_loss = 0.0;   // integral of the dashpots' power (normal; tangential while
                               // sticking), at the half-step velocities
  double friction_loss = 0.0;  // energy lost to Coulomb sliding (see contact::TangentialResult)
  double dissipated = 0.0;     // all the energy dashpots and sliding removed, exactly
  double spring_work = 0.0;    // energy the Mindlin springs gained without work (< 0: lost)
};

/// Which specialised step kernel a scene needs (docs/architecture.md, What a scene pays for).
struct Variant {
  using Law = contact::Law;  // contact::choose_law; never frictionless_clamped (see engine.cpp)
  Law law = Law::hertz_mindlin;
  bool one_material = false;
  bool lifters = false;
  bool end_walls = true;
  bool track_energy = true;  // books the dissipated energy (only a law that dissipates)
  std::string describe() const;
};

/// The step kernels check every contact against Config::max_overlap at every step (a contact
/// too soft for its impact can pass through the limit and out again within a few steps), and
/// the state guards (Config::max_speed, a centre beyond the shell, non-finite values) at every
/// guard_interval-th step of the engine's count, at the last step of each call and before
/// every neighbour-list build or lifter refresh: those states persist (NaN stays NaN, and an
/// escaped or blown-up particle meets a wall far deeper than the overlap limit), so they are
/// reported at most guard_interval - 1 steps late and are never binned. Checking the state
/// every guard_interval-th step instead of every step keeps the guards' cost well below 1 % of
/// a step.
inline constexpr long guard_interval = 8;

/// The pair pass with the wide search (src/touching_pairs.hpp) takes blocks of rows holding at
/// most this many listed pairs (or one row that holds more): about 70 contacts in the pilot
/// mill's charges.
inline constexpr std::size_t wide_block_listed = 224;

/// A SIMD path of the engine's vector kernels (src/lane_kernels.hpp): the pair pass's search
/// for touching pairs and its contact forces, compiled for each target by Google Highway.
struct SimdPath {
  /// "avx512", "avx2", "neon", "sve", ... (the target), or "portable": the baseline build's
  /// lanes and the portable pair search, one listed pair at a time.
  std::string name;
  /// Listed pairs the pair search tests at once: the target's doubles in a vector (the wide
  /// search, src/touching_pairs.hpp), 1 for the portable search.
  std::size_t pair_lanes = 1;
};

/// The SIMD paths this build runs on this CPU, widest first; "portable" last, always there.
std::vector<std::string> simd_paths();

/// The path called `name` (one of simd_paths()), or for "" the default: the environment's
/// MILLSCOPE_SIMD where it is set and not empty, else the widest. An unknown name, or one this
/// CPU cannot run, is an std::invalid_argument naming the setting (Config::simd or
/// MILLSCOPE_SIMD), the value and the valid names.
SimdPath simd_path(const std::string& name = "");

/// Wall contact history per particle: shell, low end, high end, and two lifter slots.
inline constexpr std::size_t wall_slots = 5;

class Engine;
struct LaneKernels;  // src/lane_kernels.hpp

/// Doubles per particle in each thread's pair buffer: force and torque (6), and when the step
/// books the dissipated energy (a law that dissipates, Config::track_energy), the dissipating
/// force and its torque (6 more) for Ledger::dissipated.
constexpr std::size_t buffer_width(bool books_dissipation) {
  return books_dissipation ? 12 : 6;
}

/// Told the drive torque of every step, by one thread of the step loop while the others go on
/// with the next step: it must not look at the engine. `step` is the engine's step count
/// after the step.
class StepObserver {
 public:
  virtual ~StepObserver() = default;
  virtual void after_step(long step, const Torque& torque) = 0;
};

using StepKernel = void (*)(Engine&, long steps, StepObserver* observer);

/// The step kernels of each contact law (src/engine_law_*.cpp), for the scene's shape.
namespace kernels {
StepKernel hertz_mindlin(bool one_material, bool lifters, bool end_walls, bool track_energy);
StepKernel frictionless(bool one_material, bool lifters, bool end_walls, bool track_energy);
StepKernel elastic(bool one_material, bool lifters, bool end_walls, bool track_energy);
StepKernel clamped(bool one_material, bool lifters, bool end_walls, bool track_energy);
}  // namespace kernels

/// The engine's state and its step loop.
class Engine {
 public:
  explicit Engine(Config config);

  // ---- sizes and settings
  std::size_t size() const { return n_; }
  double dt() const { return dt_; }
  int threads() const { return threads_; }
  /// The threads that run the `threads()` shares of each step: all of them, one share each,
  /// or fewer, each running several shares in turn (on a machine where other work holds the
  /// cores). The shares, and so every result, are the same to the bit whatever this is.
  int running_threads() const { return running_threads_; }
  /// Sets running_threads(), in [1, threads()] (else std::invalid_argument).
  void set_running_threads(int n);
  const Variant& variant() const { return variant_; }
  /// Doubles of history per contact, of a pair and of a wall slot: the law's
  /// (contact::history_size; 0 without friction).
  std::size_t history_size() const { return list_.history_size(); }
  const drum::Geometry& geometry() const { return config_.geometry; }
  double skin() const { return list_.skin(); }
  double max_speed() const { return config_.max_speed; }      // guard, m/s
  double max_overlap() const { return config_.max_overlap; }  // guard, of the smaller radius
  /// The SIMD path of the vector kernels (Config::simd, chosen when the engine is made).
  const SimdPath& simd() const;
  /// Whether the pair pass finds its touching pairs with the wide search: a SIMD path that has
  /// it (not "portable") and a scene whose contacts are computed in lanes (the paper's law
  /// without the energy ledger).
  bool wide_pair_search() const;
  /// Whether the wide search prefetches the partners' state: asked for
  /// (Config::prefetch_partners) or, unset, when the engine holds more bytes than the CPU's
  /// last-level cache (then a step reads its state from memory; below, the prefetches only
  /// cost). Only the wide search prefetches.
  bool prefetch_partners() const;
  long list_builds() const { return list_.builds(); }
  std::size_t list_pairs() const { return list_.pairs(); }
  /// The threads' shares of the work: thread t takes the list rows [rows[t], rows[t+1]) in
  /// the pair pass and the particles [particles[t], particles[t+1]) in the particle pass and
  /// the kick and drift (set at each list build and at a restore, balancing their cost).
  const std::vector<std::size_t>& thread_rows() const { return row_split_; }
  const std::vector<std::size_t>& thread_particles() const { return particle_split_; }
  /// Bytes held per particle: state, wall history, neighbour list and its history, buffers.
  double bytes_per_particle() const;

  // ---- time and the drum
  long step_count() const { return step_; }
  double time() const { return static_cast<double>(step_) * dt_; }
  double drum_angle() const { return theta_; }
  double omega() const { return omega_; }
  /// Sets the drum's angular velocity about +z, rad/s, and marks the start of rotation: sample
  /// times count from here.
  void start_rotation(double omega);
  long rotation_start_step() const { return rotation_start_; }

  // ---- state in and out (n x 3, row-major)
  void set_positions(const double* xyz);
  void set_velocities(const double* v);
  void set_spins(const double* w);
  std::vector<double> positions() const;
  std::vector<double> velocities() const;
  std::vector<double> spins() const;
  std::vector<double> radius() const;  // per particle, m
  std::vector<double> mass() const;    // per particle, kg

  // ---- running
  /// Advances `steps` steps.
  void advance(long steps);
  /// Advances until `count` more torque samples were taken at interval `sample_dt` (s) from the
  /// start of rotation, or `max_steps` steps were run, whichever comes first. Sample k (k >= 1)
  /// is stamped t_k = k sample_dt and covers (t_(k-1), t_k]: "instant" takes the torque of the
  /// step nearest t_k, "mean" the mean over exactly the steps ending in that interval. A fresh
  /// call takes as its first sample the first whose interval starts now or later (a call from
  /// a sample time advances exactly count x sample_dt); with `resume` it goes on with the
  /// sampling the previous call left, the sample under way included, so that one run may be
  /// cut into calls of at most max_steps steps anywhere and give the same samples.
  /// Returns (samples taken) x 5 values: time (s since rotation start), total, shell, lifters,
  /// end walls.
  std::vector<double> advance_sampled(double sample_dt, bool mean, long count,
                                      long max_steps = std::numeric_limits<long>::max(),
                                      bool resume = false);

  // ---- observables
  Torque torque() const { return torque_; }
  const Ledger& ledger() const { return ledger_; }
  double kinetic_energy() const;    // translational + rotational, J
  double potential_energy() const;  // m g y summed, J (y = 0 on the axis)
  double elastic_energy() const;    // stored in all contacts, J
  double max_overlap_ratio() const;  // largest overlap / radius of the smaller body

  // ---- checkpoint: every array and scalar needed to continue bit for bit
  struct Snapshot {
    // Arrays in storage order; order[k] is the caller's index of the particle in slot k.
    std::vector<std::uint32_t> order;
    std::vector<double> x, v, w, f, t;  // n x 3 each
    std::vector<double> x_ref;          // n x 3, positions at the last list build
    std::vector<double> wall_history;   // n x wall_slots x history_size()
    std::vector<std::int32_t> wall_lifter;  // n x 2
    std::vector<std::uint32_t> list_start, list_partner;
    std::vector<double> list_history;
    long step = 0, rotation_start = -1, last_sample_offset = -1, list_builds = 0;
    double theta = 0.0, omega = 0.0;
    bool forces_valid = false;
    Torque torque;
    Ledger ledger;

    /// Calls f(key, field) for every field in a fixed order: the one list of the snapshot's
    /// keys (the bindings' snapshot and restore, and through them a checkpoint's members).
    template <class S, class F>
    static void for_each_field(S& s, F&& f) {
      f("order", s.order);
      f("x", s.x);
      f("v", s.v);
      f("w", s.w);
      f("f", s.f);
      f("t", s.t);
      f("x_ref", s.x_ref);
      f("wall_history", s.wall_history);
      f("wall_lifter", s.wall_lifter);
      f("list_start", s.list_start);
      f("list_partner", s.list_partner);
      f("list_history", s.list_history);
      f("step", s.step);
      f("rotation_start", s.rotation_start);
      f("last_sample_offset", s.last_sample_offset);
      f("list_builds", s.list_builds);
      f("theta", s.theta);
      f("omega", s.omega);
      f("forces_valid", s.forces_valid);
      f("torque", s.torque);
      f("ledger", s.ledger);
    }
  };
  Snapshot snapshot() const;
  void restore(const Snapshot& s);

  // ---- used by the step kernels (src/engine_access.hpp, src/step/)
  struct Access;

 private:
  friend struct Access;
  void check_state(const char* where) const;
  void set_particle_constants();  // r_, mat_, m_, inv_m_, inv_i_ from config_ in order_

  Config config_;
  std::size_t n_;
  double cache_bytes_;  // the CPU's last-level cache, bytes (prefetch_partners())
  double dt_;
  int threads_;          // the shares of the work (the results depend on it)
  int running_threads_;  // the threads that run them (the results do not)
  Variant variant_;
  StepKernel kernel_;
  const LaneKernels* lanes_;  // the SIMD path's kernels (Config::simd)
  materials::PairTable pairs_;
  neighbors::VerletList list_;

  // structure of arrays
  std::vector<double> x_, y_, z_, vx_, vy_, vz_, wx_, wy_, wz_;
  std::vector<double> fx_, fy_, fz_, tx_, ty_, tz_;
  std::vector<double> r_, m_, inv_m_, inv_i_;
  std::vector<std::uint8_t> mat_;             // material index (at most 256 materials)
  // Positions at the last list build, in single precision: they only tell how far a particle
  // has moved, and the step kernel allows for their rounding (ref_rounding()).
  std::vector<float> x_ref_, y_ref_, z_ref_;
  // Wall contact history, kept only for the particles near the drum (friction only): particle
  // i owns block wall_block_[i] (-1: none) of wall_slots x history_size() doubles in
  // wall_history_ and of 2 lifter indices (-1: free) in wall_lifter_. Re-packed by
  // Access::refresh_walls.
  std::vector<std::int32_t> wall_block_;      // n
  std::vector<double> wall_history_;          // blocks x wall_slots x history_size()
  std::vector<std::int32_t> wall_lifter_;     // blocks x 2: lifter index of each lifter slot
  std::vector<std::uint32_t> order_;          // n: the caller's index of the particle in slot k
  std::vector<std::uint8_t> wall_held_;       // n: bit s set while wall slot s holds a contact
  drum::LifterAngles lifter_angles_;          // the lifters at theta_ (kept in step by the kernel)
  std::vector<drum::LifterReach> lifter_reach_;  // n: the lifters each particle may touch
  double reach_theta_ = 0.0;                  // drum angle at the last Access::refresh_walls
  std::size_t buffer_width_ = 6;               // sums per particle, see buffer_width()
  std::vector<double> dissipative_;           // 6 x n: pair sums of the dissipating forces and
                                              // torques (only when the law dissipates)
  std::vector<std::vector<double>> buffers_;  // per thread t: buffer_width x
                                              // (buffer_end[t] - row_split[t+1]) sums for the
                                              // particles after its rows that they touch
  std::vector<std::size_t> buffer_end_;       // per thread: 1 + the last partner of its rows
  std::vector<std::size_t> row_split_;        // threads + 1 row boundaries balancing the pair
                                              // pass's cost (Access::split_rows)
  std::vector<std::size_t> particle_split_;   // threads + 1 particle boundaries balancing the
                                              // particle pass's and the kick's cost
                                              // (Access::split_particles)
  std::vector<std::uint32_t> list_moved_;     // the reorder of the list build under way
  // (r_i + r_j)^2 of each listed pair, m^2, in list order (Access::list_touch_distances): the
  // pair touches while |x_i - x_j|^2 is below it. Radii do not change between builds, so the
  // pair search reads it instead of summing and squaring the radii at every step.
  std::vector<double> touch_dist2_;
  // The gap, m, within which the wide search last took listed pairs as near, those it tests
  // at every step (src/step/near_pairs.hpp): where the next call starts. It changes no result.
  double near_gap_ = 0.0;

  long step_ = 0;
  long rotation_start_ = -1;
  long last_sample_offset_ = -1;
  SamplingState sampling_;  // what the last advance_sampled call left, for one that resumes
  double theta_ = 0.0;
  double omega_ = 0.0;
  bool forces_valid_ = false;
  Torque torque_;
  Ledger ledger_;
};

}  // namespace millscope::engine
