// The loop of neighbors::near_in_lanes (millscope/neighbors.hpp), compiled for each SIMD target
// lane_kernels.cpp names (foreach_target.h includes this file once per target). Not for other
// files.

// Per-target include guard: Highway toggles HWY_TARGET_TOGGLE for each target it compiles.
#if defined(MILLSCOPE_NEAR_IN_LANES_INL_) == defined(HWY_TARGET_TOGGLE)
#ifdef MILLSCOPE_NEAR_IN_LANES_INL_
#undef MILLSCOPE_NEAR_IN_LANES_INL_
#else
#define MILLSCOPE_NEAR_IN_LANES_INL_
#endif

#include <hwy/highway.h>

#include <cstddef>

#include "millscope/neighbors.hpp"

HWY_BEFORE_NAMESPACE();
namespace millscope::neighbors::HWY_NAMESPACE {

/// neighbors::near_in_lanes, written as a loop the compiler computes in this target's lanes
/// (`omp simd`).
void near_in_lanes(double xi, double yi, double zi, double ri, double skin, const double* x,
                   const double* y, const double* z, const double* r, std::size_t m,
                   unsigned char* near) {
#pragma omp simd
  for (std::size_t k = 0; k < m; ++k) {
    const double sx = xi - x[k], sy = yi - y[k], sz = zi - z[k];
    const double far = squared_test_reach(ri, r[k], skin);
    near[k] = sx * sx + sy * sy + sz * sz < far * far;
  }
}

}  // namespace millscope::neighbors::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // per-target include guard
