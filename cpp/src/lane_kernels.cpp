// The engine's vector kernels (lane_kernels.hpp), compiled once per SIMD target by Google
// Highway: foreach_target.h includes this file again for each target, and the kernels'
// -inl headers define them in that target's namespace: the engine's pair search, contact
// loop, kicks and drift, chosen per engine (lane_kernels.hpp), and the list build's squared
// test (neighbors::near_in_lanes), always in the widest lanes. Which targets: those that pay.
// - AVX-512 (Highway's AVX3) and AVX2: the wide search tests 8 or 4 listed pairs at once; the
//   contact loop computes 4 contacts in one instruction (AVX-512 takes the AVX2 build:
//   step/contact_lanes-inl.hpp).
// - The baseline build (x86-64: SSE2, Highway's static target): the contact loop's lanes for
//   the portable path (two contacts at once).
// - SSSE3 and SSE4 are left out: two doubles a vector are what the baseline already has for the
//   contact loop, and a search two pairs at a time is not worth its build time for the few
//   x86-64 CPUs without AVX2 (not measured). So are
//   Highway's AVX3_DL (Ice Lake's additions: nothing these kernels use) and the Arm SVE
//   variants fixed at 128 or 256 bits (SVE, which adapts to any width, is compiled). Every
//   target compiled costs build time.
// - On Arm, NEON (the baseline there), SVE and SVE2: not timed, checked for the same results
//   under emulation (benchmarks/arm_paths.sh).
#define HWY_DISABLED_TARGETS (HWY_SSSE3 | HWY_SSE4 | HWY_AVX3_DL | HWY_SVE_256 | HWY_SVE2_128)

#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "lane_kernels.cpp"
#include <hwy/foreach_target.h>  // must come before highway.h

#include <hwy/highway.h>

#include "lane_kernels.hpp"
#include "near_in_lanes-inl.hpp"
#include "step/contact_lanes-inl.hpp"
#include "step/motion_lanes-inl.hpp"
#include "touching_pairs-inl.hpp"

HWY_BEFORE_NAMESPACE();
namespace millscope::engine::HWY_NAMESPACE {

/// This target's kernels. Highway's emulated targets (EMU128, SCALAR: the static target where
/// the baseline has no vectors Highway uses) get no wide search: the portable one is faster.
LaneKernels kernels_of_target() {
  LaneKernels k;
  for (int uniform = 0; uniform < 2; ++uniform) {  // null: the next narrower path's (make_paths)
    k.contact_forces[uniform] = contact_loop[uniform];
    k.wall_forces[uniform] = wall_loop[uniform];
  }
  for (int friction = 0; friction < 2; ++friction) {
    k.half_kick[friction] = half_kick_loop[friction];
    for (int periodic = 0; periodic < 2; ++periodic)
      for (int guard = 0; guard < 2; ++guard)
        k.kick_drift[friction][periodic][guard] = kick_drift_loop[friction][periodic][guard];
  }
#if !(HWY_TARGET & (HWY_EMU128 | HWY_SCALAR))
  k.path.pair_lanes = hwy::HWY_NAMESPACE::Lanes(hwy::HWY_NAMESPACE::ScalableTag<double>());
  const WideSearches wide;
  for (int periodic = 0; periodic < 2; ++periodic)
    for (int prefetch = 0; prefetch < 2; ++prefetch) {
      k.touching_pairs[periodic][prefetch] = wide.of[periodic][prefetch];
      k.touching_entries[periodic][prefetch] = wide.entries[periodic][prefetch];
    }
#endif
  return k;
}

}  // namespace millscope::engine::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace millscope::engine {
namespace {

HWY_EXPORT(kernels_of_target);

/// Highway's name of a target in lower case, AVX3 called what the CPU calls it.
std::string path_name(std::int64_t target) {
  if (target == HWY_AVX3) return "avx512";
  std::string name = hwy::TargetName(target);
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return name;
}

/// Every path this build runs on this CPU, widest first, "portable" last. Each target's
/// kernels are taken from Highway's table (HWY_EXPORT) at the index its dispatch would use for
/// that target alone (a ChosenTarget of our own: Highway's process-wide one is left alone). A
/// target without its own contact loops takes the next narrower path's.
std::vector<LaneKernels> make_paths() {
  std::vector<LaneKernels> paths;
  for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
    hwy::ChosenTarget only;
    only.Update(target);
    LaneKernels k = HWY_DISPATCH_TABLE(kernels_of_target)[only.GetIndex()]();
    if (k.path.pair_lanes <= 1) continue;  // an emulated target: the portable path below
    k.path.name = path_name(target);
    paths.push_back(k);
  }
  LaneKernels portable = HWY_STATIC_DISPATCH(kernels_of_target)();
  portable.path = SimdPath{"portable", 1};
  for (auto& row : portable.touching_pairs) row[0] = row[1] = nullptr;
  for (auto& row : portable.touching_entries) row[0] = row[1] = nullptr;
  paths.push_back(portable);
  for (std::size_t p = paths.size() - 1; p-- > 0;) {
    for (int uniform = 0; uniform < 2; ++uniform) {
      auto& contact = paths[p].contact_forces[uniform];
      auto& wall = paths[p].wall_forces[uniform];
      if (contact == nullptr) contact = paths[p + 1].contact_forces[uniform];
      if (wall == nullptr) wall = paths[p + 1].wall_forces[uniform];
    }
  }
  return paths;
}

const std::vector<LaneKernels>& paths() {
  static const std::vector<LaneKernels> all = make_paths();  // the CPU does not change
  return all;
}

}  // namespace

std::vector<std::string> simd_paths() {
  std::vector<std::string> names;
  for (const LaneKernels& k : paths()) names.push_back(k.path.name);
  return names;
}

const LaneKernels& lane_kernels(const std::string& name) {
  const char* env = std::getenv("MILLSCOPE_SIMD");
  const bool from_env = name.empty() && env != nullptr && env[0] != '\0';
  const std::string wanted = from_env ? std::string(env) : name;
  if (wanted.empty()) return paths().front();
  for (const LaneKernels& k : paths())
    if (k.path.name == wanted) return k;
  std::ostringstream msg;
  msg << (from_env ? "MILLSCOPE_SIMD" : "simd") << " = '" << wanted
      << "' is not a SIMD path this build runs on this CPU; it must be one of:";
  for (const LaneKernels& k : paths()) msg << " '" << k.path.name << "'";
  msg << (from_env ? ", or unset or empty for the widest" : ", or '' for the default");
  throw std::invalid_argument(msg.str());
}

SimdPath simd_path(const std::string& name) { return lane_kernels(name).path; }

}  // namespace millscope::engine

namespace millscope::neighbors {

HWY_EXPORT(near_in_lanes);

void near_in_lanes(double xi, double yi, double zi, double ri, double skin, const double* x,
                   const double* y, const double* z, const double* r, std::size_t m,
                   unsigned char* near) {
  HWY_DYNAMIC_DISPATCH(near_in_lanes)(xi, yi, zi, ri, skin, x, y, z, r, m, near);
}

}  // namespace millscope::neighbors
#endif  // HWY_ONCE
