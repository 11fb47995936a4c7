// Stage: the first half kick and the drift of thread t's particles (Engine::Access::Step).
#pragma once

#include "step/context.hpp"

namespace millscope::engine {

// Particles [lo, hi) of particle_split_, in the SIMD path's lanes (motion_lanes-inl.hpp):
// v += (F / m) dt/2, w += (T / I) dt/2, x += v dt. Tracks the largest move since the list
// build and the largest speed of the drift and, with Guard, guards the new state (see sound).
template <class S>
template <bool Guard>
void Engine::Access::Step<S>::kick_drift(int t, StepPartial& part) {
  const std::size_t lo = e.particle_split_[static_cast<std::size_t>(t)];
  const std::size_t hi = e.particle_split_[static_cast<std::size_t>(t) + 1];
  const DriftFound found = lanes.kick_drift[friction][!EndWalls][Guard](motion, lo, hi, drift);
  part.displacement2 = found.move2;
  part.speed2 = found.speed2;
  if (Guard && !found.sound) {  // rare: find the first particle that failed
    for (std::size_t i = lo; i < hi && part.bad == std::numeric_limits<std::size_t>::max(); ++i)
      if (!sound(i)) part.bad = i;
  }
}

}  // namespace millscope::engine
