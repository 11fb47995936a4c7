// The first phase of the engine's pair pass, several listed pairs at a time: which listed
// pairs of a block of Verlet list rows touch (|x_i - x_j| < r_i + r_j), packed in list order.
// The pair pass runs it in two forms (step/near_pairs.hpp): over a block's listed pairs, with
// a distance a gap beyond touching, to find the near pairs when it looks for them, and at
// every step over the near pairs alone, packed one after another, to find those that touch.
// This header holds what the search reads and writes; touching_pairs-inl.hpp holds the search
// itself, compiled once per SIMD target (lane_kernels.cpp).
//
// The portable search in the engine (step/pair_pass_lanes.hpp) tests one listed pair at a time
// and branches on the answer; a third of the pairs touch, so the branch is mispredicted about
// once a row, and each test waits on its own loads. The wide search tests a vector's worth of
// listed pairs at once (4 with AVX2, 8 with AVX-512) and packs the touching ones without a
// branch. Its arithmetic is the portable search's, operation for operation (the build keeps
// the compiler from fusing a multiply and an add: -ffp-contract=off), so the same pairs touch
// and the same differences x_i - x_j are kept, to the bit.
#pragma once

#include <cstddef>
#include <cstdint>

namespace millscope::engine {

/// The most listed pairs the wide search tests at once on any target (doubles in the widest
/// vector, SVE's 2048 bits): the room its whole-vector stores need past their last entry.
inline constexpr std::size_t max_search_lanes = 32;

/// Where the wide search writes the touching pairs: row i, partner j, list slot, and x_i - x_j
/// (m), one entry per pair. Each array needs room for max_search_lanes entries beyond the last
/// pair it can receive (whole vectors are stored).
struct TouchingPairs {
  std::uint32_t* i;
  std::uint32_t* j;
  std::uint32_t* slot;
  double* dx;
  double* dy;
  double* dz;
};

/// What the wide search asks for ahead of its reads, where the engine's data do not fit the
/// caches (Engine::prefetch_partners). A row's partners lie just after it or about a row of
/// cells further on (200-250 particles in the slices), and their state is read through the
/// list, which the hardware's prefetchers cannot follow. So at each vector of listed pairs the
/// search asks for the state of the partners `pair_ahead` pairs on, and for the list
/// `list_ahead` pairs on, so that the partners' indices are at hand when their turn comes.
/// Asking does not change what is computed. Both are needed: the partners' state alone waits
/// on list entries that are not in the cache yet, and the list alone does not bring the state.
/// Every array the pair pass reads for a partner is asked for (positions, radii, velocities,
/// spins, inverse masses). The arrays are a fixed count, so that the loop over them unrolls.
struct PartnerPrefetch {
  static constexpr std::size_t count = 11;
  const double* arrays[count];  // per-particle arrays to ask for, at partner j's entry
  static constexpr std::uint32_t list_ahead = 2048;  // listed pairs
  static constexpr std::uint32_t pair_ahead = 256;   // listed pairs
};

/// The wide search: the pairs of the Verlet list rows [first_row, end_row) (half list: row i's
/// partners partner[start[i]..start[i + 1])) closer than a distance of their own, in list
/// order, into `out`; returns how many. x, y, z (m) hold the n particles' centres; within2
/// (m^2) that distance squared for each listed pair of the block, from its first (listed pair
/// start[first_row] + k at within2[k]): (r_i + r_j)^2 finds the touching pairs, (r_i + r_j +
/// g)^2 those within g of touching (step/near_pairs.hpp). It needs room for max_search_lanes
/// beyond the block's last listed pair (whole vectors are loaded). Periodic (the template's
/// first flag):
/// z differences wrap by `period` (m), as dz - period * nearbyint(dz / period). `slot_row` is
/// scratch for the rows' listed pairs, with room for max_search_lanes beyond them. Prefetching
/// (the second flag): asks for what `ahead` names as it goes.
using TouchingPairsSearch = std::size_t (*)(std::size_t first_row, std::size_t end_row,
                                            const std::uint32_t* start,
                                            const std::uint32_t* partner, const double* x,
                                            const double* y, const double* z,
                                            const double* within2, std::size_t n,
                                            double period, std::uint32_t* slot_row,
                                            const TouchingPairs& out,
                                            const PartnerPrefetch& ahead);

/// The wide search over pairs packed one after another (the near pairs of a block,
/// step/near_pairs.hpp): which of pairs [0, count) touch, in order, into `out`; returns how
/// many. Pair k: row[k] (ascending, as in the list), partner[k], list slot slot[k] and
/// touch2[k] = (r_i + r_j)^2, m^2. Each of the four arrays is read in whole vectors: it needs
/// max_search_lanes entries past count that hold particle indices below n (they are not
/// kept). The rest as in TouchingPairsSearch (Prefetch asks `pair_ahead` pairs on).
using TouchingEntriesSearch = std::size_t (*)(std::size_t count, const std::uint32_t* row,
                                              const std::uint32_t* partner,
                                              const std::uint32_t* slot, const double* touch2,
                                              const double* x, const double* y, const double* z,
                                              std::size_t n, double period,
                                              const TouchingPairs& out,
                                              const PartnerPrefetch& ahead);

}  // namespace millscope::engine
