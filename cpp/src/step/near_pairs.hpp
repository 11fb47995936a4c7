// The near pairs of a share's rows, for the wide search (Engine::Access::Step): the listed
// pairs that were within a gap g (m) of touching when the search last looked, in list order.
// The pair pass tests only these at every step (touching_pairs.hpp, TouchingEntriesSearch),
// and looks for them again, over all listed pairs of its rows, after each list build and
// before a pair not among them may touch: a pair apart by at least g when they were found
// can touch only once its two particles have moved g between them, and a drift moves a
// particle by at most |v| dt, so the step loop (run.hpp) sums the largest speed of each drift
// times dt and looks again before twice that sum reaches g. The same pairs touch as in a
// search over the whole list, in the same order: the forces are the same to the bit,
// whatever g. The step loop widens g where it looks again within a few steps and narrows it
// where it looks only every few dozen (the search's cost is the near pairs at every step
// plus all listed pairs at each look).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "step/context.hpp"

namespace millscope::engine {

/// One share's near pairs, in the blocks of rows the pair pass works on: block k holds rows
/// [block_row[k], block_row[k + 1]) and near pairs [block_pair[k], block_pair[k + 1]).
struct NearPairs {
  // Per near pair: row i, partner j, list slot and (r_i + r_j)^2, m^2; max_search_lanes
  // entries of room past the last, holding particle 0 (the search loads whole vectors).
  std::vector<std::uint32_t> row, partner, slot;
  std::vector<double> touch2;
  std::vector<std::size_t> block_row, block_pair;
  // Scratch of a look: (r_i + r_j + gap)^2, m^2, of the share's listed pairs, from its first.
  std::vector<double> within2;

  void start(std::size_t first_row) {
    row.clear(), partner.clear(), slot.clear(), touch2.clear();
    block_row.assign(1, first_row);
    block_pair.assign(1, 0);
  }
  /// Appends a block's near pairs: the wide search's first `count` pairs in `b`.
  void add_block(std::size_t end_row, const ContactBatch& b, std::size_t count,
                 const double* touch_dist2) {
    row.insert(row.end(), b.i.begin(), b.i.begin() + static_cast<std::ptrdiff_t>(count));
    partner.insert(partner.end(), b.j.begin(), b.j.begin() + static_cast<std::ptrdiff_t>(count));
    slot.insert(slot.end(), b.slot.begin(), b.slot.begin() + static_cast<std::ptrdiff_t>(count));
    for (std::size_t c = 0; c < count; ++c) touch2.push_back(touch_dist2[b.slot[c]]);
    block_row.push_back(end_row);
    block_pair.push_back(row.size());
  }
  void finish() {
    const std::size_t n = row.size() + max_search_lanes;
    row.resize(n, 0), partner.resize(n, 0), slot.resize(n, 0), touch2.resize(n, 0.0);
  }
};

// The near pairs of rows [row_begin, own_end) within `gap` (m) of touching, in the blocks of
// rows the pair pass works on (each at most wide_block_listed listed pairs, or one row that
// holds more): the wide search over the listed pairs with the near distances in place of the
// touching ones. `b` is scratch.
template <class S>
void Engine::Access::Step<S>::find_near_pairs(NearPairs& near, ContactBatch& b,
                                              std::size_t row_begin, std::size_t own_end,
                                              double gap) {
  const std::uint32_t* const start = e.list_.start().data();
  const std::uint32_t* const partner = e.list_.partner().data();
  const std::uint32_t first = start[row_begin];
  near.within2.assign(start[own_end] - first + max_search_lanes, 0.0);
  for (std::size_t i = row_begin; i < own_end; ++i) {
    for (std::uint32_t s = start[i]; s < start[i + 1]; ++s) {
      const double reach = r[i] + r[partner[s]] + gap;
      near.within2[s - first] = reach * reach;
    }
  }
  near.start(row_begin);
  for (std::size_t block = row_begin; block < own_end;) {
    const std::size_t row_limit = std::min(own_end, block + ContactBatch::max_rows);
    std::size_t block_end = block + 1;
    while (block_end < row_limit && start[block_end + 1] - start[block] <= wide_block_listed)
      ++block_end;
    b.size = 0;  // reserve_listed counts its room from size
    b.reserve_listed(start[block_end] - start[block]);
    const TouchingPairs out{b.i.data(),  b.j.data(),  b.slot.data(),
                            b.dx.data(), b.dy.data(), b.dz.data()};
    const std::size_t count = lanes.touching_pairs[!EndWalls][prefetch](
        block, block_end, start, partner, x, y, z, near.within2.data() + (start[block] - first),
        n, period, b.slot_row.data(), out, ahead);
    near.add_block(block_end, b, count, e.touch_dist2_.data());
    block = block_end;
  }
  near.finish();
}

}  // namespace millscope::engine
