// Loops written for SIMD lanes (`omp simd`) are compiled twice where the loader can choose by
// the CPU (GCC or Clang, x86-64 Linux): for AVX2, four doubles to a register, and for the
// x86-64 baseline, SSE2 and two. AVX2 alone brings no fused multiply-add, so both give the
// same bits. Put MILLSCOPE_LANE_TARGETS before such a function.
#pragma once

#if defined(__x86_64__) && defined(__linux__) && (defined(__GNUC__) || defined(__clang__))
#define MILLSCOPE_LANE_TARGETS __attribute__((target_clones("avx2", "default")))
#else
#define MILLSCOPE_LANE_TARGETS
#endif
