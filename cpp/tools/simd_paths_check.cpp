// Runs small scenes on every SIMD path this CPU runs (engine::simd_paths()) and checks that
// they all end in the same state, to the bit: the engine's promise that a path changes the
// speed and never the result. The Python tests check it where the package runs
// (tests/test_simd_paths.py); this program, linked against the core library alone, checks it
// where only a cross-compiled core runs, e.g. Arm's NEON, SVE and SVE2 paths under emulation
// (benchmarks/arm_paths.sh). It prints one fingerprint per scene and path and exits with 1
// when the paths of a scene disagree, 0 otherwise.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

#include "millscope/engine.hpp"

namespace {

namespace en = millscope::engine;

/// FNV-1a over the bytes of doubles: a fingerprint that any changed bit changes.
class Fingerprint {
 public:
  void add(const std::vector<double>& values) {
    for (double v : values) {
      unsigned char bytes[sizeof v];
      std::memcpy(bytes, &v, sizeof v);
      for (unsigned char b : bytes) hash_ = (hash_ ^ b) * 0x100000001b3ULL;
    }
  }
  std::uint64_t value() const { return hash_; }

 private:
  std::uint64_t hash_ = 0xcbf29ce484222325ULL;
};

/// A small mill and where its balls start.
struct Scene {
  en::Config config;
  std::vector<double> xyz;  // n x 3, m
};

/// Steel balls (and, with `two_materials`, every other one ceramic) of radius 10 or 12 mm on
/// a lattice in the lower half of a drum of radius 0.2 m and length 0.1 m with 8 lifters, and
/// periodic ends or end walls.
Scene small_mill(bool end_walls, bool two_materials, int threads, const std::string& path) {
  Scene s;
  en::Config& c = s.config;
  c.materials = {{7800.0, 8.0e7, 0.3}, {3600.0, 1.2e8, 0.22}};  // softened 1000 x
  c.restitution = {0.5, 0.6, 0.6, 0.7};
  c.friction = {0.3, 0.35, 0.35, 0.4};
  c.geometry = {0.2, 0.1, end_walls, 8, 0.03, 0.02, 0.0};
  const double pitch = 0.026;  // m: no two balls overlap at the start
  for (double x = -0.16; x <= 0.16; x += pitch)
    for (double y = -0.16; y <= 0.0; y += pitch)
      for (double z = 0.015; z <= 0.085; z += pitch) {
        if (x * x + y * y > 0.15 * 0.15) continue;
        const std::size_t k = c.radius.size();
        c.radius.push_back(k % 3 == 0 ? 0.012 : 0.010);
        c.material.push_back(two_materials ? static_cast<int>(k % 2) : 0);
        s.xyz.insert(s.xyz.end(), {x, y, z});
      }
  c.dt = 2.0e-5;           // s, at most a tenth of either material's Rayleigh time
  c.track_energy = false;  // the paper's law in SIMD lanes
  c.threads = threads;
  c.simd = path;
  return s;
}

/// What a run ends with.
struct Outcome {
  std::uint64_t print;   // the fingerprint
  double overlap_ratio;  // the deepest contact at the end, of the smaller radius (> 0: touching)
};

/// A run: the balls fall for 6000 steps (0.12 s, onto the shell and the lifters), then the
/// drum turns at 2 rad/s for 4000 more; its fingerprint covers the torque's 100-step means and
/// the final positions, velocities and spins.
Outcome run(bool end_walls, bool two_materials, int threads, const std::string& path) {
  const Scene scene = small_mill(end_walls, two_materials, threads, path);
  en::Engine engine(scene.config);
  engine.set_positions(scene.xyz.data());
  constexpr long fall_steps = 6000, turn_steps = 4000;
  engine.advance(fall_steps);
  engine.start_rotation(2.0);
  Fingerprint print;
  print.add(engine.advance_sampled(100 * scene.config.dt, true, turn_steps / 100));
  print.add(engine.positions());
  print.add(engine.velocities());
  print.add(engine.spins());
  return {print.value(), engine.max_overlap_ratio()};
}

}  // namespace

int main(int argc, char** argv) {
  try {
    // The thread counts to run: the arguments, else 1 and 2.
    std::vector<int> thread_counts;
    for (int a = 1; a < argc; ++a) {
      char* end = nullptr;
      const long threads = std::strtol(argv[a], &end, 10);
      if (end == argv[a] || *end != '\0' || threads < 1 || threads > 64)
        throw std::invalid_argument(std::string("threads = ") + argv[a] +
                                    " is not valid; it must be an integer in [1, 64]");
      thread_counts.push_back(static_cast<int>(threads));
    }
    if (thread_counts.empty()) thread_counts = {1, 2};
    const std::vector<std::string> paths = en::simd_paths();
    bool agree = true;
    for (const bool end_walls : {false, true}) {
      for (const bool two_materials : {false, true}) {
        for (const int threads : thread_counts) {
          std::uint64_t first = 0;
          for (std::size_t p = 0; p < paths.size(); ++p) {
            const Outcome out = run(end_walls, two_materials, threads, paths[p]);
            if (p == 0) first = out.print;
            agree = agree && out.print == first;
            std::printf("%-10s %-13s %-14s threads=%d overlap=%.2e %016llx%s\n",
                        paths[p].c_str(), end_walls ? "end walls" : "periodic ends",
                        two_materials ? "two materials" : "one material", threads,
                        out.overlap_ratio, static_cast<unsigned long long>(out.print),
                        out.print == first ? "" : "  DIFFERS");
            std::fflush(stdout);  // each line as its run ends (emulated runs are slow)
          }
        }
      }
    }
    std::printf(agree ? "every path gives the same state\n" : "the paths disagree\n");
    return agree ? 0 : 1;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "simd_paths_check: %s\n", error.what());
    return 2;
  }
}
