// Stage: closing a step (Engine::Access::Step): torque, ledger, observer and guards.
#pragma once

#include "step/context.hpp"

namespace millscope::engine {

// Closes a step from its partials, summed in thread order (reproducible): every thread calls
// it and reaches the same verdict (true: stop); the master thread alone books the torque and
// the ledger, tells the observer and writes the error.
template <class S>
bool Engine::Access::Step<S>::close_step(const StepPartial* parts, double ledger_dt, bool master,
                                         long step) {
  Torque tq;
  double damping = 0.0, friction_loss = 0.0, shift = 0.0, loss = 0.0, spring_work = 0.0;
  std::size_t bad = std::numeric_limits<std::size_t>::max();
  const StepPartial* deepest = nullptr;  // the deepest contact beyond max_overlap
  for (int b = 0; b < team; ++b) {
    const StepPartial& p = parts[b];
    if (p.deepest_ratio > (deepest ? deepest->deepest_ratio : 0.0)) deepest = &p;
    tq.shell += p.shell;
    tq.lifters += p.lifters;
    tq.ends += p.ends;
    damping += p.damping_power;
    friction_loss += p.friction_loss;
    shift += p.dissipation_shift;
    spring_work += p.spring_work;
    loss += p.loss;
    bad = std::min(bad, p.bad);
  }
  tq.total = tq.shell + tq.lifters + tq.ends;
  if (master) {
    e.torque_ = tq;
    e.ledger_.drive_work += e.omega_ * tq.total * ledger_dt;
    e.ledger_.damping_loss += damping * ledger_dt;
    if (ledger_dt > 0.0 && Law::dissipates && !Tally) {
      // not booked: unknown from here on
      e.ledger_.damping_loss = e.ledger_.friction_loss = e.ledger_.dissipated =
          e.ledger_.spring_work = std::numeric_limits<double>::quiet_NaN();
    } else if (ledger_dt > 0.0) {
      e.ledger_.friction_loss += friction_loss;
      e.ledger_.dissipated += loss + shift;
      e.ledger_.spring_work += spring_work;
    }
    if (observer != nullptr && ledger_dt > 0.0) observer->after_step(step, tq);
  }
  if (bad != std::numeric_limits<std::size_t>::max()) {
    if (master) error = describe_bad(e, bad);
    return true;
  }
  if (deepest != nullptr) {
    if (master)
      error = describe_overlap(e, deepest->deepest, deepest->deepest_ratio,
                               deepest->deepest_at_wall);
    return true;
  }
  return false;
}

}  // namespace millscope::engine
