// Stage: the pair pass of the paper's law without the ledger (Engine::Access::Step), each
// block of rows in three phases: 1. its touching pairs (the wide search over the block's near
// pairs where the SIMD path has it, touching_pairs.hpp and near_pairs.hpp, else the portable
// search over the listed pairs), 2. their forces in SIMD lanes
// (contact_lanes.hpp), 3. the springs back, and the sums. The vector kernels are the engine's
// SIMD path's (lane_kernels.hpp).
#pragma once

#include "step/context.hpp"
#include "step/near_pairs.hpp"

namespace millscope::engine {

template <class S>
void Engine::Access::Step<S>::pair_pass_in_lanes(int t, double history_dt, const NearLook& look,
                                                 StepPartial& part, std::size_t row_begin,
                                                 std::size_t own_end, double* const* buffered) {
  const std::uint32_t* const start = e.list_.start().data();
  const std::uint32_t* const partner = e.list_.partner().data();
  double* const history = e.list_.history().data();
  const double* const touch2 = e.touch_dist2_.data();
  static_assert(!in_lanes || hs == 3, "the lanes carry the spring d_t, 3 doubles");
  // 3. The springs back, and the sums: those on j straight into j, those on i into the row's
  // sums (in registers while the batch is on row i), added to i when the batch leaves its row.
  // As in the portable pass, to the bit: i receives from the rows before it (j > i in a half
  // list, so all of that is in by the time row i begins), then its own row's sum. A row with
  // no touching pair adds nothing: its sum would be +0.0, and a sum that starts at +0.0 and
  // only adds never becomes -0.0, so adding +0.0 would change no bit.
  auto sum_block = [&](ContactBatch& b) {
    std::size_t row = 0;
    double sum_i[6] = {};
    const auto close_row = [&] {
      for (std::size_t q = 0; q < 6; ++q) own[q][row] += sum_i[q];
    };
    for (std::size_t c = 0; c < b.size; ++c) {
      const std::size_t i = b.i[c], j = b.j[c];
      if (c == 0 || i != row) {
        if (c > 0) close_row();
        row = i;
        for (double& v : sum_i) v = 0.0;
      }
      double* const hist = history + static_cast<std::size_t>(b.slot[c]) * hs;
      hist[0] = b.sx[c], hist[1] = b.sy[c], hist[2] = b.sz[c];
      const double r_min = std::min(r[i], r[j]), overlap = b.overlap[c];
      if (overlap > max_overlap * r_min) part.note_overlap(i, overlap / r_min, false);
      const double on_i[6] = {b.fx[c], b.fy[c], b.fz[c], b.tix[c], b.tiy[c], b.tiz[c]};
      const double on_j[6] = {-b.fx[c], -b.fy[c], -b.fz[c], b.tjx[c], b.tjy[c], b.tjz[c]};
      const bool j_own = j < own_end;
      const std::size_t k = j_own ? j : j - own_end;
      double* const* const dst = j_own ? own : buffered;
      for (std::size_t q = 0; q < 6; ++q) {
        sum_i[q] += on_i[q];
        dst[q][k] += on_j[q];
      }
    }
    if (b.size > 0) close_row();
  };
  ContactBatch& b = *batches[static_cast<std::size_t>(t)];
  const materials::PairConstants* const pairs = lane_pairs();
  if (wide) {
    // 1. The touching pairs of each block of rows: the wide search over the block's near
    // pairs (near_pairs.hpp), found again first where `look` says so.
    NearPairs& near = *near_pairs[static_cast<std::size_t>(t)];
    if (look.renew) find_near_pairs(near, b, row_begin, own_end, look.gap);
    for (std::size_t k = 0; k + 1 < near.block_row.size(); ++k) {
      const std::size_t p0 = near.block_pair[k], count = near.block_pair[k + 1] - p0;
      b.size = 0;  // reserve_listed counts its room from size
      b.reserve_listed(count);
      const TouchingPairs out{b.i.data(),  b.j.data(),  b.slot.data(),
                              b.dx.data(), b.dy.data(), b.dz.data()};
      b.size = lanes.touching_entries[!EndWalls][prefetch](
          count, near.row.data() + p0, near.partner.data() + p0, near.slot.data() + p0,
          near.touch2.data() + p0, x, y, z, n, period, out, ahead);
      for (std::size_t c = 0; c < b.size; ++c) {
        const double* const hist = history + static_cast<std::size_t>(b.slot[c]) * hs;
        b.sx[c] = hist[0], b.sy[c] = hist[1], b.sz[c] = hist[2];
        if constexpr (!OneMaterial) b.pair[c] = lane_pair(mat[b.i[c]], mat[b.j[c]]);
      }
      // A listed pair that does not touch has its history cleared; those that touch get
      // theirs back in phase 3. Only near pairs can hold one, but when they have just been
      // found, every listed pair of the block is cleared: a pair that touched at the step
      // before may no longer be near (its slot moved in a list build, or this is a call's first
      // step, or the gap is now narrower than it moved).
      if (look.renew) {
        std::fill(history + static_cast<std::size_t>(start[near.block_row[k]]) * hs,
                  history + static_cast<std::size_t>(start[near.block_row[k + 1]]) * hs, 0.0);
      } else {
        for (std::size_t q = p0; q < p0 + count; ++q)
          std::fill_n(history + static_cast<std::size_t>(near.slot[q]) * hs, hs, 0.0);
      }
      // 2. Their forces, several at a time.
      lanes.contact_forces[OneMaterial](b, pairs, r, inv_m, vx, vy, vz, wx, wy, wz, history_dt);
      sum_block(b);
    }
    return;
  }
  for (std::size_t block = row_begin; block < own_end;) {
    // 1. The touching pairs of the rows [block, block_end); a listed pair that does not
    // touch has its history cleared.
    b.size = 0;
    std::size_t block_end = block;
    while (block_end < own_end && b.size < ContactBatch::max_contacts &&
           block_end - block < ContactBatch::max_rows) {
      const std::size_t i = block_end;
      const double xi = x[i], yi = y[i], zi = z[i];
      b.reserve(start[i + 1] - start[i]);
      for (std::uint32_t s = start[i]; s < start[i + 1]; ++s) {
        const std::size_t j = partner[s];
        double* const hist = history + static_cast<std::size_t>(s) * hs;
        const double dx = xi - x[j], dy = yi - y[j];
        double dz = zi - z[j];
        if constexpr (!EndWalls) dz -= period * std::nearbyint(dz / period);
        if (!(dx * dx + dy * dy + dz * dz < touch2[s])) {
          Law::clear(hist);
          continue;
        }
        const std::size_t c = b.size++;
        b.i[c] = static_cast<std::uint32_t>(i);
        b.j[c] = static_cast<std::uint32_t>(j);
        b.slot[c] = s;
        if constexpr (!OneMaterial) b.pair[c] = lane_pair(mat[i], mat[j]);
        b.dx[c] = dx, b.dy[c] = dy, b.dz[c] = dz;
        b.sx[c] = hist[0], b.sy[c] = hist[1], b.sz[c] = hist[2];
      }
      ++block_end;
    }
    // 2. Their forces, several at a time.
    lanes.contact_forces[OneMaterial](b, pairs, r, inv_m, vx, vy, vz, wx, wy, wz, history_dt);
    sum_block(b);
    block = block_end;
  }
}

}  // namespace millscope::engine
