// How long one cache line takes to travel from one core to the other: two threads hand a
// counter back and forth through a shared atomic, each waiting for the other's write.
//
// On a VM the host decides which physical cores carry the vCPUs. When the two share a
// last-level cache a hand-off takes some 30 ns; when they do not it takes several times
// that, and millscope's 2-thread runs slow down with it (docs/performance.md, "Threads on a
// busy machine"), while work that stays on one core does not. compare_liggghts.sh prints this
// figure before each of its millscope runs.
//
// build: g++ -O2 -pthread benchmarks/core_handoff.cpp -o core_handoff
// usage: core_handoff [HANDOFFS] [ROUNDS]    (defaults 1000000 and 5)
// prints: core_handoff_ns=<median over the rounds of the mean one-way hand-off, ns>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <vector>

namespace {

long parse_count(const char* text, const char* name) {
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  if (end == text || *end != '\0' || value < 1) {
    std::fprintf(stderr, "core_handoff: %s = '%s' is not valid; it must be an integer >= 1\n",
                 name, text);
    std::exit(2);
  }
  return value;
}

// The counter, alone on its cache line: even, the main thread's turn; odd, the other's.
struct alignas(64) Turn {
  std::atomic<long> value{0};
};

// Spins of a waiting thread between two yields: some microseconds, far above a hand-off
// between two cores.
constexpr long spins_before_yield = 4096;

// One round: `handoffs` one-way hand-offs; returns the mean time of one, ns.
double time_round(long handoffs) {
  Turn line;
  std::atomic<long>& turn = line.value;
  auto play = [&turn, handoffs](long first) {
    for (long k = first; k < handoffs; k += 2) {
      // Spin, and now and then give the core away: when the two threads share one core (a
      // one-core machine, or a busy one) the other can only answer once this one yields, and
      // spinning on would cost a whole time slice per hand-off.
      for (long spins = 1; turn.load(std::memory_order_acquire) != k; ++spins)
        if (spins % spins_before_yield == 0) std::this_thread::yield();
      turn.store(k + 1, std::memory_order_release);
    }
  };
  std::thread other(play, 1L);
  const auto begin = std::chrono::steady_clock::now();
  play(0L);
  other.join();
  const auto end = std::chrono::steady_clock::now();
  return std::chrono::duration<double, std::nano>(end - begin).count() /
         static_cast<double>(handoffs);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 3) {
    std::fprintf(stderr, "usage: %s [HANDOFFS] [ROUNDS]\n", argv[0]);
    return 2;
  }
  const long handoffs = argc > 1 ? parse_count(argv[1], "HANDOFFS") : 1000000;
  const long rounds = argc > 2 ? parse_count(argv[2], "ROUNDS") : 5;
  std::vector<double> ns;
  for (long k = 0; k < rounds; ++k) ns.push_back(time_round(handoffs));
  std::sort(ns.begin(), ns.end());
  std::printf("core_handoff_ns=%.1f\n", ns[ns.size() / 2]);
  return 0;
}
