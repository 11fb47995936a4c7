// The step kernel of the engine, specialised per scene (engine.hpp explains the step).
// Included only by the src/engine_law_*.cpp files that instantiate it; never by bindings.
#pragma once

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "millscope/contact.hpp"
#include "millscope/drum.hpp"
#include "millscope/engine.hpp"
#include "millscope/lanes.hpp"
#include "millscope/touching_pairs.hpp"

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
  std::size_t bad = std::numeric_limits<std::size_t>::max();  // first particle in a bad state
  std::size_t deepest = std::numeric_limits<std::size_t>::max();   // a contact beyond max_overlap
  double deepest_ratio = 0.0;                                       // its overlap / radius
  bool deepest_at_wall = false;
};

/// One thread's touching pairs of a block of list rows, in list order, as arrays: the pair
/// pass finds them, computes their forces in SIMD lanes (contact_forces_in_lanes), then sums
/// them into the particles in list order.
struct ContactBatch {
  static constexpr std::size_t max_contacts = 64;  // a block closes once it holds this many
  static constexpr std::size_t max_rows = 128;     // ... or this many rows
  std::size_t size = 0;
  std::vector<std::uint32_t> i, j, slot, pair;  // rows, partners, list slots, pair constants
  std::vector<double> dx, dy, dz;               // x_i - x_j, m
  std::vector<double> sx, sy, sz;               // tangential spring d_t, m: in, then out
  std::vector<double> overlap;                  // d_n = r_i + r_j - |x_i - x_j|, m
  std::vector<double> fx, fy, fz;               // force on i, N
  std::vector<double> tix, tiy, tiz, tjx, tjy, tjz;  // torques on i and on j, N m
  std::vector<double> row_sum;  // force, N, and torque, N m, on each row's particle: 6 a row

  // The wide search's scratch (touching_pairs_wide): each listed pair's row.
  std::vector<std::uint32_t> slot_row;

  ContactBatch() : row_sum(6 * max_rows) {
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
  /// registers of 8 past its last entry.
  void reserve_listed(std::size_t listed) {
    const std::size_t need = listed + 8;
    if (need > slot_row.size()) slot_row.resize(need);
    if (need > overlap.size()) reserve(need - size);
  }
};

/// The paper's law (contact::HertzMindlin: Hertz (1), viscous damping (2), Mindlin no-slip
/// spring (5)-(7) with the Coulomb limit (8), unclamped) for every contact of a block, written
/// branch-free so that the compiler computes several contacts in the lanes of one instruction
/// (`omp simd`; the sliding select needs -fno-trapping-math). Every operation is the one
/// contact::pair_force does, in the same order, so the forces are the same to the bit
/// (tests: a run with the energy ledger, which takes contact::pair_force, moves the same).
/// Particles are read through the pairs' indices (radius r, m; inverse mass, 1/kg; velocity,
/// m/s; spin, rad/s); `pairs` holds the pair constants; dt, s, advances the springs.
MILLSCOPE_LANE_TARGETS inline void contact_forces_in_lanes(
    ContactBatch& b, const materials::PairConstants* pairs, const double* r, const double* inv_m,
    const double* vx, const double* vy, const double* vz, const double* wx, const double* wy,
    const double* wz, double dt) {
  using Normal = contact::HertzMindlin::normal_part;
  using Damping = contact::HertzMindlin::damping_part;
  using Tangential = contact::HertzMindlin::tangential_part;
  const std::size_t n = b.size;
  const std::uint32_t* __restrict bi = b.i.data();
  const std::uint32_t* __restrict bj = b.j.data();
  const std::uint32_t* __restrict bp = b.pair.data();
  const double* __restrict dxs = b.dx.data();
  const double* __restrict dys = b.dy.data();
  const double* __restrict dzs = b.dz.data();
  double* __restrict sxs = b.sx.data();
  double* __restrict sys = b.sy.data();
  double* __restrict szs = b.sz.data();
  double* __restrict overlaps = b.overlap.data();
  double* __restrict fxs = b.fx.data();
  double* __restrict fys = b.fy.data();
  double* __restrict fzs = b.fz.data();
  double* __restrict tixs = b.tix.data();
  double* __restrict tiys = b.tiy.data();
  double* __restrict tizs = b.tiz.data();
  double* __restrict tjxs = b.tjx.data();
  double* __restrict tjys = b.tjy.data();
  double* __restrict tjzs = b.tjz.data();
#pragma omp simd
  for (std::size_t c = 0; c < n; ++c) {
    const std::uint32_t i = bi[c], j = bj[c];
    const materials::PairConstants& p = pairs[bp[c]];
    const double dx = dxs[c], dy = dys[c], dz = dzs[c];
    const double ri = r[i], rj = r[j], r_sum = ri + rj;
    const double dist = std::sqrt(dx * dx + dy * dy + dz * dz);
    const double inv_dist = 1.0 / dist;
    const double nx = dx * inv_dist, ny = dy * inv_dist, nz = dz * inv_dist;  // j to i
    // contact-point velocity of i relative to j: (v_i - v_j) + (w_i x (-r_i n) - w_j x (r_j n))
    const double ax = -ri * nx, ay = -ri * ny, az = -ri * nz;
    const double bx = rj * nx, by = rj * ny, bz = rj * nz;
    const double vrx = (vx[i] - vx[j]) + ((wy[i] * az - wz[i] * ay) - (wy[j] * bz - wz[j] * by));
    const double vry = (vy[i] - vy[j]) + ((wz[i] * ax - wx[i] * az) - (wz[j] * bx - wx[j] * bz));
    const double vrz = (vz[i] - vz[j]) + ((wx[i] * ay - wy[i] * ax) - (wx[j] * by - wy[j] * bx));
    const double r_star = ri * rj / r_sum;
    const double m_star = 1.0 / (inv_m[i] + inv_m[j]);
    const double d_n = r_sum - dist;
    const double v_n = vrx * nx + vry * ny + vrz * nz;
    const double vtx = vrx - v_n * nx, vty = vry - v_n * ny, vtz = vrz - v_n * nz;
    const double sqrt_rd = std::sqrt(r_star * d_n);
    const double s_n = Normal::stiffness(p, sqrt_rd);            // (4)
    const double gamma_n = Damping::gamma(p, s_n, m_star);       // (2)
    const double f_n = Normal::force(s_n, d_n) - gamma_n * v_n;  // (1), (2)
    const double s_t = Tangential::stiffness(p, sqrt_rd);        // (6)
    double sx = sxs[c], sy = sys[c], sz = szs[c];
    Tangential::turn(sx, sy, sz, nx, ny, nz);
    Tangential::advance(sx, sy, sz, vtx, vty, vtz, dt);
    const double gamma_t = gamma_n * p.tangential_damping_ratio;  // (7)
    double ftx, fty, ftz;
    Tangential::trial(s_t, gamma_t, sx, sy, sz, vtx, vty, vtz, ftx, fty, ftz);  // (5), (7)
    const bool sliding = Tangential::limit(p, f_n, ftx, fty, ftz);              // (8)
    sxs[c] = sliding ? -ftx / s_t : sx;
    sys[c] = sliding ? -fty / s_t : sy;
    szs[c] = sliding ? -ftz / s_t : sz;
    overlaps[c] = d_n;
    fxs[c] = f_n * nx + ftx, fys[c] = f_n * ny + fty, fzs[c] = f_n * nz + ftz;
    const double cx = ny * ftz - nz * fty, cy = nz * ftx - nx * ftz, cz = nx * fty - ny * ftx;
    tixs[c] = -ri * cx, tiys[c] = -ri * cy, tizs[c] = -ri * cz;  // (-r_i n) x F_t
    tjxs[c] = -rj * cx, tjys[c] = -rj * cy, tjzs[c] = -rj * cz;  // (r_j n) x (-F_t)
  }
}

struct Engine::Access {
  template <class Law, bool OneMaterial, bool Lifters, bool EndWalls, bool Tally>
  static void run(Engine& e, long steps, StepObserver* observer);

  static void rebuild(Engine& e);  // by one thread
  // ... in parallel: rebuild_begin by one thread, the list's find_rows, size_rows and
  // place_rows phases, then rebuild_end by one thread (see the step loop)
  static void rebuild_begin(Engine& e, int team);
  static void rebuild_end(Engine& e);
  static void refresh_walls(Engine& e);
  static void split_rows(Engine& e);
  static void split_particles(Engine& e);
  static std::string describe_bad(const Engine& e, std::size_t i);
  static std::string describe_overlap(const Engine& e, std::size_t i, double ratio, bool wall);
};

template <class Law, bool OneMaterial, bool Lifters, bool EndWalls, bool Tally>
void Engine::Access::run(Engine& e, long steps, StepObserver* observer) {
  using contact::Vec3;
  constexpr std::size_t hs = Law::history_size;  // per pair-contact history, doubles
  constexpr bool friction = Law::has_friction;
  // Whether the step books the dissipated energy (Ledger): the dissipating forces summed per
  // particle, the dashpots' power and the sliding losses. Without it (Config::track_energy)
  // the forces are the same to the bit and only the drive work is booked.
  constexpr bool dissipates = Law::dissipates && Tally;
  constexpr std::size_t width = buffer_width(dissipates);  // per-thread buffer, x n doubles
  static_assert(hs == Law::tangential_part::history_size,
                "the pair history is the tangential spring alone, odd under swapping the pair "
                "(neighbors::VerletList negates it when a reorder swaps the pair's ranks)");

  const std::size_t n = e.n_;
  const int team = e.threads_;
  const double dt = e.dt_;
  const double half_dt = 0.5 * dt;
  const double gravity = e.config_.gravity;
  const drum::Geometry& geom = e.config_.geometry;
  const double period = geom.length;  // periodic ends: the drum length is the period
  const std::size_t drum_mat = static_cast<std::size_t>(e.config_.drum_material);
  // One material in use: the drum's (used_materials counts the drum), whatever its index in
  // the table; the table may list materials the scene does not use.
  const materials::PairConstants pc_one = e.pairs_(drum_mat, drum_mat);
  const materials::PairTable& table = e.pairs_;
  // A rebuild is due once a particle may have moved skin/2 since the last build. The reference
  // positions are floats: each coordinate is off by at most half an ulp of the drum's largest
  // extent, so the test moves the threshold in by that much (x sqrt(3), and twice over).
  const double ref_rounding = 2.0 * std::sqrt(3.0) * 0.5 * std::numeric_limits<float>::epsilon() *
                              std::max(geom.radius, geom.length);
  const double skin_half = 0.5 * e.list_.skin() - ref_rounding;
  const double skin_half2 = skin_half * skin_half;
  const double lifter_drift = 0.5 * e.list_.skin();  // see refresh_walls
  const double max_speed2 =  // finite, so that an infinite speed fails the guard
      std::min(e.config_.max_speed * e.config_.max_speed, std::numeric_limits<double>::max());
  const double max_overlap = e.config_.max_overlap;
  // Guard: a contact deeper than max_overlap x the smaller radius (rare: a predictable branch).
  auto note_overlap = [](StepPartial& part, std::size_t i, double ratio, bool wall) {
    if (ratio > part.deepest_ratio) {
      part.deepest = i;
      part.deepest_ratio = ratio;
      part.deepest_at_wall = wall;
    }
  };

  double* const x = e.x_.data();
  double* const y = e.y_.data();
  double* const z = e.z_.data();
  double* const vx = e.vx_.data();
  double* const vy = e.vy_.data();
  double* const vz = e.vz_.data();
  double* const wx = e.wx_.data();
  double* const wy = e.wy_.data();
  double* const wz = e.wz_.data();
  double* const fx = e.fx_.data();
  double* const fy = e.fy_.data();
  double* const fz = e.fz_.data();
  double* const tx = e.tx_.data();
  double* const ty = e.ty_.data();
  double* const tz = e.tz_.data();
  const double* const r = e.r_.data();
  const double* const m = e.m_.data();
  const double* const inv_m = e.inv_m_.data();
  const double* const inv_i = e.inv_i_.data();
  const std::uint8_t* const mat = e.mat_.data();

  // Two sets of per-thread partials, by step parity: step s writes set s % 2 while the threads
  // still read set (s - 1) % 2 to close the step before (see the step loop below).
  std::vector<StepPartial> partial(2 * static_cast<std::size_t>(team));
  // The paper's law without the ledger computes its pair contacts in SIMD lanes
  // (contact_forces_in_lanes); the ledger's kernels and the other laws take pair_force.
  constexpr bool in_lanes = std::is_same_v<Law, contact::HertzMindlin> && !Tally;
  static_assert(!in_lanes || hs == 3, "the lanes carry the spring d_t, 3 doubles");
  // ... and finds them with the wide search where the CPU can (Engine::wide_pair_search).
  [[maybe_unused]] const bool wide = in_lanes && e.wide_pair_search();
  // ... asking ahead for the state of the partners where the data exceed the caches: their
  // positions and radii (the search), velocities, spins and inverse masses (the law in lanes).
  [[maybe_unused]] const bool prefetch = wide && e.prefetch_partners();
  [[maybe_unused]] const PartnerPrefetch ahead{{x, y, z, r, vx, vy, vz, wx, wy, wz, inv_m}};
  // Each thread makes its own (see the parallel region), so that its arrays come from that
  // thread's allocator arena and share no cache line with another thread's.
  std::vector<std::unique_ptr<ContactBatch>> batches(static_cast<std::size_t>(team));
  auto partials_of = [&](long s) { return partial.data() + static_cast<std::size_t>(s & 1) * team; };
  std::string error;

  if (e.buffer_width_ != width || (dissipates && e.dissipative_.size() != 6 * n))
    throw std::logic_error("the engine's pair buffers do not fit its step kernel");
  if (e.list_.builds() == 0) rebuild(e);
  if constexpr (Lifters) e.lifter_angles_.update(geom, e.theta_);

  // Pair forces of the rows [row_split[t], row_split[t+1]) ("own" particles of thread t). The
  // list is a half list (j > i), so every write of thread t goes to a particle at or after its
  // first row: own particles are summed straight into the shared arrays (forces into fx.., the
  // dissipating parts into e.dissipative_), later ones into thread t's buffer, which holds only
  // the particles after its rows up to its last partner (buffer_end). No two threads write the
  // same place.
  double* const dissip = e.dissipative_.data();

  // Ledger: a contact that ends drops what its spring held after the step before,
  // S_t |d_t|^2 / 2 with S_t (6) at the overlap of then (Ledger::spring_work). The damped
  // contact leaves in tension and slides out, so that energy does not vanish with the overlap:
  // it scales as mu^2 (F_n, S_t and the dashpot all go as d_n^(1/4) to d_n^(1/2)).
  auto spring_energy_at = [](const materials::PairConstants& pc, double r_star, double d_prev,
                             const double* hist) {
    if constexpr (friction) {
      if (!(d_prev > 0.0)) return 0.0;
      return Law::tangential_part::energy(pc, std::sqrt(r_star * d_prev),
                                          hist + Law::tangential_offset);
    } else {
      (void)pc, (void)r_star, (void)d_prev, (void)hist;
      return 0.0;
    }
  };
  // ... for a pair that has separated: its previous separation is d - (v_i - v_j) dt exactly.
  auto ended_pair_energy = [&](std::size_t i, std::size_t j, double dx, double dy, double dz,
                               double history_dt, const double* hist) {
    const double px = dx - (vx[i] - vx[j]) * history_dt, py = dy - (vy[i] - vy[j]) * history_dt,
                 pz = dz - (vz[i] - vz[j]) * history_dt;
    const materials::PairConstants& pc =
        OneMaterial ? pc_one
                    : table(static_cast<std::size_t>(mat[i]), static_cast<std::size_t>(mat[j]));
    const double r_sum = r[i] + r[j];
    return spring_energy_at(pc, r[i] * r[j] / r_sum, r_sum - std::sqrt(px * px + py * py + pz * pz),
                            hist);
  };
  // ... for a wall slot: the previous position x - v dt, turned by omega dt into the drum's
  // frame of now (the lifters have turned since; the shell and the end walls look the same).
  auto ended_wall_energy = [&](std::size_t i, std::size_t slot, int lifter, double history_dt,
                               const double* hist) {
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
    const materials::PairConstants& pc =
        OneMaterial ? pc_one : table(static_cast<std::size_t>(mat[i]), drum_mat);
    return spring_energy_at(pc, r[i], d_prev, hist);
  };

  // The sums of each particle, in the layout of a thread's pair buffer: force, N; torque, N m;
  // with the ledger, the dissipating force and its torque.
  double* const own[12] = {fx,         fy,         fz,         tx,
                           ty,         tz,         dissip,     dissip + n,
                           dissip + 2 * n, dissip + 3 * n, dissip + 4 * n, dissip + 5 * n};
  // Sums q, q + 1, q + 2 of particle i (a vector: q = 0 force, 3 torque, 6 and 9 with the
  // ledger), read and written.
  auto sums_of = [&](std::size_t q, std::size_t i) {
    return Vec3(own[q][i], own[q + 1][i], own[q + 2][i]);
  };
  auto put_sums = [&](std::size_t q, std::size_t i, const Vec3& v) {
    own[q][i] = v.x(), own[q + 1][i] = v.y(), own[q + 2][i] = v.z();
  };
  auto pair_pass = [&](int t, double history_dt, StepPartial& part) {
    const std::size_t row_begin = e.row_split_[static_cast<std::size_t>(t)];
    const std::size_t own_end = e.row_split_[static_cast<std::size_t>(t) + 1];
    const std::size_t later = e.buffer_end_[static_cast<std::size_t>(t)] - own_end;  // buffered
    double* const buf = e.buffers_[static_cast<std::size_t>(t)].data();
    std::fill(buf, buf + width * later, 0.0);
    // quantity c of particle k: own[c][k] for k < own_end, buffered[c][k - own_end] after
    double* buffered[12];
    for (std::size_t c = 0; c < 12; ++c) buffered[c] = c < width ? buf + c * later : nullptr;
    for (std::size_t c = 0; c < width; ++c) std::fill(own[c] + row_begin, own[c] + own_end, 0.0);

    const std::uint32_t* const start = e.list_.start().data();
    const std::uint32_t* const partner = e.list_.partner().data();
    double* const history = e.list_.history().data();
    if constexpr (in_lanes) {
      // Each block of rows in three phases: 1. its touching pairs, 2. their forces in lanes,
      // 3. (sum_block) the springs back, and the sums: those on j straight into j, those on i
      // into the block's row sums, added to i last. As in the loop below, to the bit: i
      // receives from the rows before it (j > i in a half list), then its own row's sum.
      auto sum_block = [&](ContactBatch& b, std::size_t block, std::size_t block_end) {
        double* const row_sum = b.row_sum.data();  // 6 per row of the block
        std::fill(row_sum, row_sum + 6 * (block_end - block), 0.0);
        for (std::size_t c = 0; c < b.size; ++c) {
          const std::size_t i = b.i[c], j = b.j[c];
          double* const hist = history + static_cast<std::size_t>(b.slot[c]) * hs;
          hist[0] = b.sx[c], hist[1] = b.sy[c], hist[2] = b.sz[c];
          const double r_min = std::min(r[i], r[j]), overlap = b.overlap[c];
          if (overlap > max_overlap * r_min) note_overlap(part, i, overlap / r_min, false);
          const double on_i[6] = {b.fx[c], b.fy[c], b.fz[c], b.tix[c], b.tiy[c], b.tiz[c]};
          const double on_j[6] = {-b.fx[c], -b.fy[c], -b.fz[c], b.tjx[c], b.tjy[c], b.tjz[c]};
          double* const sum_i = row_sum + 6 * (i - block);
          const bool j_own = j < own_end;
          const std::size_t k = j_own ? j : j - own_end;
          double* const* const dst = j_own ? own : buffered;
          for (std::size_t q = 0; q < 6; ++q) {
            sum_i[q] += on_i[q];
            dst[q][k] += on_j[q];
          }
        }
        for (std::size_t i = block; i < block_end; ++i)
          for (std::size_t q = 0; q < 6; ++q) own[q][i] += row_sum[6 * (i - block) + q];
      };
      ContactBatch& b = *batches[static_cast<std::size_t>(t)];
#if MILLSCOPE_WIDE_PAIRS
      if (wide) {
        for (std::size_t block = row_begin; block < own_end;) {
          // 1. The touching pairs of the rows [block, block_end), which hold at most
          // wide_block_listed listed pairs (or one row that holds more).
          const std::size_t row_limit = std::min(own_end, block + ContactBatch::max_rows);
          std::size_t block_end = block + 1;
          while (block_end < row_limit &&
                 start[block_end + 1] - start[block] <= wide_block_listed)
            ++block_end;
          const std::uint32_t s0 = start[block], s1 = start[block_end];
          b.size = 0;  // reserve_listed counts its room from size
          b.reserve_listed(s1 - s0);
          const TouchingPairs out{b.i.data(),  b.j.data(),  b.slot.data(),
                                  b.dx.data(), b.dy.data(), b.dz.data()};
          auto search = [&](auto with_prefetch) {
            return touching_pairs_wide<!EndWalls, decltype(with_prefetch)::value>(
                block, block_end, start, partner, x, y, z, r, n, period, b.slot_row.data(), out,
                ahead);
          };
          b.size = prefetch ? search(std::true_type{}) : search(std::false_type{});
          for (std::size_t c = 0; c < b.size; ++c) {
            const double* const hist = history + static_cast<std::size_t>(b.slot[c]) * hs;
            b.sx[c] = hist[0], b.sy[c] = hist[1], b.sz[c] = hist[2];
            b.pair[c] = OneMaterial ? 0u
                                    : static_cast<std::uint32_t>(table.index(mat[b.i[c]],
                                                                             mat[b.j[c]]));
          }
          // A listed pair that does not touch has its history cleared; those that touch get
          // theirs back in phase 3.
          std::fill(history + static_cast<std::size_t>(s0) * hs,
                    history + static_cast<std::size_t>(s1) * hs, 0.0);
          // 2. Their forces, several at a time.
          contact_forces_in_lanes(b, OneMaterial ? &pc_one : &table(0, 0), r, inv_m, vx, vy, vz,
                                  wx, wy, wz, history_dt);
          sum_block(b, block, block_end);
          block = block_end;
        }
        return;
      }
#endif
      for (std::size_t block = row_begin; block < own_end;) {
        // 1. The touching pairs of the rows [block, block_end); a listed pair that does not
        // touch has its history cleared.
        b.size = 0;
        std::size_t block_end = block;
        while (block_end < own_end && b.size < ContactBatch::max_contacts &&
               block_end - block < ContactBatch::max_rows) {
          const std::size_t i = block_end;
          const double xi = x[i], yi = y[i], zi = z[i], ri = r[i];
          b.reserve(start[i + 1] - start[i]);
          for (std::uint32_t s = start[i]; s < start[i + 1]; ++s) {
            const std::size_t j = partner[s];
            double* const hist = history + static_cast<std::size_t>(s) * hs;
            const double dx = xi - x[j], dy = yi - y[j];
            double dz = zi - z[j];
            if constexpr (!EndWalls) dz -= period * std::nearbyint(dz / period);
            const double r_sum = ri + r[j];
            if (!(dx * dx + dy * dy + dz * dz < r_sum * r_sum)) {
              Law::clear(hist);
              continue;
            }
            const std::size_t c = b.size++;
            b.i[c] = static_cast<std::uint32_t>(i);
            b.j[c] = static_cast<std::uint32_t>(j);
            b.slot[c] = s;
            b.pair[c] = static_cast<std::uint32_t>(OneMaterial ? 0 : table.index(mat[i], mat[j]));
            b.dx[c] = dx, b.dy[c] = dy, b.dz[c] = dz;
            b.sx[c] = hist[0], b.sy[c] = hist[1], b.sz[c] = hist[2];
          }
          ++block_end;
        }
        // 2. Their forces, several at a time.
        contact_forces_in_lanes(b, OneMaterial ? &pc_one : &table(0, 0), r, inv_m, vx, vy, vz,
                                wx, wy, wz, history_dt);
        sum_block(b, block, block_end);
        block = block_end;
      }
      return;
    }
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
        if (r_sum - dist > max_overlap * r_min) note_overlap(part, i, (r_sum - dist) / r_min, false);
        const double inv_dist = 1.0 / dist;
        const Vec3 nrm(dx * inv_dist, dy * inv_dist, dz * inv_dist);  // from j to i
        const Vec3 vi(vx[i], vy[i], vz[i]), vj(vx[j], vy[j], vz[j]);
        Vec3 v_rel = vi - vj;
        if constexpr (friction) {
          const Vec3 wi(wx[i], wy[i], wz[i]), wj(wx[j], wy[j], wz[j]);
          v_rel += wi.cross(-r[i] * nrm) - wj.cross(r[j] * nrm);
        }
        const materials::PairConstants& pc =
            OneMaterial ? pc_one
                        : table(static_cast<std::size_t>(mat[i]), static_cast<std::size_t>(mat[j]));
        const double r_star = r[i] * r[j] / r_sum;
        const double m_star = 1.0 / (inv_m[i] + inv_m[j]);
        const contact::PairForce pf = contact::pair_force<Law, dissipates>(
            pc, nrm, r_sum - dist, r_star, m_star, v_rel, r[i], r[j], history_dt, hist);

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
  };

  // Guard: no speed above the bound, no centre beyond the shell. Called after a kick and a
  // drift: a non-finite force makes the velocity non-finite (NaN fails every comparison, and
  // an infinite speed exceeds max_speed2, which is finite), a non-finite torque the spin and
  // through it the next step's forces.
  const double radius2 = geom.radius * geom.radius;
  auto sound = [&](std::size_t i) {
    const double speed2 = vx[i] * vx[i] + vy[i] * vy[i] + vz[i] * vz[i];
    return speed2 <= max_speed2 && x[i] * x[i] + y[i] * y[i] <= radius2;
  };

  // The particles near the drum (those that may touch it before the next refresh_walls): the
  // drum's contacts, added to the sums of particle i (force, N; torque, N m; with the ledger,
  // the dissipating force and its torque).
  auto drum_contacts = [&](std::size_t i, double history_dt, StepPartial& part) {
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
              part.spring_work -= ended_wall_energy(i, slot, lifter_of_slot[slot - 3],
                                                    history_dt, wall_hist + slot * hs);
            lifter_of_slot[slot - 3] = wc.index;
            Law::reset(wall_hist + slot * hs);
          }
        } else {
          slot = static_cast<std::size_t>(wc.part);  // shell 0, end_low 1, end_high 2
        }
        used |= 1u << slot;
        hist = wall_hist + slot * hs;
      }
      if (wc.overlap > max_overlap * r[i]) note_overlap(part, i, wc.overlap / r[i], true);
      const Vec3 v_wall = drum::surface_velocity(omega, wc.point);
      Vec3 v_rel = vi - v_wall;
      if constexpr (friction) v_rel += wi.cross(-r[i] * wc.normal);
      const materials::PairConstants& pc =
          OneMaterial ? pc_one : table(static_cast<std::size_t>(mat[i]), drum_mat);
      const contact::PairForce pf = contact::pair_force<Law, dissipates>(
          pc, wc.normal, wc.overlap, r[i], m[i], v_rel, r[i], 0.0, history_dt, hist);
      f += pf.force_i;
      // Drive torque: ((x_c - axis) x F_drum_on_particle) . z (docs/architecture.md, Torque).
      const double arm_torque =
          wc.point.x() * pf.force_i.y() - wc.point.y() * pf.force_i.x();
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
  };

  // Per particle, in chunks that stay in the first-level cache, three loops: the pair sums
  // completed (gravity, then what the threads whose rows come before the particle buffered for
  // it, in thread order), the drum's contacts of the particles near the drum, then (kick) the
  // second half kick. Each sum takes its terms in the order a loop per particle would, so the
  // forces are the same to the bit; the bulk pays nothing for the drum. Particles [lo, hi) of
  // particle_split_ belong to thread t, here and in the kick and drift that follows with no
  // barrier between.
  auto particle_pass = [&](int t, double history_dt, bool kick, StepPartial& part) {
    const std::size_t lo = e.particle_split_[static_cast<std::size_t>(t)];
    const std::size_t hi = e.particle_split_[static_cast<std::size_t>(t) + 1];
    constexpr std::size_t chunk = 128;  // particles: 1 KiB of each of the ~20 arrays read
    for (std::size_t c0 = lo; c0 < hi; c0 += chunk) {
      const std::size_t c1 = std::min(c0 + chunk, hi);
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
      // blocks, and every particle looks (find_contacts_of gives up early in the bulk).
      for (std::size_t i = c0; i < c1; ++i)
        if (!friction || e.wall_block_[i] >= 0) drum_contacts(i, history_dt, part);
      if (!kick) {  // a step's kick_drift checks it otherwise
        for (std::size_t i = c0; i < c1; ++i)
          if (!sound(i)) part.bad = std::min(part.bad, i);
        continue;
      }
      for (std::size_t i = c0; i < c1; ++i) {
        const double kv = inv_m[i] * half_dt;
        const double dvx = fx[i] * kv, dvy = fy[i] * kv, dvz = fz[i] * kv;
        vx[i] += dvx;
        vy[i] += dvy;
        vz[i] += dvz;
        [[maybe_unused]] double dwx = 0.0, dwy = 0.0, dwz = 0.0;
        if constexpr (friction) {
          const double kw = inv_i[i] * half_dt;
          dwx = tx[i] * kw, dwy = ty[i] * kw, dwz = tz[i] * kw;
          wx[i] += dwx;
          wy[i] += dwy;
          wz[i] += dwz;
        }
        // The dissipating forces worked against the half-step velocities above; what the
        // integrator removes is their work with the full-step ones (Ledger::dissipated).
        if constexpr (dissipates) {
          const Vec3 diss = sums_of(6, i);
          const Vec3 diss_tq = friction ? sums_of(9, i) : Vec3(0.0, 0.0, 0.0);
          part.dissipation_shift -=
              (diss.dot(Vec3(dvx, dvy, dvz)) + diss_tq.dot(Vec3(dwx, dwy, dwz))) * dt;
        }
      }
    }
  };

  // First half kick and drift for particles [lo, hi); tracks the largest move since the build
  // and, with `guard` (std::true_type), guards the new state.
  auto kick_drift = [&](int t, StepPartial& part, auto guard) {
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
      if constexpr (decltype(guard)::value)
        all_sound &= (vxi * vxi + vyi * vyi + vzi * vzi <= max_speed2) &
                     (xi * xi + yi * yi <= radius2);
    }
    part.displacement2 = move2;
    if (decltype(guard)::value && !all_sound) {  // rare: find the first particle that failed
      for (std::size_t i = lo; i < hi && part.bad == std::numeric_limits<std::size_t>::max(); ++i)
        if (!sound(i)) part.bad = i;
    }
  };

  // Closes a step from its partials, summed in thread order (reproducible): every thread
  // calls it and reaches the same verdict (true: stop); the master thread alone books the
  // torque and the ledger, tells the observer and writes the error.
  auto close_step = [&](const StepPartial* parts, double ledger_dt, bool master, long step) {
    Torque tq;
    double damping = 0.0, friction_loss = 0.0, shift = 0.0, loss = 0.0, spring_work = 0.0;
    std::size_t bad = std::numeric_limits<std::size_t>::max();
    const StepPartial* deepest = nullptr;  // the deepest contact beyond max_overlap
    for (int b = 0; b < team; ++b) {
      const StepPartial& p = parts[b];
      if (p.deepest_ratio > (deepest ? deepest->deepest_ratio : 0.0)) deepest = &p;
      tq.shell += p.shell;
      tq.lifters += p.lifters;
      tq.ends += p.ends;
      damping += p.damping_power;
      friction_loss += p.friction_loss;
      shift += p.dissipation_shift;
      spring_work += p.spring_work;
      loss += p.loss;
      bad = std::min(bad, p.bad);
    }
    tq.total = tq.shell + tq.lifters + tq.ends;
    if (master) {
      e.torque_ = tq;
      e.ledger_.drive_work += e.omega_ * tq.total * ledger_dt;
      e.ledger_.damping_loss += damping * ledger_dt;
      if (ledger_dt > 0.0 && Law::dissipates && !Tally) {
        // not booked: unknown from here on
        e.ledger_.damping_loss = e.ledger_.friction_loss = e.ledger_.dissipated =
            e.ledger_.spring_work = std::numeric_limits<double>::quiet_NaN();
      } else if (ledger_dt > 0.0) {
        e.ledger_.friction_loss += friction_loss;
        e.ledger_.dissipated += loss + shift;
        e.ledger_.spring_work += spring_work;
      }
      if (observer != nullptr && ledger_dt > 0.0) observer->after_step(step, tq);
    }
    if (bad != std::numeric_limits<std::size_t>::max()) {
      if (master) error = describe_bad(e, bad);
      return true;
    }
    if (deepest != nullptr) {
      if (master)
        error = describe_overlap(e, deepest->deepest, deepest->deepest_ratio,
                                 deepest->deepest_at_wall);
      return true;
    }
    return false;
  };

  const long first_step = e.step_;  // the step count when this call began
  // Two barriers per step. A step's particle pass and the next step's kick and drift touch only
  // the thread's own particles, so they need none between them; the step is closed (torque,
  // ledger, observer, guards) after the next step's first barrier, from its set of partials.
#pragma omp parallel num_threads(team)
  {
    const int t = omp_get_thread_num();
    const bool master = t == 0;
    if constexpr (in_lanes) batches[static_cast<std::size_t>(t)] = std::make_unique<ContactBatch>();
    bool failed = false;  // the same in every thread
    if (!e.forces_valid_) {
      // The forces of the initial state; the tangential history does not advance.
      StepPartial* const parts = partials_of(-1);
      parts[t] = StepPartial{};
      pair_pass(t, 0.0, parts[t]);
#pragma omp barrier
      particle_pass(t, 0.0, false, parts[t]);
#pragma omp barrier
      failed = close_step(parts, 0.0, master, first_step);
      if (master && !failed) e.forces_valid_ = true;
#pragma omp barrier
    }
    // Every thread follows the drum angle and the angle of the last lifter refresh itself, so
    // that the decisions below need no shared write.
    double theta = e.theta_, reach_theta = e.reach_theta_;
    for (long s = 0; !failed; ++s) {
      StepPartial* const parts = partials_of(s);
      // The state guards look at every guard_interval-th step of the engine's count and at the
      // last step of the call; rebuild and refresh_walls look before they bin the particles.
      const bool guarded = (first_step + s + 1) % guard_interval == 0 || s + 1 == steps;
      if (s < steps) {
        parts[t] = StepPartial{};
        if (guarded) {
          kick_drift(t, parts[t], std::true_type{});
        } else {
          kick_drift(t, parts[t], std::false_type{});
        }
      }
#pragma omp barrier
      // Every particle has drifted and the step before is complete: close it.
      if (s > 0 && close_step(partials_of(s - 1), dt, master, first_step + s)) break;
      if (s == steps) break;
      theta += e.omega_ * dt;
      double move2 = 0.0;
      std::size_t bad = std::numeric_limits<std::size_t>::max();
      for (int b = 0; b < team; ++b) {
        move2 = std::max(move2, parts[b].displacement2);
        bad = std::min(bad, parts[b].bad);
      }
      const bool rebuild_now = move2 > skin_half2;
      // The lifters have moved as far as the particles may: look again which are near.
      const bool refresh_now =
          Lifters && !rebuild_now && geom.radius * std::abs(theta - reach_theta) > lifter_drift;
      if (bad != std::numeric_limits<std::size_t>::max() || rebuild_now || refresh_now) {
#pragma omp single
        {
          e.theta_ = theta;
          e.step_ = first_step + s + 1;
          if constexpr (Lifters) e.lifter_angles_.update(geom, e.theta_);
          if (bad == std::numeric_limits<std::size_t>::max() && !guarded) {
            // not looked at this step: a non-finite or stray position must not be binned
            for (std::size_t i = 0; i < n; ++i) {
              if (!sound(i)) {
                bad = i;
                break;
              }
            }
          }
          if (bad != std::numeric_limits<std::size_t>::max()) {
            error = describe_bad(e, bad);
          } else if (rebuild_now) {
            rebuild_begin(e, team);
          } else {
            refresh_walls(e);
          }
        }
        if (!error.empty()) break;
        if (rebuild_now) {  // every thread finds the partners of its block of rows
          e.list_.find_rows(x, y, z, r, t, team);
#pragma omp barrier
#pragma omp single
          e.list_.size_rows();
          e.list_.place_rows(t, team);
#pragma omp barrier
#pragma omp single
          rebuild_end(e);
        }
        reach_theta = theta;
      } else if (master) {
        // Read by nobody before the barrier after the pair pass.
        e.theta_ = theta;
        e.step_ = first_step + s + 1;
        if constexpr (Lifters) e.lifter_angles_.update(geom, e.theta_);
      }
      pair_pass(t, dt, parts[t]);
#pragma omp barrier
      particle_pass(t, dt, true, parts[t]);
    }
  }
  if (!error.empty()) throw std::runtime_error(error);
}

/// The kernel of a law for the scene's shape, chosen once per engine.
template <class Law, bool Tally>
StepKernel select_shape(bool one_material, bool lifters, bool end_walls) {
  using A = Engine::Access;
  if (one_material) {
    if (lifters)
      return end_walls ? &A::run<Law, true, true, true, Tally> : &A::run<Law, true, true, false, Tally>;
    return end_walls ? &A::run<Law, true, false, true, Tally> : &A::run<Law, true, false, false, Tally>;
  }
  if (lifters)
    return end_walls ? &A::run<Law, false, true, true, Tally> : &A::run<Law, false, true, false, Tally>;
  return end_walls ? &A::run<Law, false, false, true, Tally> : &A::run<Law, false, false, false, Tally>;
}

/// ... and whether it books the dissipated energy (only a law that dissipates has two).
template <class Law>
StepKernel select_kernel(bool one_material, bool lifters, bool end_walls, bool track_energy) {
  if constexpr (Law::dissipates) {
    if (track_energy) return select_shape<Law, true>(one_material, lifters, end_walls);
  }
  (void)track_energy;
  return select_shape<Law, false>(one_material, lifters, end_walls);
}

}  // namespace millscope::engine
