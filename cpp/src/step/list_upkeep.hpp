// Stage: the upkeep between a step's drift and its pair pass (Engine::Access::Step): the
// drum's angle and step count, and when due the neighbour list's rebuild (in parallel) or the
// lifter refresh, after the state guards. Called by every thread of the team.
#pragma once

#include "step/context.hpp"

namespace millscope::engine {

// w: this thread of the `workers` that run the shares (run.hpp); theta: the drum's angle after
// this step; reach_theta: the angle of the last lifter refresh (every thread follows both
// itself, so that the decisions need no shared write); step: the engine's step count after
// this step. Returns false when the run must stop (error is set).
template <class S>
bool Engine::Access::Step<S>::list_upkeep(int w, int workers, const StepPartial* parts,
                                          bool guarded, long step, double theta,
                                          double& reach_theta) {
  double move2 = 0.0;
  std::size_t bad = std::numeric_limits<std::size_t>::max();
  for (int b = 0; b < team; ++b) {
    move2 = std::max(move2, parts[b].displacement2);
    bad = std::min(bad, parts[b].bad);
  }
  const bool rebuild_now = move2 > skin_half2;
  // The lifters have moved as far as the particles may: look again which are near.
  const bool refresh_now =
      Lifters && !rebuild_now && geom.radius * std::abs(theta - reach_theta) > lifter_drift;
  if (bad != std::numeric_limits<std::size_t>::max() || rebuild_now || refresh_now) {
#pragma omp single
    {
      e.theta_ = theta;
      e.step_ = step;
      if constexpr (Lifters) e.lifter_angles_.update(geom, e.theta_);
      if (bad == std::numeric_limits<std::size_t>::max() && !guarded) {
        // not looked at this step: a non-finite or stray position must not be binned
        for (std::size_t i = 0; i < n; ++i) {
          if (!sound(i)) {
            bad = i;
            break;
          }
        }
      }
      if (bad != std::numeric_limits<std::size_t>::max()) {
        error = describe_bad(e, bad);
      } else if (rebuild_now) {
        rebuild_begin(e, team);
      } else {
        refresh_walls(e);
      }
    }
    if (!error.empty()) return false;
    if (rebuild_now) {  // each share's thread finds the partners of its block of rows
      for (int t = w; t < team; t += workers) e.list_.find_rows(x, y, z, r, t, team);
#pragma omp barrier
#pragma omp single
      e.list_.size_rows();
      for (int t = w; t < team; t += workers) e.list_.place_rows(t, team);
#pragma omp barrier
#pragma omp single
      rebuild_end(e);
    }
    reach_theta = theta;
  } else if (w == 0) {
    // Read by nobody before the barrier after the pair pass.
    e.theta_ = theta;
    e.step_ = step;
    if constexpr (Lifters) e.lifter_angles_.update(geom, e.theta_);
  }
  return true;
}

}  // namespace millscope::engine
