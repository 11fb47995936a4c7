// The wide search of touching_pairs.hpp, written once with Highway's portable vector operations
// and compiled for each SIMD target lane_kernels.cpp names (foreach_target.h includes this file
// once per target, with HWY_NAMESPACE naming the target's namespace). Not for other files.

// Per-target include guard: Highway toggles HWY_TARGET_TOGGLE for each target it compiles.
#if defined(MILLSCOPE_TOUCHING_PAIRS_INL_) == defined(HWY_TARGET_TOGGLE)
#ifdef MILLSCOPE_TOUCHING_PAIRS_INL_
#undef MILLSCOPE_TOUCHING_PAIRS_INL_
#else
#define MILLSCOPE_TOUCHING_PAIRS_INL_
#endif

#include <hwy/cache_control.h>
#include <hwy/highway.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "touching_pairs.hpp"

HWY_BEFORE_NAMESPACE();
namespace millscope::engine::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

/// Whether Highway's Compress packs this target's lanes of `Bytes` bytes with one instruction,
/// in a register (AVX-512's compress of 32-bit lanes; SVE's of any), stored as a whole vector
/// after it. Not CompressStore: on AVX-512 that is the compress instruction's memory form, which
/// AMD Zen 4 runs as microcode, far slower than the register form and a store. Elsewhere
/// Highway 1.0's Compress permutes by a table that it copies onto the stack at every call (a
/// local constexpr array: AVX2, NEON, and AVX-512's 64-bit lanes), which cost more than the rest
/// of the search; there the search permutes by a table of its own, in read-only memory:
/// PackTable.
template <std::size_t Bytes>
inline constexpr bool native_compress =
    (Bytes == 4 && HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3) ||
    (HWY_TARGET & (HWY_SVE | HWY_SVE2 | HWY_SVE_256 | HWY_SVE2_128)) != 0;

/// For N lanes and each mask `bits` of them: the lanes in the order that packs those set in
/// `bits` first, in lane order (then the others), for TableLookupLanes on doubles (64-bit
/// indices) and on 32-bit lanes.
template <std::size_t N>
struct PackTable {
  std::int64_t lane64[1u << N][N] = {};
  std::int32_t lane32[1u << N][N] = {};
  constexpr PackTable() {
    for (std::size_t bits = 0; bits < (1u << N); ++bits) {
      std::size_t k = 0;
      for (int set = 1; set >= 0; --set)
        for (std::size_t lane = 0; lane < N; ++lane)
          if (((bits >> lane) & 1u) == static_cast<std::size_t>(set)) {
            lane64[bits][k] = static_cast<std::int64_t>(lane);
            lane32[bits][k++] = static_cast<std::int32_t>(lane);
          }
    }
  }
};
template <std::size_t N>
inline constexpr PackTable<N> pack_table{};

/// Stores at `p` the lanes of v that mask m selects, packed in lane order; may write the whole
/// vector. `bits` holds m as StoreMaskBits writes it (the table's row). v has lanes of 32 or
/// 64 bits; without a native compress (native_compress), at most 8 of them.
template <class D>
HWY_INLINE void pack_store(D d, hn::Vec<D> v, hn::Mask<D> m, const std::uint8_t* bits,
                           hn::TFromD<D>* p) {
  using T = hn::TFromD<D>;
  if constexpr (native_compress<sizeof(T)>) {
    hn::StoreU(hn::Compress(v, m), d, p);
  } else {
    constexpr std::size_t N = hn::MaxLanes(D());
    static_assert(N <= 8, "a mask of at most 8 lanes");
    const hn::RebindToSigned<D> di;
    const auto* const order = [&] {
      if constexpr (sizeof(T) == 8) {
        return pack_table<N>.lane64[bits[0]];
      } else {
        return pack_table<N>.lane32[bits[0]];
      }
    }();
    hn::StoreU(hn::TableLookupLanes(v, hn::IndicesFromVec(d, hn::LoadU(di, order))), d, p);
  }
}

/// Tests N = Lanes(d) pairs at once, rows i and partners j (the lanes past `live` are not
/// kept), and packs those closer than their distance (within2, squared: (r_i + r_j)^2 for
/// touching) at out[size..]: row, partner, slot and x_i - x_j. Returns how many it packed.
template <bool Periodic, class D, class DU>
HWY_INLINE std::size_t test_and_pack(D d, DU du, hn::Vec<DU> rows, hn::Vec<DU> j,
                                     hn::Vec<DU> slots, hn::Vec<D> within2, hn::Mask<D> live,
                                     const double* x, const double* y, const double* z,
                                     std::size_t n, hn::Vec<D> per, const TouchingPairs& out,
                                     std::size_t size) {
  const hn::RebindToUnsigned<D> du64;  // the indices, widened for the gathers
  const hn::RebindToSigned<D> di64;
  const std::size_t lanes = hn::Lanes(d);
  const auto window = hn::Set(du, static_cast<std::uint32_t>(lanes));
  // The rows' values. A list row's partners follow it closely, so N pairs mostly belong to
  // rows within N particles of the first: one load and a permute. Else (empty rows between
  // them, or the array's end) a gather. Lanes past `live` hold the first lane's row.
  const std::uint32_t base = hn::GetLane(rows);
  const auto base_v = hn::Set(du, base);
  const auto rel = hn::Sub(rows, base_v);
  hn::Vec<D> xi, yi, zi;
  if (base + lanes <= n && hn::AllTrue(du, hn::Lt(rel, window))) {
    const auto idx = hn::IndicesFromVec(d, hn::BitCast(di64, hn::PromoteTo(du64, rel)));
    xi = hn::TableLookupLanes(hn::LoadU(d, x + base), idx);
    yi = hn::TableLookupLanes(hn::LoadU(d, y + base), idx);
    zi = hn::TableLookupLanes(hn::LoadU(d, z + base), idx);
  } else {
    const auto idx = hn::BitCast(di64, hn::PromoteTo(du64, rows));
    xi = hn::GatherIndex(d, x, idx);
    yi = hn::GatherIndex(d, y, idx);
    zi = hn::GatherIndex(d, z, idx);
  }
  const auto jdx = hn::BitCast(di64, hn::PromoteTo(du64, j));
  const auto xj = hn::GatherIndex(d, x, jdx);
  const auto yj = hn::GatherIndex(d, y, jdx);
  const auto zj = hn::GatherIndex(d, z, jdx);
  const auto dx = hn::Sub(xi, xj);
  const auto dy = hn::Sub(yi, yj);
  auto dz = hn::Sub(zi, zj);
  if constexpr (Periodic) {  // the nearest image: Round is nearbyint in the default mode
    dz = hn::Sub(dz, hn::Mul(per, hn::Round(hn::Div(dz, per))));
  }
  // Touching: dx^2 + dy^2 + dz^2 < (r_i + r_j)^2, summed left to right as the portable
  // search does; a NaN does not touch.
  const auto d2 = hn::Add(hn::Add(hn::Mul(dx, dx), hn::Mul(dy, dy)), hn::Mul(dz, dz));
  const auto touch = hn::And(live, hn::Lt(d2, within2));
  // The index vectors have lanes half as wide as the doubles: they take the mask as bits.
  std::uint8_t bits[(max_search_lanes + 7) / 8];
  hn::StoreMaskBits(d, touch, bits);
  const auto touch_u = hn::LoadMaskBits(du, bits);  // the same mask, in the index lanes
  pack_store(du, rows, touch_u, bits, out.i + size);
  pack_store(du, j, touch_u, bits, out.j + size);
  pack_store(du, slots, touch_u, bits, out.slot + size);
  pack_store(d, dx, touch, bits, out.dx + size);
  pack_store(d, dy, touch, bits, out.dy + size);
  pack_store(d, dz, touch, bits, out.dz + size);
  return hn::CountTrue(d, touch);
}

/// The wide search (touching_pairs.hpp, TouchingPairsSearch), N = Lanes(d) listed pairs at a
/// time.
template <bool Periodic, bool Prefetch>
std::size_t touching_pairs_wide(std::size_t first_row, std::size_t end_row,
                                const std::uint32_t* start, const std::uint32_t* partner,
                                const double* x, const double* y, const double* z,
                                const double* within2, std::size_t n, double period,
                                std::uint32_t* slot_row, const TouchingPairs& out,
                                const PartnerPrefetch& ahead) {
  const hn::ScalableTag<double> d;                  // the positions, N lanes
  const hn::Rebind<std::uint32_t, decltype(d)> du;  // the indices, as many lanes
  const std::size_t lanes = hn::Lanes(d);
  const std::uint32_t s0 = start[first_row];
  const std::uint32_t listed = start[end_row] - s0;
  // Each listed pair's row, N at a time: an empty row writes N that the next row overwrites.
  for (std::size_t i = first_row; i < end_row; ++i) {
    const auto row = hn::Set(du, static_cast<std::uint32_t>(i));
    std::uint32_t s = start[i] - s0;
    const std::uint32_t row_end = start[i + 1] - s0;
    do {
      hn::StoreU(row, du, slot_row + s);
      s += static_cast<std::uint32_t>(lanes);
    } while (s < row_end);
  }
  const auto per = hn::Set(d, period);
  const auto lane = hn::Iota(du, 0);
  std::size_t size = 0;
  // All listed pairs, read once: the stores to `out` below may alias `start` for the compiler.
  [[maybe_unused]] const std::uint32_t listed_all = start[n];
  // The block's last partial vector of partners, padded with particle 0 (read, never kept).
  HWY_ALIGN std::uint32_t tail[max_search_lanes] = {};
  for (std::uint32_t s = 0; s < listed; s += static_cast<std::uint32_t>(lanes)) {
    if constexpr (Prefetch) {
      const std::uint32_t list_at = s0 + s + PartnerPrefetch::list_ahead;
      hwy::Prefetch(partner + std::min(list_at, listed_all));
      const std::uint32_t q0 = s0 + s + PartnerPrefetch::pair_ahead;
      const std::uint32_t q1 = std::min(q0 + static_cast<std::uint32_t>(lanes), listed_all);
      for (std::uint32_t q = q0; q < q1; ++q) {
        const std::uint32_t j = partner[q];
        for (std::size_t a = 0; a < PartnerPrefetch::count; ++a)
          hwy::Prefetch(ahead.arrays[a] + j);
      }
    }
    const std::size_t live_count = std::min<std::size_t>(lanes, listed - s);
    const std::uint32_t* js = partner + s0 + s;
    if (live_count < lanes) {
      std::copy(js, js + live_count, tail);
      js = tail;
    }
    const auto rows = hn::IfThenElse(hn::FirstN(du, live_count), hn::LoadU(du, slot_row + s),
                                     hn::Set(du, slot_row[s]));
    size += test_and_pack<Periodic>(d, du, rows, hn::LoadU(du, js),
                                    hn::Add(hn::Set(du, s0 + s), lane),
                                    hn::LoadU(d, within2 + s), hn::FirstN(d, live_count),
                                    x, y, z, n, per, out, size);
  }
  return size;
}

/// The wide search over packed pairs (touching_pairs.hpp, TouchingEntriesSearch), N =
/// Lanes(d) at a time.
template <bool Periodic, bool Prefetch>
std::size_t touching_entries_wide(std::size_t count, const std::uint32_t* row,
                                  const std::uint32_t* partner, const std::uint32_t* slot,
                                  const double* touch2, const double* x, const double* y,
                                  const double* z, std::size_t n, double period,
                                  const TouchingPairs& out, const PartnerPrefetch& ahead) {
  const hn::ScalableTag<double> d;
  const hn::Rebind<std::uint32_t, decltype(d)> du;
  const std::size_t lanes = hn::Lanes(d);
  const auto per = hn::Set(d, period);
  std::size_t size = 0;
  for (std::size_t s = 0; s < count; s += lanes) {
    if constexpr (Prefetch) {
      const std::size_t q1 = std::min(s + PartnerPrefetch::pair_ahead + lanes, count);
      for (std::size_t q = s + PartnerPrefetch::pair_ahead; q < q1; ++q)
        for (std::size_t a = 0; a < PartnerPrefetch::count; ++a)
          hwy::Prefetch(ahead.arrays[a] + partner[q]);
    }
    const std::size_t live_count = std::min(lanes, count - s);
    const auto rows = hn::IfThenElse(hn::FirstN(du, live_count), hn::LoadU(du, row + s),
                                     hn::Set(du, row[s]));
    size += test_and_pack<Periodic>(d, du, rows, hn::LoadU(du, partner + s),
                                    hn::LoadU(du, slot + s), hn::LoadU(d, touch2 + s),
                                    hn::FirstN(d, live_count), x, y, z, n, per, out, size);
  }
  return size;
}

/// The four variants of each wide search, [periodic][prefetch].
struct WideSearches {
  TouchingPairsSearch of[2][2] = {
      {&touching_pairs_wide<false, false>, &touching_pairs_wide<false, true>},
      {&touching_pairs_wide<true, false>, &touching_pairs_wide<true, true>}};
  TouchingEntriesSearch entries[2][2] = {
      {&touching_entries_wide<false, false>, &touching_entries_wide<false, true>},
      {&touching_entries_wide<true, false>, &touching_entries_wide<true, true>}};
};

}  // namespace millscope::engine::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // per-target include guard
