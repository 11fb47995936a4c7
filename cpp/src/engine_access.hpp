// Engine::Access: the engine's private state as the step kernels and the list upkeep of
// engine.cpp reach it. Private to the library (included by engine.cpp and src/step/).
#pragma once

#include <string>

#include "millscope/engine.hpp"

namespace millscope::engine {

struct Engine::Access {
  /// The step of a kernel's shape (src/step/): its context and its stages.
  template <class Shape>
  struct Step;

  template <class Law, bool OneMaterial, bool Lifters, bool EndWalls, bool Tally>
  static void run(Engine& e, long steps, StepObserver* observer);

  static void rebuild(Engine& e);  // by one thread
  // ... in parallel: rebuild_begin by one thread, the list's find_rows, size_rows and
  // place_rows phases, then rebuild_end by one thread (src/step/run.hpp)
  static void rebuild_begin(Engine& e, int team);
  static void rebuild_end(Engine& e);
  static void refresh_walls(Engine& e);
  static void list_touch_distances(Engine& e);
  static void split_rows(Engine& e);
  static void split_particles(Engine& e);
  static std::string describe_bad(const Engine& e, std::size_t i);
  static std::string describe_overlap(const Engine& e, std::size_t i, double ratio, bool wall);
};

}  // namespace millscope::engine
