// Pair sums by cell clusters, without neighbour lists, on the lanes of
// simd/: the particles of one cell, a tile of up to eight (four for the
// forces) at a time, against groups of lanes of the contiguous candidate
// runs of half the stencil, each pair once. A group's data is loaded once for
// the tile; the tile's sums stay in registers, and the group's shares are
// summed in registers and added to memory once per group and tile. The
// traversal knows no physics: a density weight of r^2, or an interaction
// (load a group's data; add a pair's shares) from the method, does the rest.
//
// Half the stencil: for particle i of cell (cx, cy), the run of cells cx - 1 ..
// cx + 1 of its own row from i + 1 on, and the same three cells of the row
// above (both runs are contiguous in the cell-sorted storage). Each pair within
// a block of cell rows is met once, from its lower particle; j's share goes to
// j. A pair across two blocks (the top row of one, the bottom row of the
// next) is met from each side, and each side keeps its own share: the first
// row of a block also runs over the row below, for i's share alone. So every
// sum is taken in one order whatever the thread count (each thread takes whole
// blocks). Lanes beyond the support add exactly zero (they are masked out).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "core/types.hpp"
#include "neighbours/grid.hpp"
#include "simd/points.hpp"
#include "terms/density.hpp"

namespace sphfluid {

// Whether a weight of r^2 says it is cheap: a polynomial in r^2 (kCheap), whose
// weights the density sums without a branch as unscaled(r2), applying factor()
// once per particle.
template <class W, class = void>
struct IsCheap : std::false_type {};
template <class W>
struct IsCheap<W, std::void_t<decltype(W::kCheap)>> : std::bool_constant<W::kCheap> {};

class CellPairs {
 public:
  // The cell clusters run where the lanes do (simd/: AVX-512F and VL).
  static constexpr bool kAvailable = kVector8;

  // The storage runs of cell (cx, cy) in the block of rows [y0, y1): its own
  // row's three cells end at own_end; the row above's three cells (j's share
  // kept when that row is in the block); the row below's, in a block's first
  // row only (i's share alone).
  struct Runs {
    Index own_end, above0, above1, below0, below1;
    bool above_in_block;
  };

  // Cuts the grid's rows into at most `count` blocks of whole rows: block k
  // starts at the first row boundary at or past k n / count particles, so the
  // blocks hold near-equal shares and depend on the sorted particles alone,
  // not on the thread count. These blocks serve the density pass, which then
  // cuts the pair passes' blocks by its pair counts (cut_pair_blocks).
  void make_blocks(const CellGrid& grid, Index n, Index count) {
    const Index nx = grid.nx(), ny = grid.ny();
    const Index* start = grid.cell_starts();
    count_ = count;
    cut_rows(ny, count, n, [&](Index y) { return std::int64_t(start[y * nx]); }, rows_);
    pair_rows_ = rows_;
  }
  Index blocks() const { return static_cast<Index>(rows_.size()) - 1; }
  Index block_row(Index b) const { return rows_[b]; }  // first row of block b (b = blocks(): ny)
  // The same for the pair passes' blocks.
  Index pair_blocks() const { return static_cast<Index>(pair_rows_.size()) - 1; }
  Index pair_block_row(Index b) const { return pair_rows_[b]; }
  std::size_t bytes() const {
    return (rows_.capacity() + pair_rows_.capacity()) * sizeof(Index) +
           (row_pairs_.capacity() + cost_below_.capacity()) * sizeof(std::int64_t);
  }

  // After a block's pass its particles' sums are complete (no other block
  // adds to them): finish(first, last) is called on them by the same thread,
  // in the same parallel loop.
  struct NoFinish {
    void operator()(Index, Index) const {}
  };

#if SPHFLUID_AVX512
  // rho_i = m (self + sum_j w(|r_ij|^2)) over j != i with |r_ij| < h, where
  // w(D8 r2) is the weight of r^2 (zero-safe: masked lanes are dropped).
  // Returns the number of distinct pairs.
  template <class WeightOfR2>
  std::int64_t density(const CellGrid& grid, const Vec2* x, Real h, Real m, Real self,
                       WeightOfR2 w, Real* rho, int threads) {
    const Index nx = grid.nx(), ny = grid.ny();
    const Index* start = grid.cell_starts();
    const simd::D8 h2 = simd::D8::splat(h * h);
    std::int64_t pairs = 0;
    const Index nb = blocks();
    row_pairs_.resize(static_cast<std::size_t>(ny));
    std::int64_t* const row_pairs = row_pairs_.data();
#pragma omp parallel for schedule(static) num_threads(threads) reduction(+ : pairs)
    for (Index b = 0; b < nb; ++b) {
      const Index y0 = rows_[b], y1 = rows_[b + 1];
      std::fill(rho + start[y0 * nx], rho + start[y1 * nx], Real(0));
      for (Index cy = y0; cy < y1; ++cy) {
        std::int64_t row = 0;  // this row's pairs
        for (Index cx = 0; cx < nx; ++cx) {
          const Index c = cy * nx + cx, s0 = start[c], s1 = start[c + 1];
          const Runs runs = runs_of(start, nx, ny, cx, cy, y0, y1);
          for (Index q0 = s0; q0 < s1; q0 += kDensityTile)
            with_tile<kDensityTile>(s1 - q0, [&](auto tile) {
              row += density_tile<decltype(tile)::value>(x, h2, m, self, w, rho, q0, runs);
            });
        }
        row_pairs[cy] = row;
        pairs += row;
      }
    }
    cut_pair_blocks(grid);
    return pairs;
  }
#endif

  // The pair passes' traversal: each block of rows by one thread, its part of
  // each output zeroed first and finish(first, last) called on its particles
  // at the end; in it each cell's particles a tile of up to MaxTile at a
  // time: tile(k, q0, cx, cy, s0, s1, runs), k a std::integral_constant of
  // the tile's size. (Three outputs at once in tiles of 2 or 3 ran 9 and 4 %
  // slower than in tiles of 4 on the 10k dam break with shifting.)
  template <int MaxTile, std::size_t N, class Tile, class Finish>
  void for_each_pair_tile(const CellGrid& grid, const std::array<Vec2*, N>& outs, int threads,
                          Tile&& tile, Finish& finish) const {
    const Index nx = grid.nx(), ny = grid.ny();
    const Index* start = grid.cell_starts();
    const Index nb = pair_blocks();
#pragma omp parallel for schedule(static) num_threads(threads)
    for (Index b = 0; b < nb; ++b) {
      const Index y0 = pair_rows_[b], y1 = pair_rows_[b + 1];
      for (Vec2* a : outs) std::fill(a + start[y0 * nx], a + start[y1 * nx], Vec2::Zero());
      for (Index cy = y0; cy < y1; ++cy) {
        for (Index cx = 0; cx < nx; ++cx) {
          const Index c = cy * nx + cx, s0 = start[c], s1 = start[c + 1];
          const Runs runs = runs_of(start, nx, ny, cx, cy, y0, y1);
          for (Index q0 = s0; q0 < s1; q0 += MaxTile)
            with_tile<MaxTile>(s1 - q0, [&](auto k) { tile(k, q0, cx, cy, s0, s1, runs); });
        }
      }
      finish(start[y0 * nx], start[y1 * nx]);
    }
  }

#if SPHFLUID_AVX512
  // Pair sums into a (overwritten) by the cluster loop, in the lanes of the
  // frame (neighbours/frames.hpp: where positions come from, where the
  // shares go): pair.load(j, span) returns the data of the group's particles
  // from j; pair.add(i, data, in, dx, dy, r2, fi.., fj..) adds, on the lanes
  // `in` (r < h), i's share to fi and j's to fj (r_ij = (dx, dy)).
  template <class Frame, class Pair, class Finish = NoFinish>
  void pair_sums(const CellGrid& grid, const Frame& frame, const Pair& pair, Vec2* a,
                 int threads, Finish finish = {}) const {
    pair_sums(grid, frame, OneOutput<Pair>{pair}, std::array<Vec2*, 1>{a}, threads, finish);
  }
  // The same into N outputs at once (Pair::kOutputs = N): pair.add takes
  // arrays of N lanes for each of fix, fiy, fjx, fjy, output o's sums in
  // outs[o]. A frame that keeps j's shares itself (CellFloatFrame) takes one.
  template <class Frame, class Pair, std::size_t N, class Finish = NoFinish>
  void pair_sums(const CellGrid& grid, const Frame& frame, const Pair& pair,
                 const std::array<Vec2*, N>& outs, int threads, Finish finish = {}) const {
    using L = typename Frame::Lane;
    static_assert(N == Pair::kOutputs && N <= Frame::kMaxOutputs);
    auto block_done = [&](Index i0, Index i1) {
      frame.block_done(i0, i1, outs[0]);
      finish(i0, i1);
    };
    for_each_pair_tile<kPairTile>(grid, outs, threads, [&](auto tile, Index q0, Index cx, Index cy,
                                                Index s0, Index s1, const Runs& runs) {
      constexpr int k = decltype(tile)::value;
      L fx[N][k], fy[N][k];
      for (std::size_t o = 0; o < N; ++o)
        for (int q = 0; q < k; ++q) fx[o][q] = fy[o][q] = simd::zero<L>();
      frame.for_runs(grid, cx, cy, q0, s0, s1, runs, [&](const auto& run, Index j0, Index j1,
                                                         bool own, bool scatter) {
        pair_run<k>(frame, pair, run, outs, q0, j0, j1, own, scatter, fx, fy);
      });
      for (std::size_t o = 0; o < N; ++o) frame.add_tile(q0, k, fx[o], fy[o], outs[o]);
    }, block_done);
  }
#endif

  // A pair interaction of one output as one of N = 1.
  template <class Pair>
  struct OneOutput {
    static constexpr std::size_t kOutputs = 1;
    using Data = typename Pair::Data;
    Pair pair;  // by value, like the interactions it adapts
    template <class S>
    SPHFLUID_INLINE void load(Index j, const S& s, Data& d) const {
      pair.load(j, s, d);
    }
    template <class L, class M>
    SPHFLUID_INLINE void add(Index i, const Data& d, M in, L dx, L dy, L r2, L (&fix)[1],
                             L (&fiy)[1], L (&fjx)[1], L (&fjy)[1]) const {
      pair.add(i, d, in, dx, dy, r2, fix[0], fiy[0], fjx[0], fjy[0]);
    }
  };

 private:
  // Cuts rows [0, ny) into at most `count` blocks: block k starts at the first
  // row y where below(y), the cost of the rows under y (non-decreasing, total
  // at most `total`), reaches k total / count; no block starts where all the
  // cost is below.
  template <class Below>
  static void cut_rows(Index ny, Index count, std::int64_t total, Below below,
                       std::vector<Index>& rows) {
    rows.assign(1, 0);
    Index k = 1;
    for (Index y = 1; y < ny && k < count; ++y) {
      const std::int64_t c = below(y);
      if (c >= total) break;
      if (c * count >= k * total) {
        rows.push_back(y);
        while (k < count && c * count >= k * total) ++k;
      }
    }
    rows.push_back(ny);
  }
  // A cell's particles are taken up to kDensityTile (kPairTile) at a time, their
  // sums held in registers: with_tile<Max> calls body with
  // std::integral_constant<int, min(left, Max)>. (Wider pair tiles spill.)
  static constexpr Index kDensityTile = 8, kPairTile = 4;
  template <int Max, class Body>
  static void with_tile(Index left, Body&& body) {
    if constexpr (Max > 1) {
      if (left < Max) return with_tile<Max - 1>(left, body);
    }
    body(std::integral_constant<int, Max>{});
  }

#if SPHFLUID_AVX512
  // A tile's K particles from q0 against the run [j0, j1) of a frame, each
  // group of lanes loaded once: i's shares into fx, fy (per output), j's added
  // to the frame's sums (where `scatter`); `own`: the run of the tile's own
  // cells from q0 + 1 on, whose lanes before a tile particle are not its pairs.
  template <int K, class Frame, class Pair, class Run, std::size_t N,
            class L = typename Frame::Lane>
  SPHFLUID_INLINE static void pair_run(const Frame& frame, const Pair& pair, const Run& run,
                                       const std::array<Vec2*, N>& outs, Index q0, Index j0,
                                       Index j1, bool own, bool scatter, L (&fx)[N][K],
                                       L (&fy)[N][K]) {
    constexpr Index kW = simd::kLanes<L>;
    const L zero = simd::zero<L>(), h2 = frame.support2();
    for (Index j = j0; j < j1; j += kW) {
      const typename Frame::Span span(j1 - j);
      L at_x, at_y;
      run.positions(j, span, at_x, at_y);
      typename Pair::Data data;
      pair.load(j, span, data);
      L fjx[N], fjy[N];
      for (std::size_t o = 0; o < N; ++o) fjx[o] = fjy[o] = zero;
      for (int q = 0; q < K; ++q) {
        const Index i = q0 + q;
        const simd::Mask8 live = own ? span.lanes & after<kW>(i, j) : span.lanes;
        if (!live) continue;
        L xi, yi;
        frame.position(i, xi, yi);
        const L dx = xi - at_x, dy = yi - at_y;
        const L r2 = simd::fmadd(dx, dx, dy * dy);
        const simd::Mask8 in = simd::lt(live, r2, h2);
        if (!in) continue;
        L ix[N], iy[N];
        for (std::size_t o = 0; o < N; ++o) ix[o] = fx[o][q], iy[o] = fy[o][q];
        pair.add(i, data, in, dx, dy, r2, ix, iy, fjx, fjy);
        for (std::size_t o = 0; o < N; ++o) fx[o][q] = ix[o], fy[o][q] = iy[o];
      }
      if (scatter)
        for (std::size_t o = 0; o < N; ++o) frame.add_shares(j, span, fjx[o], fjy[o], outs[o]);
    }
  }
#endif

  static Runs runs_of(const Index* start, Index nx, Index ny, Index cx, Index cy, Index y0,
                      Index y1) {
    const Index x0 = std::max<Index>(cx - 1, 0), x1 = std::min<Index>(cx + 1, nx - 1);
    Runs r{start[cy * nx + x1 + 1], 0, 0, 0, 0, cy + 1 < y1};
    if (cy + 1 < ny) {
      r.above0 = start[(cy + 1) * nx + x0];
      r.above1 = start[(cy + 1) * nx + x1 + 1];
    }
    if (cy == y0 && cy > 0) {
      r.below0 = start[(cy - 1) * nx + x0];
      r.below1 = start[(cy - 1) * nx + x1 + 1];
    }
    return r;
  }

  // Lanes of the group of W at j whose particle comes after i (j + lane > i).
  template <int W>
  static simd::Mask8 after(Index i, Index j) {
    constexpr unsigned all = (1u << W) - 1;
    const Index d = i + 1 - j;  // the first lane after i
    return d <= 0    ? simd::Mask8(all)
           : d >= W  ? simd::Mask8(0)
                     : static_cast<simd::Mask8>((all << d) & all);
  }

#if SPHFLUID_AVX512
  // The density sums of the tile of K particles from q0, against its cell's
  // runs: each pair met once, its weight added to both (j's shares in rho[],
  // i's in registers until every pair of the tile is in). Returns the pairs
  // met in the own row and the row above.
  template <int K, class WeightOfR2>
  SPHFLUID_INLINE static std::int64_t density_tile(const Vec2* x, simd::D8 h2, Real m, Real self,
                                                   const WeightOfR2& w, Real* rho, Index q0,
                                                   const Runs& runs) {
    using simd::D8;
    D8 acc[K], xs[K], ys[K];  // the tile's sums and positions
    for (int q = 0; q < K; ++q) {
      acc[q] = simd::zero<D8>();
      xs[q] = D8::splat(x[q0 + q].x());
      ys[q] = D8::splat(x[q0 + q].y());
    }
    // Returns the pairs it met (counted where asked), in a local rather than
    // in the thread's total, which stays in memory.
    auto run = [&](Index j0, Index j1, bool own, bool scatter, bool count) {
      unsigned met = 0;
      for (Index j = j0; j < j1; j += 8) {
        const simd::Span8 g(j1 - j);
        D8 at_x, at_y;
        simd::load_xy(x[j].data(), g, at_x, at_y);
        D8 wj = simd::zero<D8>();
        for (int q = 0; q < K; ++q) {
          const Index i = q0 + q;
          const simd::Mask8 live = own ? g.lanes & after<8>(i, j) : g.lanes;
          if (!live) continue;
          const D8 dx = xs[q] - at_x, dy = ys[q] - at_y;
          const D8 r2 = simd::fmadd(dx, dx, dy * dy);
          const simd::Mask8 in = simd::lt(live, r2, h2);
          // A weight of a few instructions goes without a branch on in
          // (whose mispredictions cost more); one with a square root not.
          D8 wv;
          if constexpr (IsCheap<WeightOfR2>::value) {
            wv = simd::maskz(in, w.unscaled(r2));
          } else {
            if (!in) continue;
            wv = simd::maskz(in, w(r2));
          }
          acc[q] = acc[q] + wv;
          wj = wj + wv;
          if (count) met += static_cast<unsigned>(simd::count(in));
        }
        if (scatter) (D8::load(rho + j, g.lanes) + wj).store(rho + j, g.lanes);
      }
      return met;
    };
    std::int64_t pairs = run(q0 + 1, runs.own_end, true, true, true);
    pairs += run(runs.above0, runs.above1, false, runs.above_in_block, true);
    run(runs.below0, runs.below1, false, false, false);
    // Every pair of these particles is in now (no later cell adds to them).
    for (int q = 0; q < K; ++q) {
      const Index i = q0 + q;
      const Real sum = rho[i] + simd::reduce_add(acc[q]);
      if constexpr (IsCheap<WeightOfR2>::value) {
        rho[i] = summation_density(m, self, w.factor() * sum);
      } else {
        rho[i] = summation_density(m, self, sum);
      }
    }
    return pairs;
  }
#endif

  // The pair passes' blocks, as many as the density pass's, cut where the
  // cost of the rows below reaches k / count of the whole: a row costs the
  // pairs the density pass counted in it, plus kParticleCost for each of its
  // particles (so that rows of lone particles still split). A pair pass's time
  // follows its pairs, which are not spread evenly over the particles: the
  // compressed rows near the floor hold more than those at the free surface.
  // Like the density pass's blocks, these depend on the particles alone, not
  // on the thread count.
  // row_pairs_ holds the density pass's counts for this grid's ny rows.
  void cut_pair_blocks(const CellGrid& grid) {
    const Index nx = grid.nx(), ny = grid.ny();
    const Index* start = grid.cell_starts();
    cost_below_.resize(static_cast<std::size_t>(ny) + 1);
    std::int64_t sum = 0;
    for (Index y = 0; y < ny; ++y) {
      cost_below_[y] = sum;
      sum += row_pairs_[y] + kParticleCost * std::int64_t(start[(y + 1) * nx] - start[y * nx]);
    }
    cost_below_[ny] = sum;
    cut_rows(ny, count_, sum, [&](Index y) { return cost_below_[y]; }, pair_rows_);
  }

  // A particle's cost in a pair pass, in pairs (cut_pair_blocks). The 10k dam
  // break's two blocks, timed on one thread: 1 splits the pair sums evenly
  // (94 against 94 ms over 1,100 steps); 4 leaves 95 against 92, and the
  // density pass's cut by particles 96 against 92.
  static constexpr std::int64_t kParticleCost = 1;
  Index count_ = 1;                      // the blocks asked for
  std::vector<Index> rows_;              // first cell row of each density block, then ny
  std::vector<Index> pair_rows_;         // the same for the pair passes' blocks
  std::vector<std::int64_t> row_pairs_;  // the pairs the density pass counted in each row
  std::vector<std::int64_t> cost_below_;  // cut_pair_blocks' scratch
};

}  // namespace sphfluid
