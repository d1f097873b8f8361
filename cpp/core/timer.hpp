// Wall-clock seconds spent in each phase of the step, summed over steps: a few
// clock reads a step, each adding the time since the last mark to a phase.
#pragma once

#include <array>
#include <chrono>

namespace sphfluid {

// kSolve: an implicit method's pressure solves (dfsph).
enum Phase : int {
  kSort, kNeighbours, kGhosts, kDensity, kForces, kIntegrate, kDomain, kSolve, kNumPhases
};

inline const char* phase_name(int p) {
  static const char* names[kNumPhases] = {"sort",   "neighbours", "ghosts", "density",
                                          "forces", "integrate",  "domain", "solve"};
  return names[p];
}

class PhaseTimer {
 public:
  // Starts the clock for the next mark.
  void start() { mark_ = std::chrono::steady_clock::now(); }
  // Adds the time since the last mark (or start) to phase p.
  void mark(int p) {
    const auto now = std::chrono::steady_clock::now();
    seconds_[p] += std::chrono::duration<double>(now - mark_).count();
    mark_ = now;
  }
  const std::array<double, kNumPhases>& seconds() const { return seconds_; }
  void reset() { seconds_.fill(0.0); }

 private:
  std::array<double, kNumPhases> seconds_{};
  std::chrono::steady_clock::time_point mark_;
};

}  // namespace sphfluid
