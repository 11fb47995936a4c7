// The step loop of a kernel (Engine::Access::run): one OpenMP team per call, the stages in
// order with two barriers per step, and the list's upkeep (rebuild, lifter refresh) between
// them. Included by the src/engine_law_*.cpp files that instantiate the kernels.
#pragma once

#include <omp.h>

#include <stdexcept>

#include "step/close.hpp"
#include "step/context.hpp"
#include "step/ended_springs.hpp"
#include "step/kick_drift.hpp"
#include "step/list_upkeep.hpp"
#include "step/pair_pass.hpp"
#include "step/particle_pass.hpp"

namespace millscope::engine {

template <class Law, bool OneMaterial, bool Lifters, bool EndWalls, bool Tally>
void Engine::Access::run(Engine& e, long steps, StepObserver* observer) {
  using Kernel = Step<Shape<Law, OneMaterial, Lifters, EndWalls, Tally>>;
  if (e.buffer_width_ != Kernel::width ||
      (Kernel::dissipates && e.dissipative_.size() != 6 * e.n_))
    throw std::logic_error("the engine's pair buffers do not fit its step kernel");
  Kernel step(e, observer);
  if (e.list_.builds() == 0) rebuild(e);
  if constexpr (Lifters) e.lifter_angles_.update(e.config_.geometry, e.theta_);
  step.run(steps);
  if (!step.error.empty()) throw std::runtime_error(step.error);
}

// Two barriers per step. A step's particle pass and the next step's kick and drift touch only
// the share's own particles, so they need none between them; the step is closed (torque,
// ledger, observer, guards) after the next step's first barrier, from its set of partials.
//
// The work is split into `team` shares (the engine's threads); each stage of a share reads
// and writes only what that share owns until the next barrier, and the partials are summed
// in share order. The shares are run by e.running_threads_ threads (or fewer, if OpenMP
// grants fewer), thread w taking shares w, w + W, ...: a thread running several shares runs
// them in turn, stage by stage, and the results are the same to the bit.
template <class S>
void Engine::Access::Step<S>::run(long steps) {
  const long first_step = e.step_;  // the step count when this call began
#pragma omp parallel num_threads(e.running_threads_)
  {
    const int w = omp_get_thread_num();
    const int workers = omp_get_num_threads();
    const bool master = w == 0;
    // Runs a stage for each share of this thread, in share order.
    const auto each_share = [&](auto&& stage) {
      for (int t = w; t < team; t += workers) stage(t);
    };
    if constexpr (in_lanes) {
      each_share([&](int t) {
        batches[static_cast<std::size_t>(t)] = std::make_unique<ContactBatch>();
        wall_batches[static_cast<std::size_t>(t)] = std::make_unique<WallBatch>(particle_chunk);
        near_pairs[static_cast<std::size_t>(t)] = std::make_unique<NearPairs>();
      });
    }
    bool failed = false;  // the same in every thread
    NearWatch near{{true, e.near_gap_}};  // the wide search's near pairs (near_pairs.hpp)
    if (!e.forces_valid_) {
      near.build = e.list_.builds();
      // The forces of the initial state; the tangential history does not advance.
      StepPartial* const parts = partials_of(-1);
      each_share([&](int t) {
        parts[t] = StepPartial{};
        pair_pass(t, 0.0, near.look, parts[t]);
      });
#pragma omp barrier
      each_share([&](int t) { particle_pass(t, 0.0, false, parts[t]); });
#pragma omp barrier
      failed = close_step(parts, 0.0, master, first_step);
      if (master && !failed) e.forces_valid_ = true;
#pragma omp barrier
    }
    // Every thread follows the drum angle and the angle of the last lifter refresh itself, so
    // that the decisions below need no shared write.
    double theta = e.theta_, reach_theta = e.reach_theta_;
    for (long s = 0; !failed; ++s) {
      StepPartial* const parts = partials_of(s);
      // The state guards look at every guard_interval-th step of the engine's count and at the
      // last step of the call; rebuild and refresh_walls look before they bin the particles.
      const bool guarded = (first_step + s + 1) % guard_interval == 0 || s + 1 == steps;
      if (s < steps) {
        each_share([&](int t) {
          parts[t] = StepPartial{};
          if (guarded) {
            kick_drift<true>(t, parts[t]);
          } else {
            kick_drift<false>(t, parts[t]);
          }
        });
      }
#pragma omp barrier
      // Every particle has drifted and the step before is complete: close it.
      if (s > 0 && close_step(partials_of(s - 1), dt, master, first_step + s)) break;
      if (s == steps) break;
      theta += e.omega_ * dt;
      if (!list_upkeep(w, workers, parts, guarded, first_step + s + 1, theta, reach_theta))
        break;
      near_renewal(parts, near);
      each_share([&](int t) { pair_pass(t, dt, near.look, parts[t]); });
#pragma omp barrier
      each_share([&](int t) { particle_pass(t, dt, true, parts[t]); });
    }
    if (master) e.near_gap_ = near.look.gap;  // where the next call starts; no thread reads it now
  }
}

// Whether the wide search looks again for its near pairs before this step's pair pass
// (near_pairs.hpp), from the step's partials: after a list build, or before a pair farther
// than the gap when they were found may touch, twice the farthest any particle may have
// moved since (the margin covers the rounding of the drifts' sums). The gap doubles, up to
// the skin, where the search looked again within steps_low steps, and halves where it waited
// more than steps_high. Every thread calls it and decides alike.
template <class S>
void Engine::Access::Step<S>::near_renewal(const StepPartial* parts, NearWatch& near) const {
  constexpr long steps_low = 4, steps_high = 32;
  constexpr double margin = 0.99;           // of the gap
  constexpr double least_gap = 1.0 / 64.0;  // of the skin
  double speed2 = 0.0;
  for (int b = 0; b < team; ++b) speed2 = std::max(speed2, parts[b].speed2);
  near.travel += std::sqrt(speed2) * dt;
  ++near.steps;
  const bool built = e.list_.builds() != near.build;
  NearLook& look = near.look;
  look.renew = built || !(2.0 * near.travel < margin * look.gap);
  if (!look.renew) return;
  if (!built) {
    const double skin = e.list_.skin();
    if (near.steps < steps_low) look.gap = std::min(2.0 * look.gap, skin);
    if (near.steps > steps_high) look.gap = std::max(0.5 * look.gap, least_gap * skin);
  }
  near.build = e.list_.builds();
  near.travel = 0.0;
  near.steps = 0;
}

/// The kernel of a law for the scene's shape, chosen once per engine.
template <class Law, bool Tally>
StepKernel select_shape(bool one_material, bool lifters, bool end_walls) {
  using A = Engine::Access;
  if (one_material) {
    if (lifters)
      return end_walls ? &A::run<Law, true, true, true, Tally> : &A::run<Law, true, true, false, Tally>;
    return end_walls ? &A::run<Law, true, false, true, Tally> : &A::run<Law, true, false, false, Tally>;
  }
  if (lifters)
    return end_walls ? &A::run<Law, false, true, true, Tally> : &A::run<Law, false, true, false, Tally>;
  return end_walls ? &A::run<Law, false, false, true, Tally> : &A::run<Law, false, false, false, Tally>;
}

/// ... and whether it books the dissipated energy (only a law that dissipates has two).
template <class Law>
StepKernel select_kernel(bool one_material, bool lifters, bool end_walls, bool track_energy) {
  if constexpr (Law::dissipates) {
    if (track_energy) return select_shape<Law, true>(one_material, lifters, end_walls);
  }
  (void)track_energy;
  return select_shape<Law, false>(one_material, lifters, end_walls);
}

}  // namespace millscope::engine
