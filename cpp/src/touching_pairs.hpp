// The first phase of the engine's pair pass, in AVX-512 registers: which listed pairs of a
// block of Verlet list rows touch (|x_i - x_j| < r_i + r_j), packed in list order.
//
// The portable search in the engine (step/pair_pass_lanes.hpp) tests one listed
// pair at a time and branches on the answer; a third of the pairs touch, so the branch is
// mispredicted about once a row, and each test waits on its own loads. Here 8 listed pairs are
// tested at once: the partners' positions and radii gathered, the rows' read with two loads
// and a permute, and the touching pairs packed by the registers' compress, without a branch.
// The arithmetic is the portable search's, operation for operation (the build keeps the
// compiler from fusing a multiply and an add: -ffp-contract=off), so the same pairs touch and
// the same differences x_i - x_j are kept, to the bit.
//
// Compiled for AVX-512 (F, VL) on x86-64 with GCC or Clang, and taken where the CPU has it
// (wide_pairs_supported); elsewhere MILLSCOPE_WIDE_PAIRS is 0 and only the portable search
// exists.
#pragma once

#include <cstddef>
#include <cstdint>

#include "millscope/engine.hpp"  // wide_block_listed, wide_pairs_supported

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define MILLSCOPE_WIDE_PAIRS 1
#include <immintrin.h>
#else
#define MILLSCOPE_WIDE_PAIRS 0
#endif

namespace millscope::engine {

/// Where touching_pairs_wide writes the touching pairs: row i, partner j, list slot, and
/// x_i - x_j (m), one entry per pair. Each array needs room for 8 entries beyond the last pair
/// it can receive (whole registers are stored).
struct TouchingPairs {
  std::uint32_t* i;
  std::uint32_t* j;
  std::uint32_t* slot;
  double* dx;
  double* dy;
  double* dz;
};

/// What touching_pairs_wide asks for ahead of its reads, where the engine's data do not fit the
/// caches (Engine::prefetch_partners). A row's partners lie just after it or about a row of
/// cells further on (200-250 particles in the slices), and their state is read through the
/// list, which the hardware's prefetchers cannot follow. So at each 8 listed pairs the search
/// asks for the state of the partners `pair_ahead` pairs on, and for the list `list_ahead`
/// pairs on, so that the partners' indices are at hand when their turn comes. Asking does not
/// change what is computed. Both are needed: the partners' state alone waits on list entries
/// that are not in the cache yet, and the list alone does not bring the state. Every array the
/// pair pass reads for a partner is asked for (positions, radii, velocities, spins, inverse
/// masses).
/// The arrays are a fixed count, so that the loop over them unrolls.
struct PartnerPrefetch {
  static constexpr std::size_t count = 11;
  const double* arrays[count];  // per-particle arrays to ask for, at partner j's entry
  static constexpr std::uint32_t list_ahead = 2048;  // listed pairs
  static constexpr std::uint32_t pair_ahead = 256;   // listed pairs
};

#if MILLSCOPE_WIDE_PAIRS
/// The touching pairs of the Verlet list rows [first_row, end_row) (half list: row i's partners
/// partner[start[i]..start[i + 1])), in list order, into `out`; returns how many. x, y, z
/// (m) and r (m) hold the n particles. Periodic: z differences wrap by `period` (m), as
/// dz - period * nearbyint(dz / period). `slot_row` is scratch for the rows' listed pairs,
/// with room for 8 beyond them. With Prefetch, asks for what `ahead` names as it goes.
template <bool Periodic, bool Prefetch>
__attribute__((target("avx512f,avx512vl"))) inline std::size_t touching_pairs_wide(
    std::size_t first_row, std::size_t end_row, const std::uint32_t* start,
    const std::uint32_t* partner, const double* x, const double* y, const double* z,
    const double* r, std::size_t n, double period, std::uint32_t* slot_row,
    const TouchingPairs& out, const PartnerPrefetch& ahead) {
  const std::uint32_t s0 = start[first_row];
  const std::uint32_t listed = start[end_row] - s0;
  // Each listed pair's row, 8 at a time: an empty row writes 8 that the next row overwrites.
  for (std::size_t i = first_row; i < end_row; ++i) {
    const __m256i row = _mm256_set1_epi32(static_cast<int>(i));
    std::uint32_t s = start[i] - s0;
    const std::uint32_t row_end = start[i + 1] - s0;
    do {
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(slot_row + s), row);
      s += 8;
    } while (s < row_end);
  }
  const __m512d zero = _mm512_setzero_pd();
  const __m512d per = _mm512_set1_pd(period);
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i sixteen = _mm256_set1_epi32(16);
  std::size_t size = 0;
  // All listed pairs, read once: the stores to `out` below may alias `start` for the compiler.
  [[maybe_unused]] const std::uint32_t listed_all = start[n];
  for (std::uint32_t s = 0; s < listed; s += 8) {
    if constexpr (Prefetch) {
      const std::uint32_t list_at = s0 + s + PartnerPrefetch::list_ahead;
      __builtin_prefetch(partner + (list_at < listed_all ? list_at : listed_all), 0, 3);
      const std::uint32_t q0 = s0 + s + PartnerPrefetch::pair_ahead;
      const std::uint32_t q1 = q0 + 8 < listed_all ? q0 + 8 : listed_all;
      for (std::uint32_t q = q0; q < q1; ++q) {
        const std::uint32_t j = partner[q];
        for (std::size_t a = 0; a < PartnerPrefetch::count; ++a)
          __builtin_prefetch(ahead.arrays[a] + j, 0, 3);
      }
    }
    const __mmask8 live =
        listed - s >= 8 ? __mmask8(0xFF) : static_cast<__mmask8>((1u << (listed - s)) - 1u);
    const __m256i j = _mm256_maskz_loadu_epi32(live, partner + s0 + s);
    // The rows' values. A list row's partners follow it closely, so 8 listed pairs mostly
    // belong to rows within 16 particles of the first: two loads and a permute. Else (empty
    // rows between them, or the array's end) a gather.
    const std::uint32_t base = slot_row[s];
    const __m256i base8 = _mm256_set1_epi32(static_cast<int>(base));
    const __m256i rows = _mm256_mask_loadu_epi32(base8, live, slot_row + s);
    const __m256i rel = _mm256_sub_epi32(rows, base8);
    __m512d xi, yi, zi, ri;
    if (base + 16 <= n && _mm256_cmplt_epu32_mask(rel, sixteen) == 0xFF) {
      const __m512i idx = _mm512_maskz_cvtepu32_epi64(0xFF, rel);
      xi = _mm512_permutex2var_pd(_mm512_loadu_pd(x + base), idx, _mm512_loadu_pd(x + base + 8));
      yi = _mm512_permutex2var_pd(_mm512_loadu_pd(y + base), idx, _mm512_loadu_pd(y + base + 8));
      zi = _mm512_permutex2var_pd(_mm512_loadu_pd(z + base), idx, _mm512_loadu_pd(z + base + 8));
      ri = _mm512_permutex2var_pd(_mm512_loadu_pd(r + base), idx, _mm512_loadu_pd(r + base + 8));
    } else {
      xi = _mm512_mask_i32gather_pd(zero, 0xFF, rows, x, 8);
      yi = _mm512_mask_i32gather_pd(zero, 0xFF, rows, y, 8);
      zi = _mm512_mask_i32gather_pd(zero, 0xFF, rows, z, 8);
      ri = _mm512_mask_i32gather_pd(zero, 0xFF, rows, r, 8);
    }
    const __m512d xj = _mm512_mask_i32gather_pd(zero, live, j, x, 8);
    const __m512d yj = _mm512_mask_i32gather_pd(zero, live, j, y, 8);
    const __m512d zj = _mm512_mask_i32gather_pd(zero, live, j, z, 8);
    const __m512d rj = _mm512_mask_i32gather_pd(zero, live, j, r, 8);
    const __m512d dx = _mm512_sub_pd(xi, xj);
    const __m512d dy = _mm512_sub_pd(yi, yj);
    __m512d dz = _mm512_sub_pd(zi, zj);
    if constexpr (Periodic) {  // the nearest image: nearbyint rounds in the current mode
      const __m512d k = _mm512_maskz_roundscale_pd(
          0xFF, _mm512_div_pd(dz, per), _MM_FROUND_CUR_DIRECTION | _MM_FROUND_NO_EXC);
      dz = _mm512_sub_pd(dz, _mm512_mul_pd(per, k));
    }
    // Touching: dx^2 + dy^2 + dz^2 < (r_i + r_j)^2, summed left to right as the portable
    // search does; a NaN does not touch.
    const __m512d r_sum = _mm512_add_pd(ri, rj);
    const __m512d d2 = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(dx, dx), _mm512_mul_pd(dy, dy)),
                                     _mm512_mul_pd(dz, dz));
    const __mmask8 touch =
        _mm512_mask_cmp_pd_mask(live, d2, _mm512_mul_pd(r_sum, r_sum), _CMP_LT_OQ);
    const __m256i slots = _mm256_add_epi32(_mm256_set1_epi32(static_cast<int>(s0 + s)), lane);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out.i + size),
                        _mm256_maskz_compress_epi32(touch, rows));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out.j + size),
                        _mm256_maskz_compress_epi32(touch, j));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out.slot + size),
                        _mm256_maskz_compress_epi32(touch, slots));
    _mm512_storeu_pd(out.dx + size, _mm512_maskz_compress_pd(touch, dx));
    _mm512_storeu_pd(out.dy + size, _mm512_maskz_compress_pd(touch, dy));
    _mm512_storeu_pd(out.dz + size, _mm512_maskz_compress_pd(touch, dz));
    size += static_cast<std::size_t>(__builtin_popcount(touch));
  }
  return size;
}
#endif

}  // namespace millscope::engine
