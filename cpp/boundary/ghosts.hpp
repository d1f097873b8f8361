// The wall ghosts of every particle (seed 4.1: a ghost at the clamped foot of
// the perpendicular on each wall within h), found once per step and reused by
// every pass of it, and each particle's clearance: the squared length of a
// path from it that meets no wall, which lets the next integration skip the
// wall check for the short paths of most particles. Reads positions and the
// walls; writes the ghosts' rows (r_i - r_ghost) and the clearances.
#pragma once

#include <type_traits>
#include <vector>

#include "boundary/walls.hpp"
#include "core/csr.hpp"
#include "core/parallel.hpp"
#include "core/types.hpp"
#include "simd/ints.hpp"
#include "simd/points.hpp"

namespace sphfluid {

class Ghosts {
 public:
  struct NoThen {
    void operator()(Index, Index) const {}
  };
  // The ghosts of particles [0, n) (with nearest_only, only those at the
  // walls' nearest point: not at a joint that another segment comes nearer
  // than, nor where three or more segments meet; WallSet::for_each_ghost).
  // on_row(i, row) runs as particle i's ghosts are found,
  // for a particle that has any; then(first, last) on each thread's range of
  // particles once their ghosts are found, in the same parallel region.
  template <class OnRow, class Then>
  void find(const WallSet& walls, const Vec2* x, Index n, Real h, int threads, bool nearest_only,
            OnRow on_row, Then then) {
    // Returns the squared distance from x[i] to the nearest wall of its lookup cell.
    auto emit = [&](Index i, Chunk<Vec2>& out) {
      const std::size_t before = out.size();
      const Real d2 = walls.for_each_ghost(x[i], [&](const Vec2& r, bool nearest) {
        if (nearest || !nearest_only) out.push_back(r);
      });
      if (out.size() != before) on_row(i, Row<Vec2>{out.begin() + before, out.end()});
      return d2;
    };
#if SPHFLUID_AVX512
    if constexpr (kVector8 && sizeof(Index) == 4) {
      find8(walls, x, n, h, threads, emit, then);
      return;
    }
#endif
    (void)h;
    fresh_ = false;
    rows_.build(n, threads, emit);
    if constexpr (std::is_same_v<Then, NoThen>) return;
    const int nt = resolve_threads(threads);
#pragma omp parallel for schedule(static) num_threads(nt)
    for (int t = 0; t < nt; ++t) {
      const Share s = share_of(n, t, nt);
      then(s.first, s.last);
    }
  }
  void find(const WallSet& walls, const Vec2* x, Index n, Real h, int threads,
            bool nearest_only) {
    find(walls, x, n, h, threads, nearest_only, [](Index, Row<Vec2>) {}, NoThen{});
  }

  Row<Vec2> row(Index i) const { return rows_.row(i); }
  const Csr<Vec2>& rows() const { return rows_; }
  // Per particle of the last find (8 entries of padding after n): the squared
  // length of a path from it that meets no wall, from the distance to the
  // nearest wall of its lookup cell (every wall within h of it is there; none
  // where no wall comes within h, nor off the lookup grid: WallSet::near8,
  // safe_path2). Fresh until the next integration (fresh_for), or anything
  // that moves or reorders the particles without a find (stale): the seed's
  // right after its evaluation, wcsph's drift in the next step.
  const float* clearances() const { return clear2_.data(); }
  bool fresh_for(Index n) const {
    return fresh_ && clear2_.size() >= static_cast<std::size_t>(n) + 8;
  }
  void stale() { fresh_ = false; }
  std::size_t bytes() const { return rows_.bytes() + clear2_.capacity() * sizeof(float); }

 private:
#if SPHFLUID_AVX512
  // Eight particles at a time: most lie in lookup cells that no wall comes
  // near, and their rows are left empty in one store. Each particle's
  // clearance goes to clear2_, in float: h^2 and its margin 2e-6 h^2 are
  // normal floats for h from 1e-16 m to 1e19 m. The threads' shares follow
  // the cost of their last call (Balance: a particle near a wall costs several
  // times one away from them).
  template <class Emit, class Then>
  void find8(const WallSet& walls, const Vec2* x, Index n, Real h, int threads, Emit& emit,
             Then& then) {
    clear2_.resize(static_cast<std::size_t>(n) + 8);
    float* clear2 = clear2_.data();
    auto clearance = [&](Real d2) { return static_cast<float>(walls.safe_path2(d2)); };
    const float far2 = clearance(h * h);
    balance_.begin(n, resolve_threads(threads));
    rows_.build_ranges(n, threads, balance_, [&](Index lo, Index hi, Index* start,
                                                  Chunk<Vec2>& out) {
      Index i = lo;
      for (; i + 8 <= hi; i += 8) {
        simd::D8 px, py;
        simd::load_xy8(x[i].data(), px, py);
        const simd::Mask8 near = walls.near8(0xFF, px, py);
        simd::fill8(clear2 + i, far2);
        if (!near) {
          simd::I8::splat(static_cast<Index>(out.size())).store(start + i);
          continue;
        }
        for (Index k = 0; k < 8; ++k) {
          start[i + k] = static_cast<Index>(out.size());
          if (near >> k & 1) clear2[i + k] = clearance(emit(i + k, out));
        }
      }
      for (; i < hi; ++i) {
        start[i] = static_cast<Index>(out.size());
        clear2[i] = clearance(emit(i, out));
      }
      then(lo, hi);
    });
    balance_.end();
    fresh_ = true;
  }
#endif

  Csr<Vec2> rows_;      // r_i - r_ghost of each wall ghost of particle i
  Balance balance_;     // the threads' shares of the search (and of `then`)
  std::vector<float> clear2_;
  bool fresh_ = false;
};

}  // namespace sphfluid
