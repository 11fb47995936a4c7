// Neighbour search: a cell grid and a half Verlet list with a skin, with per-pair contact
// history carried across rebuilds (docs/architecture.md, The engine).
//
// The list holds every pair i < j whose surfaces are closer than the skin, in compressed rows:
// the partners of i are partner[start[i] .. start[i+1]), sorted. Each listed pair owns
// `history_size` doubles in an array aligned with the list, so the hot loop reads a pair's
// history next to its partner index, without lookups. A rebuild moves each surviving pair's
// history to its new slot (a binary search in the old, sorted row) and zeroes new pairs.
// Rebuilding is O(N) for a bounded density: particles are binned into cubic cells at least
// 2 r_max + skin wide, and each particle looks in its cell and the 26 around it, skipping a
// cell farther than r_i + r_max + skin and the particles before it.
// Optionally periodic along z with period `period_z` (minimum image).
//
// spatial_order() gives the order of the particles cell by cell, the axis with the most cells
// slowest: stored in that order, the partners of a particle sit close to it in memory, and the
// partners of a block of rows fall within a short range of indices after the block (what the
// engine's per-thread pair buffers hold). build() takes the permutation the caller applied
// since the last build, so the history follows the pairs. A pair's history is that of its row
// particle relative to its partner (the tangential spring of contact.hpp is odd: swapping the
// two negates it), so a pair whose two particles swap ranks has its history negated.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace millscope::neighbors {

/// Empties v and gives its memory back (`v = {}` would keep the capacity).
template <class T>
void release(std::vector<T>& v) {
  std::vector<T>().swap(v);
}

/// The list's squared test lets pass pairs up to this much (relative) beyond r_i + r_j + skin,
/// far more than the rounding of the distances, so that it never rejects a pair the exact
/// test (a root) would list.
inline constexpr double squared_test_slack = 1e-9;

/// The distance, m, below which the squared test lets a pair of radii ri and rj (m) pass with
/// this skin (m): (ri + rj + skin) (1 + squared_test_slack).
inline double squared_test_reach(double ri, double rj, double skin) {
  return (ri + rj + skin) * (1.0 + squared_test_slack);
}

/// near[k] = whether candidate k (centre x[k], y[k], z[k], radius r[k]; k < m) passes the
/// list's first, squared test against a sphere at xi, yi, zi of radius ri (VerletList::
/// is_partner, in the same operations): |d|^2 < squared_test_reach(ri, r_k, skin)^2.
/// Not for a periodic axis. In SIMD lanes, in the widest the CPU has (src/near_in_lanes-inl.hpp,
/// dispatched by Google Highway); a comparison gives the same answer in any lanes.
void near_in_lanes(double xi, double yi, double zi, double ri, double skin, const double* x,
                   const double* y, const double* z, const double* r, std::size_t m,
                   unsigned char* near);

class VerletList {
 public:
  /// skin: extra gap kept in the list, m; history_size: doubles of history per pair;
  /// period_z: the period along z for periodic ends, or 0 for none, m.
  VerletList(double skin, std::size_t history_size, double period_z = 0.0)
      : skin_(skin), history_size_(history_size), period_z_(period_z) {
    auto fail = [](const char* name, double value, const char* range) {
      std::ostringstream msg;
      msg << name << " = " << value << " m is not valid; it must be " << range;
      throw std::invalid_argument(msg.str());
    };
    if (!(skin > 0.0) || !std::isfinite(skin)) fail("skin", skin, "> 0");
    if (!(period_z >= 0.0) || !std::isfinite(period_z))
      fail("period_z", period_z, ">= 0 (0: not periodic)");
  }

  /// The particles in cell order: order[k] is the index of the k-th particle when they are
  /// sorted by cell, the axis with the most cells slowest, then the next; stable within a cell.
  std::vector<std::uint32_t> spatial_order(const double* x, const double* y, const double* z,
                                           const double* r, std::size_t n) {
    bin(x, y, z, r, n);
    return cell_particles_;
  }

  /// Rebuilds the list for n spheres (centres x, y, z, radii r), keeping the history of pairs
  /// that stay listed. `moved`, when given, says where each particle came from since the last
  /// build: the particle now at index k was at index moved[k] (a permutation of 0..n-1); it
  /// must stay valid until the build is finished.
  /// `team` > 1 runs the phases below in that many blocks of rows, one block after another
  /// (the list is the same).
  void build(const double* x, const double* y, const double* z, const double* r, std::size_t n,
             const std::uint32_t* moved = nullptr, int team = 1) {
    begin_build(x, y, z, r, n, moved, team);
    build_rows(x, y, z, r, team);
    finish_build();
  }

  /// The phases between begin_build and finish_build for every block of a team, run by one
  /// thread; the blocks are placed last to first, as threads may finish in any order.
  void build_rows(const double* x, const double* y, const double* z, const double* r,
                  int team) {
    for (int t = 0; t < team; ++t) find_rows(x, y, z, r, t, team);
    size_rows();
    for (int t = team - 1; t >= 0; --t) place_rows(t, team);
  }

  // build() in phases, for a team of threads (the engine's step loop builds the rows of each
  // thread in parallel): begin_build and size_rows by one thread, find_rows and place_rows by
  // every thread t of the team for its block of rows, a barrier between phases, finish_build
  // last. The list is the same whatever the team.

  /// Bins the particles and sets the old list aside.
  void begin_build(const double* x, const double* y, const double* z, const double* r,
                   std::size_t n, const std::uint32_t* moved, int team) {
    old_start_ = std::move(start_);
    old_partner_ = std::move(partner_);
    old_history_ = std::move(history_);
    moved_ = moved;
    bin(x, y, z, r, n);
    start_.assign(n + 1, 0);
    rows_of_thread_.resize(static_cast<std::size_t>(team));
  }

  /// The partners of thread t's rows, into its own buffer; their counts into start_[i + 1].
  void find_rows(const double* x, const double* y, const double* z, const double* r, int t,
                 int team) {
    const auto [begin, end] = block_of(t, team);
    std::vector<std::uint32_t>& found = rows_of_thread_[static_cast<std::size_t>(t)];
    found.clear();
    std::vector<std::uint32_t> row;
    for (std::size_t i = begin; i < end; ++i) {
      row.clear();
      const double at[3] = {x[i], y[i], z[i]};
      int c[3];
      // Squared distance from the particle to the cell beside its own along axis a, below
      // (face2[a][0]) and above (face2[a][2]); 0 to its own (face2[a][1]), m^2.
      double face2[3][3];
      for (int a = 0; a < 3; ++a) {
        c[a] = cell_coord(at[a], lo_[a], a);
        // the faces of the cell the particle lies in (along a periodic axis, before wrapping:
        // z may round to the period itself)
        const double u = at[a] - lo_[a];
        const int k = a == 2 && periodic() ? static_cast<int>(std::floor(u / cell_size_[a])) : c[a];
        const double below = u - k * cell_size_[a];
        const double above = (k + 1) * cell_size_[a] - u;
        face2[a][0] = below > 0.0 ? below * below : 0.0;
        face2[a][1] = 0.0;
        face2[a][2] = above > 0.0 ? above * above : 0.0;
      }
      // No partner's centre lies farther than r_i + r_max + skin: a cell beyond is skipped (the
      // bound raised by far more than the rounding of the distances).
      const double reach = squared_test_reach(r[i], r_max_, skin_);
      const double reach2 = reach * reach;
      for (int dz = -1; dz <= 1; ++dz) {
        int kz = c[2] + dz;
        if (periodic()) {
          kz = (kz % dims_[2] + dims_[2]) % dims_[2];
        } else if (kz < 0 || kz >= dims_[2]) {
          continue;
        }
        for (int dy = -1; dy <= 1; ++dy) {
          const int ky = c[1] + dy;
          if (ky < 0 || ky >= dims_[1]) continue;
          for (int dx = -1; dx <= 1; ++dx) {
            const int kx = c[0] + dx;
            if (kx < 0 || kx >= dims_[0]) continue;
            if (face2[0][dx + 1] + face2[1][dy + 1] + face2[2][dz + 1] >= reach2) continue;
            // A cell holds its particles in ascending order: those after i only.
            const std::size_t cell = index(kx, ky, kz);
            const auto first = cell_particles_.begin() + cell_start_[cell];
            const auto last = cell_particles_.begin() + cell_start_[cell + 1];
            if (first == last || last[-1] <= i) continue;  // none after i
            // Stored in cell order (the engine's reorder), a cell's particles are a run of
            // consecutive indices: those after i are found without a search and tested in
            // lanes.
            if (!periodic() && last[-1] - *first == static_cast<std::uint32_t>(last - first) - 1) {
              scan_run(i, x, y, z, r, std::max<std::size_t>(*first, i + 1),
                       last[-1] + std::size_t{1}, row);
              continue;
            }
            const auto after = std::upper_bound(first, last, static_cast<std::uint32_t>(i));
            for (auto it = after; it != last; ++it) {
              const std::uint32_t p = *it;
              if (is_partner(i, x, y, z, r, p)) row.push_back(p);
            }
          }
        }
      }
      std::sort(row.begin(), row.end());
      row.erase(std::unique(row.begin(), row.end()), row.end());  // tiny periodic grids
      found.insert(found.end(), row.begin(), row.end());
      start_[i + 1] = static_cast<std::uint32_t>(row.size());
    }
  }

  /// The row starts from the counts; room for the partners and their history.
  void size_rows() {
    for (std::size_t i = 1; i < start_.size(); ++i) start_[i] += start_[i - 1];
    partner_.resize(start_.back());
    history_.assign(partner_.size() * history_size_, 0.0);
  }

  /// Thread t's partners into the list, and the history of its pairs that stay listed.
  void place_rows(int t, int team) {
    const auto [begin, end] = block_of(t, team);
    const std::vector<std::uint32_t>& found = rows_of_thread_[static_cast<std::size_t>(t)];
    std::copy(found.begin(), found.end(), partner_.begin() + start_[begin]);
    const std::size_t n = start_.size() - 1;
    if (history_size_ == 0 || old_start_.size() != n + 1) return;
    for (std::size_t i = begin; i < end; ++i) {
      const std::uint32_t old_i = moved_ != nullptr ? moved_[i] : static_cast<std::uint32_t>(i);
      for (std::uint32_t s = start_[i]; s < start_[i + 1]; ++s) {
        // The pair's old slot: in the row of its lower old index (a half list).
        std::uint32_t row = old_i, other = moved_ != nullptr ? moved_[partner_[s]] : partner_[s];
        const bool swapped = other < row;
        if (swapped) std::swap(row, other);
        const auto first = old_partner_.begin() + old_start_[row];
        const auto last = old_partner_.begin() + old_start_[row + 1];
        const auto it = std::lower_bound(first, last, other);
        if (it == last || *it != other) continue;
        const auto old_slot = static_cast<std::size_t>(it - old_partner_.begin());
        const double sign = swapped ? -1.0 : 1.0;
        for (std::size_t h = 0; h < history_size_; ++h)
          history_[s * history_size_ + h] = sign * old_history_[old_slot * history_size_ + h];
      }
    }
  }

  /// Lets go of the old list, the threads' row buffers and the cell grid (memory per particle
  /// counts between builds; a build allocates them again).
  void finish_build() {
    release(old_start_);
    release(old_partner_);
    release(old_history_);
    for (auto& rows : rows_of_thread_) release(rows);
    release(cell_start_);
    release(cell_particles_);
    moved_ = nullptr;
    ++builds_;
  }

  /// Puts back a list saved from start(), partner(), history() and builds() (a checkpoint), so
  /// that a continued run sees the very same list. Throws std::invalid_argument when the pieces
  /// do not fit together for n spheres.
  void restore(std::size_t n, std::vector<std::uint32_t> start, std::vector<std::uint32_t> partner,
               std::vector<double> history, long builds) {
    // A list never built (a checkpoint of an engine that has not stepped) is empty.
    const bool never_built = builds == 0 && start.empty() && partner.empty() && history.empty();
    const bool fits = never_built || (start.size() == n + 1 && start.front() == 0 &&
                                      start.back() == partner.size() &&
                                      std::is_sorted(start.begin(), start.end()) &&
                                      history.size() == partner.size() * history_size_ &&
                                      std::all_of(partner.begin(), partner.end(),
                                                  [n](std::uint32_t p) { return p < n; }));
    if (!fits) {
      throw std::invalid_argument("the saved neighbour list does not fit " + std::to_string(n) +
                                  " particles with " + std::to_string(history_size_) +
                                  " history values per pair");
    }
    start_ = std::move(start);
    partner_ = std::move(partner);
    history_ = std::move(history);
    builds_ = builds;
  }

  std::size_t pairs() const { return partner_.size(); }
  /// Bytes the list keeps between builds: rows, partners, history (and the cell grid, the
  /// threads' row buffers and the list before the build, released by finish_build).
  std::size_t bytes() const {
    auto of = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
    std::size_t total = of(start_) + of(partner_) + of(history_) + of(cell_start_) +
                        of(cell_particles_) + of(rows_of_thread_) + of(old_start_) +
                        of(old_partner_) + of(old_history_);
    for (const auto& rows : rows_of_thread_) total += of(rows);
    return total;
  }
  const std::vector<std::uint32_t>& start() const { return start_; }
  const std::vector<std::uint32_t>& partner() const { return partner_; }
  std::vector<double>& history() { return history_; }
  const std::vector<double>& history() const { return history_; }
  std::size_t history_size() const { return history_size_; }
  double skin() const { return skin_; }
  long builds() const { return builds_; }

  /// z displacement by the minimum image for periodic ends, m.
  double wrap_dz(double dz) const {
    return periodic() ? dz - period_z_ * std::round(dz / period_z_) : dz;
  }

 private:
  // Whether p lies within the skin of i (the list's rule): far apart by their squares (no
  // root), or else the gap itself.
  bool is_partner(std::size_t i, const double* x, const double* y, const double* z,
                  const double* r, std::size_t p) const {
    const double sx = x[i] - x[p], sy = y[i] - y[p], sz = wrap_dz(z[i] - z[p]);
    const double d2 = sx * sx + sy * sy + sz * sz;
    const double far = squared_test_reach(r[i], r[p], skin_);
    return d2 < far * far && std::sqrt(d2) - r[i] - r[p] < skin_;
  }

  // The partners of i among particles [p0, p1) (no periodic axis), in ascending order: the
  // squared test in lanes over blocks of candidates (near_in_lanes), is_partner for the few
  // that pass it.
  void scan_run(std::size_t i, const double* x, const double* y, const double* z,
                const double* r, std::size_t p0, std::size_t p1,
                std::vector<std::uint32_t>& row) const {
    constexpr std::size_t block = 64;
    unsigned char near[block];
    for (std::size_t b0 = p0; b0 < p1; b0 += block) {
      const std::size_t m = std::min(block, p1 - b0);
      near_in_lanes(x[i], y[i], z[i], r[i], skin_, x + b0, y + b0, z + b0, r + b0, m, near);
      for (std::size_t k = 0; k < m; ++k)
        if (near[k] && is_partner(i, x, y, z, r, b0 + k))
          row.push_back(static_cast<std::uint32_t>(b0 + k));
    }
  }

  bool periodic() const { return period_z_ > 0.0; }

  int cell_coord(double v, double lo, int axis) const {
    int k = static_cast<int>(std::floor((v - lo) / cell_size_[axis]));
    if (axis == 2 && periodic()) return (k % dims_[2] + dims_[2]) % dims_[2];
    return std::clamp(k, 0, dims_[axis] - 1);
  }

  // Cells are numbered with the axis of most cells slowest (axes_[0]), so that the cell order
  // cuts the charge into the thinnest slabs (spatial_order()).
  std::size_t index(int kx, int ky, int kz) const {
    const int k[3] = {kx, ky, kz};
    const auto slow = static_cast<std::size_t>(k[axes_[0]]);
    const auto mid = static_cast<std::size_t>(k[axes_[1]]);
    const auto fast = static_cast<std::size_t>(k[axes_[2]]);
    return (slow * static_cast<std::size_t>(dims_[axes_[1]]) + mid) *
               static_cast<std::size_t>(dims_[axes_[2]]) + fast;
  }

  // Counting sort of the particles into cells.
  void bin(const double* x, const double* y, const double* z, const double* r, std::size_t n) {
    double r_max = 0.0;
    double hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    lo_[0] = lo_[1] = lo_[2] = HUGE_VAL;
    const double* c[3] = {x, y, z};
    for (std::size_t i = 0; i < n; ++i) {
      r_max = std::max(r_max, r[i]);
      for (int a = 0; a < 3; ++a) {
        lo_[a] = std::min(lo_[a], c[a][i]);
        hi[a] = std::max(hi[a], c[a][i]);
      }
    }
    if (n == 0) lo_[0] = lo_[1] = lo_[2] = hi[0] = hi[1] = hi[2] = 0.0;
    r_max_ = r_max;
    const double min_cell = 2.0 * r_max + skin_;
    for (int a = 0; a < 3; ++a) {
      double extent = hi[a] - lo_[a];
      if (a == 2 && periodic()) {
        lo_[2] = 0.0;
        extent = period_z_;
      }
      dims_[a] = std::max(1, static_cast<int>(std::floor(extent / min_cell)));
      cell_size_[a] = std::max(extent / dims_[a], min_cell);
    }
    axes_[0] = 0;
    axes_[1] = 1;
    axes_[2] = 2;
    std::stable_sort(axes_, axes_ + 3, [this](int a, int b) { return dims_[a] > dims_[b]; });
    // With fewer than 3 cells along a periodic axis, neighbouring cells would be seen twice;
    // the unique() in find_rows() removes the duplicates.
    const std::size_t cells = static_cast<std::size_t>(dims_[0]) * static_cast<std::size_t>(dims_[1]) *
                              static_cast<std::size_t>(dims_[2]);
    cell_start_.assign(cells + 1, 0);
    std::vector<std::size_t> cell_of(n);
    for (std::size_t i = 0; i < n; ++i) {
      cell_of[i] = index(cell_coord(x[i], lo_[0], 0), cell_coord(y[i], lo_[1], 1),
                         cell_coord(z[i], lo_[2], 2));
      ++cell_start_[cell_of[i] + 1];
    }
    for (std::size_t k = 0; k < cells; ++k) cell_start_[k + 1] += cell_start_[k];
    cell_particles_.assign(n, 0);
    std::vector<std::uint32_t> fill(cell_start_.begin(), cell_start_.end() - 1);
    for (std::size_t i = 0; i < n; ++i)
      cell_particles_[fill[cell_of[i]]++] = static_cast<std::uint32_t>(i);
  }

  double skin_;
  std::size_t history_size_;
  double period_z_;
  long builds_ = 0;
  double r_max_ = 0.0;  // the largest radius at the last binning, m
  double lo_[3] = {0, 0, 0};
  double cell_size_[3] = {1, 1, 1};
  int dims_[3] = {1, 1, 1};
  int axes_[3] = {2, 1, 0};  // slowest to fastest in the cell numbering
  std::vector<std::uint32_t> cell_start_, cell_particles_;
  std::vector<std::uint32_t> start_, partner_;
  std::vector<double> history_;
  // during a build: the list before it, where the particles came from, each thread's rows
  std::vector<std::uint32_t> old_start_, old_partner_;
  std::vector<double> old_history_;
  const std::uint32_t* moved_ = nullptr;
  std::vector<std::vector<std::uint32_t>> rows_of_thread_;

  /// Thread t's block of rows of the list being built.
  std::pair<std::size_t, std::size_t> block_of(int t, int team) const {
    const std::size_t n = start_.size() - 1;
    const auto tt = static_cast<std::size_t>(t), k = static_cast<std::size_t>(team);
    return {n * tt / k, n * (tt + 1) / k};
  }
};

}  // namespace millscope::neighbors
