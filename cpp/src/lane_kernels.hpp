// The engine's vector kernels for one SIMD path, chosen when an Engine is made: the widest the
// CPU runs, or the one asked for (Config::simd, or the environment's MILLSCOPE_SIMD), so that
// tests can run every path a CPU has against the others. The kernels are compiled once per
// SIMD target by Google Highway (lane_kernels.cpp); every path computes the same bits.
#pragma once

#include <cstddef>
#include <string>

#include "millscope/engine.hpp"  // SimdPath, simd_paths
#include "step/contact_lanes.hpp"
#include "step/motion_lanes.hpp"
#include "touching_pairs.hpp"

namespace millscope::engine {

/// One SIMD path's kernels.
struct LaneKernels {
  SimdPath path;
  /// The wide search (touching_pairs.hpp), [periodic][prefetch]; null for the portable search.
  TouchingPairsSearch touching_pairs[2][2] = {};
  /// ... and over packed pairs (the near pairs), [periodic][prefetch]; null with the other.
  TouchingEntriesSearch touching_entries[2][2] = {};
  /// The paper's law for a block of contacts, and for a chunk's contacts with the drum
  /// (contact_lanes.hpp), [uniform]: [1] where every contact has the pair constants pairs[0]
  /// (one material in use), which the loop then need not read lane by lane.
  ContactForcesInLanes contact_forces[2] = {};
  WallForcesInLanes wall_forces[2] = {};
  /// The kicks and the drift (motion_lanes.hpp): [friction][periodic][guard] and [friction].
  KickDriftInLanes kick_drift[2][2][2] = {};
  HalfKickInLanes half_kick[2] = {};
};

/// The kernels of path `name`, as simd_path(name) chooses it.
const LaneKernels& lane_kernels(const std::string& name);

}  // namespace millscope::engine
