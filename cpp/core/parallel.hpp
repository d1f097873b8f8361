// OpenMP helpers that also compile without OpenMP: the thread count, a range's
// share of the threads, and cuts that follow the measured cost of a loop.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "core/types.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace sphfluid {

inline int resolve_threads(int requested) {
#ifdef _OPENMP
  return requested > 0 ? requested : omp_get_max_threads();
#else
  (void)requested;
  return 1;
#endif
}

// Below this many particles a step runs on one thread, whatever was asked:
// the pair-once loops have a single block there (NeighbourSearch::pair_block), and the
// threads' start and join cost more than the rest of the work could gain. Seed
// dam break, 2 threads against 1: at 703 particles 7,371 against 14,109
// steps/s, at 990 10,212 against 10,216 (medians of 7; 5,446 at worst), at
// 1,485 9,319 against 6,943. The sort alone moved to the threads at 1,000
// first: at 10k particles 39 us against 73 us serial, at 3k 19 against 26 us
// (interleaved A/B of 5).
inline constexpr Index kParallelMin = 1'000;

// The threads for a loop over n particles.
inline int threads_for(Index n, int threads) { return n >= kParallelMin ? threads : 1; }

// Share t of n items cut into `parts` contiguous, near-equal ranges: [first, last).
struct Share {
  Index first, last;
};
inline Share share_of(Index n, int t, int parts) {
  return {static_cast<Index>(std::int64_t(n) * t / parts),
          static_cast<Index>(std::int64_t(n) * (t + 1) / parts)};
}

// Cuts for a loop whose cost per item is uneven but changes slowly from one
// call to the next (the wall ghosts: a particle near a wall costs several
// times one away from them): each thread times its range, and the next call
// moves the cuts halfway towards where those times say the cost splits
// evenly. Only the work's split follows the clock, never a result.
class Balance {
 public:
  // The threads' ranges of n items for this call: [cut(t), cut(t + 1)).
  void begin(Index n, int threads) {
    if (static_cast<int>(frac_.size()) != threads + 1) {
      frac_.resize(threads + 1);
      for (int t = 0; t <= threads; ++t) frac_[t] = static_cast<double>(t) / threads;
    }
    seconds_.assign(threads, 0.0);
    cuts_.resize(threads + 1);
    for (int t = 0; t <= threads; ++t)
      cuts_[t] = static_cast<Index>(std::llround(frac_[t] * static_cast<double>(n)));
    cuts_[threads] = n;
  }
  Index cut(int t) const { return cuts_[t]; }
  // Thread t's time on its range, from inside the parallel region.
  void record(int t, double seconds) { seconds_[t] = seconds; }
  // After the region: where the cost splits evenly, if every item of a range
  // cost the same; each range keeps at least a twentieth of its even share.
  void end() {
    const int nt = static_cast<int>(seconds_.size());
    double total = 0;
    for (double s : seconds_) total += s;
    if (nt < 2 || !(total > 0)) return;
    std::vector<double>& target = target_;  // (a member: no allocation in the step)
    target.assign(nt + 1, 0.0);
    target[nt] = 1;
    int r = 0;
    double before = 0;  // cost of the ranges before r
    for (int t = 1; t < nt; ++t) {
      const double goal = total * t / nt;
      while (r < nt - 1 && before + seconds_[r] < goal) before += seconds_[r++];
      const double width = frac_[r + 1] - frac_[r];
      const double part = seconds_[r] > 0 ? (goal - before) / seconds_[r] : 0.5;
      target[t] = frac_[r] + width * std::clamp(part, 0.0, 1.0);
    }
    const double least = 0.05 / nt;
    for (int t = 1; t < nt; ++t)
      frac_[t] = std::clamp(0.5 * (frac_[t] + target[t]), frac_[t - 1] + least,
                            1.0 - (nt - t) * least);
  }

 private:
  std::vector<double> frac_;     // the cuts as fractions of n
  std::vector<double> seconds_;  // each thread's time on its range, last call
  std::vector<double> target_;   // end()'s scratch
  std::vector<Index> cuts_;
};

// The sum of f(i) over i in [0, n), on `threads` threads, the same whatever
// their number: blocks of kSumBlock items, each summed in index order, then
// the blocks' sums in block order. f may also write item i's own values (a
// loop and its reduction in one pass). `partial` is scratch (no allocation
// in a step once it has grown).
inline constexpr Index kSumBlock = 1024;
template <class F>
Real block_sum(Index n, int threads, std::vector<Real>& partial, F f) {
  const Index blocks = (n + kSumBlock - 1) / kSumBlock;
  partial.resize(static_cast<std::size_t>(blocks));
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index b = 0; b < blocks; ++b) {
    const Index last = std::min(n, (b + 1) * kSumBlock);
    Real s = 0;
    for (Index i = b * kSumBlock; i < last; ++i) s += f(i);
    partial[static_cast<std::size_t>(b)] = s;
  }
  Real sum = 0;
  for (Index b = 0; b < blocks; ++b) sum += partial[static_cast<std::size_t>(b)];
  return sum;
}

inline int thread_rank() {
#ifdef _OPENMP
  return omp_get_thread_num();
#else
  return 0;
#endif
}

inline int thread_team_size() {
#ifdef _OPENMP
  return omp_get_num_threads();
#else
  return 1;
#endif
}

}  // namespace sphfluid
