// Pair sums by cell clusters, without neighbour lists (AVX-512F and VL), for the
// density and the pair forces of both methods: the particles of one cell, a
// tile of up to eight (four for the forces) at a time, against groups of eight
// (four for wcsph's forces) of the contiguous candidate runs of half the
// stencil, each pair once. A group's data (x, v, p, 1/rho) is loaded once for
// the tile; the tile's sums stay in registers, and the group's shares are
// summed in registers and added to memory once per group and tile.
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

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

// The cell clusters need AVX-512F and, for the four-lane groups, VL.
#if defined(__AVX512F__) && defined(__AVX512VL__)
#define SPHFLUID_CELL_PAIRS 1
#else
#define SPHFLUID_CELL_PAIRS 0
#endif

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "neighbours/grid.hpp"
#include "core/types.hpp"

namespace sphfluid {

// The seed's pair forces in single precision (SimParams::float_pairs): the
// pressure and viscosity pair terms by the same cell clusters in groups of
// eight floats (256-bit lanes, which CPUs that split 512-bit arithmetic in two
// run at twice the rate of eight doubles); the density stays in double (a
// stiff EOS would amplify a float density's round-off into the pressure).
// Each position is taken relative to the corner of its cell, in units of the
// cell width w (0 <= u < 1), and a candidate's is moved by the whole cells
// between the two, so a separation keeps float's precision, about 6e-8 w, at
// any resolution and anywhere in the domain. p / rho0, rho0 / rho and v are
// rounded once per evaluation. The quantities are scaled to be of order one
// whatever the units (no overflow nor underflow from powers of h). A
// particle's own sums (its eight lanes) are widened to double before they are
// added; the shares it gets as the second particle of a pair, a few group sums
// that are float sums already, are summed in float too, in jx and jy, and
// widened once, when its pair block is done (the largest force error, 4.3e-7
// of the largest force, did not change with it).
struct SeedFloats {
  std::vector<float> ux, uy, vx, vy;  // position in its cell / w; velocity
  std::vector<float> p, ir;           // p / rho0, rho0 / rho
  std::vector<float> jx, jy;          // j's shares of the pair sums (zeroed with the copies)
  void resize(Index n) {
    for (auto* a : {&ux, &uy, &vx, &vy, &p, &ir, &jx, &jy})
      a->resize(static_cast<std::size_t>(n));
  }
  std::size_t bytes() const {
    std::size_t sum = 0;
    for (const auto* a : {&ux, &uy, &vx, &vy, &p, &ir, &jx, &jy}) sum += a->capacity();
    return sum * sizeof(float);
  }
};

// Whether a kernel of r^2 says it is cheap: a polynomial in r^2 (kCheap), whose
// weights the density sums without a branch as unscaled(r2), applying factor()
// once per particle.
template <class W, class = void>
struct IsCheap : std::false_type {};
template <class W>
struct IsCheap<W, std::void_t<decltype(W::kCheap)>> : std::bool_constant<W::kCheap> {};

// Whether the seed's double pair forces take 1/r from rsqrt14 and two Newton
// steps (SeedPair's RecipRoot) on this CPU rather than a square root and a
// division. Measured on the 10k dam break, 1 thread: on an Intel Xeon
// (AVX-512, 2026-11-25) forces 251 -> 217 us a step; on an AMD EPYC (Zen 4)
// 311 -> 341 (BENCHMARKS.md). Intel's 512-bit square root and division are
// the slow ones; so Intel CPUs take the Newton steps. (In float, with eight
// lanes of 256 bits, the root and division stay on both: on the Xeon the
// Newton step lost, 193 -> 210 us.)
inline bool prefers_recip_root() {
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
  return __builtin_cpu_is("intel");
#else
  return false;
#endif
}

class CellPairs {
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

  // The storage runs of cell (cx, cy) in the block of rows [y0, y1): its own
  // row's three cells end at own_end; the row above's three cells (j's share
  // kept when that row is in the block); the row below's, in a block's first
  // row only (i's share alone).
  struct Runs {
    Index own_end, above0, above1, below0, below1;
    bool above_in_block;
  };
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

#if SPHFLUID_CELL_PAIRS
  // Lanes of the group of W at j whose particle comes after i (j + lane > i).
  template <int W>
  static __mmask8 after(Index i, Index j) {
    constexpr unsigned all = (1u << W) - 1;
    const Index d = i + 1 - j;  // the first lane after i
    return d <= 0 ? __mmask8(all) : d >= W ? __mmask8(0) : static_cast<__mmask8>((all << d) & all);
  }
  // The lanes of a group of eight from j in a run ending at j1, and the masks of
  // the lo and hi halves of its 16 interleaved doubles.
  struct Lanes8 {
    __mmask8 lanes, lo, hi;
    Lanes8(Index j, Index j1) {
      const Index left = j1 - j;
      const unsigned doubles = 2u * static_cast<unsigned>(std::min<Index>(left, 8));
      lanes = left >= 8 ? __mmask8(0xFF) : static_cast<__mmask8>((1u << left) - 1);
      lo = static_cast<__mmask8>((1u << std::min(doubles, 8u)) - 1);
      hi = static_cast<__mmask8>((1u << (doubles > 8 ? doubles - 8 : 0u)) - 1);
    }
  };
  // Eight consecutive particles from j (fewer at the end of the run): their
  // x and y de-interleaved, and the masks of the lanes and of the doubles.
  struct Group : Lanes8 {
    __m512d x, y;
    Group(const Vec2* pos, Index j, Index j1) : Lanes8(j, j1) {
      const double* p = reinterpret_cast<const double*>(pos + j);
      const __m512d a = _mm512_maskz_loadu_pd(lo, p), b = _mm512_maskz_loadu_pd(hi, p + 8);
      x = x_of8(a, b);
      y = y_of8(a, b);
    }
  };
  // Another per-particle Vec2 array (velocities) for the group's particles.
  struct Pairs8 {
    __m512d x, y;
  };
  static Pairs8 deinterleave(const Vec2* v, Index j, const Group& g) {
    const double* p = reinterpret_cast<const double*>(v + j);
    const __m512d a = _mm512_maskz_loadu_pd(g.lo, p), b = _mm512_maskz_loadu_pd(g.hi, p + 8);
    return {x_of8(a, b), y_of8(a, b)};
  }
  // The 8-lane group's j shares (x and y lanes) added to the interleaved a.
  static void add_shares(double* out, const Lanes8& g, __m512d fjx, __m512d fjy) {
    const __m512i lo_xy = _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11);
    const __m512i hi_xy = _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15);
    const __m512d lo = _mm512_permutex2var_pd(fjx, lo_xy, fjy);
    const __m512d hi = _mm512_permutex2var_pd(fjx, hi_xy, fjy);
    _mm512_mask_storeu_pd(out, g.lo, _mm512_add_pd(_mm512_maskz_loadu_pd(g.lo, out), lo));
    _mm512_mask_storeu_pd(out + 8, g.hi, _mm512_add_pd(_mm512_maskz_loadu_pd(g.hi, out + 8), hi));
  }
  // Groups of four (256-bit lanes with AVX-512VL masks), for pair terms whose
  // arithmetic outweighs the traversal (wcsph's): a particle meets about 2.5
  // pairs per eight candidates, and on CPUs that split 512-bit arithmetic in
  // two halves (AMD Zen 4) a four-lane evaluation costs half an eight-lane
  // one.
  // Four interleaved points (x0, y0, ..., x3, y3) as (x0..x3, y0..y3), and back.
  static __m512d split4(__m512d xy) {
    return _mm512_permutexvar_pd(_mm512_setr_epi64(0, 2, 4, 6, 1, 3, 5, 7), xy);
  }
  static __m512d join4(__m256d x, __m256d y) {
    return _mm512_permutexvar_pd(_mm512_setr_epi64(0, 4, 1, 5, 2, 6, 3, 7),
                                 _mm512_insertf64x4(_mm512_castpd256_pd512(x), y, 1));
  }
  static double sum4(__m256d v) {
    const __m128d a = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
    return _mm_cvtsd_f64(_mm_add_sd(a, _mm_unpackhi_pd(a, a)));
  }
  // Four consecutive particles from j (fewer at the end of the run): x and y
  // de-interleaved, and the masks of the lanes and of the doubles.
  struct Group4 {
    __m256d x, y;
    __mmask8 lanes, doubles;
    Group4(const Vec2* pos, Index j, Index j1) {
      const unsigned left = static_cast<unsigned>(std::min<Index>(j1 - j, 4));
      lanes = static_cast<__mmask8>((1u << left) - 1);
      doubles = static_cast<__mmask8>((1u << (2 * left)) - 1);
      const __m512d xy =
          split4(_mm512_maskz_loadu_pd(doubles, reinterpret_cast<const double*>(pos + j)));
      x = _mm512_castpd512_pd256(xy);
      y = _mm512_extractf64x4_pd(xy, 1);
    }
  };
  struct Pairs4 {
    __m256d x, y;
  };
  // Another per-particle Vec2 array (velocities) for the group's particles.
  static Pairs4 deinterleave(const Vec2* v, Index j, const Group4& g) {
    const __m512d xy =
        split4(_mm512_maskz_loadu_pd(g.doubles, reinterpret_cast<const double*>(v + j)));
    return {_mm512_castpd512_pd256(xy), _mm512_extractf64x4_pd(xy, 1)};
  }
  static void add_shares(double* out, const Group4& g, __m256d fjx, __m256d fjy) {
    _mm512_mask_storeu_pd(out, g.doubles,
                          _mm512_add_pd(_mm512_maskz_loadu_pd(g.doubles, out), join4(fjx, fjy)));
  }
  // The traversal's arithmetic on either width.
  static __m512d splat(__m512d, double v) { return _mm512_set1_pd(v); }
  static __m256d splat(__m256d, double v) { return _mm256_set1_pd(v); }
  static __m512d minus(__m512d a, __m512d b) { return _mm512_sub_pd(a, b); }
  static __m256d minus(__m256d a, __m256d b) { return _mm256_sub_pd(a, b); }
  static __m512d norm2(__m512d dx, __m512d dy) {
    return _mm512_fmadd_pd(dx, dx, _mm512_mul_pd(dy, dy));
  }
  static __m256d norm2(__m256d dx, __m256d dy) {
    return _mm256_fmadd_pd(dx, dx, _mm256_mul_pd(dy, dy));
  }
  static __mmask8 below(__mmask8 live, __m512d a, __m512d b) {
    return _mm512_mask_cmp_pd_mask(live, a, b, _CMP_LT_OQ);
  }
  static __mmask8 below(__mmask8 live, __m256d a, __m256d b) {
    return _mm256_mask_cmp_pd_mask(live, a, b, _CMP_LT_OQ);
  }
  static double sum_lanes(__m512d v) { return _mm512_reduce_add_pd(v); }
  static double sum_lanes(__m256d v) { return sum4(v); }
  // The lane sums of eight vectors a..h at once, as (a, e, b, f, c, g, d, h):
  // each vector's lanes paired as _mm512_reduce_add_pd pairs them (l + (l + 4),
  // then those two apart, then the last two), so each sum has the same bits.
  static __m512d sum8(__m512d a, __m512d b, __m512d c, __m512d d, __m512d e, __m512d f,
                      __m512d g, __m512d h) {
    auto halves = [](__m512d u, __m512d v) {  // (u0 + u4, .., u3 + u7, v0 + v4, ..)
      return _mm512_add_pd(_mm512_shuffle_f64x2(u, v, 0x44), _mm512_shuffle_f64x2(u, v, 0xEE));
    };
    auto quarters = [](__m512d u, __m512d v) {  // (u0 + u2, u1 + u3, u4 + u6, u5 + u7, v..)
      return _mm512_add_pd(_mm512_shuffle_f64x2(u, v, 0x88), _mm512_shuffle_f64x2(u, v, 0xDD));
    };
    const __m512d abcd = quarters(halves(a, b), halves(c, d));
    const __m512d efgh = quarters(halves(e, f), halves(g, h));
    return _mm512_add_pd(_mm512_unpacklo_pd(abcd, efgh), _mm512_unpackhi_pd(abcd, efgh));
  }
  // A tile of k (at most 4) particles from out (their x and y interleaved, as
  // a[] holds them) gets scale times its lane sums sx[q], sy[q], in one vector.
  static void add_tile_sums(Real* out, int k, const __m512d (&sx)[4], const __m512d (&sy)[4],
                            __m512d scale) {
    const __m512d sums = sum8(sx[0], sx[1], sx[2], sx[3], sy[0], sy[1], sy[2], sy[3]);
    const __mmask8 mine = static_cast<__mmask8>((1u << (2 * k)) - 1);
    _mm512_mask_storeu_pd(out, mine,
                          _mm512_fmadd_pd(scale, sums, _mm512_maskz_loadu_pd(mine, out)));
  }
#endif

 public:
  static constexpr bool kAvailable = SPHFLUID_CELL_PAIRS && kVector8;

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

#if SPHFLUID_CELL_PAIRS
  // After a block's pass its particles' sums are complete (no other block
  // adds to them): finish(first, last) is called on them by the same thread,
  // in the same parallel loop.
  struct NoFinish {
    void operator()(Index, Index) const {}
  };

  // rho_i = m (self + sum_j w(|r_ij|^2)) over j != i with |r_ij| < h, where
  // w(__m512d r2) is the kernel of r^2 (zero-safe: masked lanes are dropped).
  // Returns the number of distinct pairs.
  template <class WeightOfR2>
  std::int64_t density(const CellGrid& grid, const Vec2* x, Real h, Real m, Real self,
                       WeightOfR2 w, Real* rho, int threads) {
    const Index nx = grid.nx(), ny = grid.ny();
    const Index* start = grid.cell_starts();
    const __m512d h2 = _mm512_set1_pd(h * h);
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
          for (Index q0 = s0; q0 < s1; q0 += kDensityTile) {
            with_tile<kDensityTile>(s1 - q0, [&](auto tile) {
              constexpr int k = decltype(tile)::value;
              __m512d acc[k];
              for (int q = 0; q < k; ++q) acc[q] = _mm512_setzero_pd();
              // Returns the pairs it met (counted where asked), in a local
              // rather than in the thread's total, which stays in memory.
              auto run = [&](Index j0, Index j1, bool own, bool scatter, bool count) {
                unsigned met = 0;
                for (Index j = j0; j < j1; j += 8) {
                  const Group g(x, j, j1);
                  __m512d wj = _mm512_setzero_pd();
                  for (int q = 0; q < k; ++q) {
                    const Index i = q0 + q;
                    const __mmask8 live = own ? g.lanes & after<8>(i, j) : g.lanes;
                    if (!live) continue;
                    const __m512d dx = _mm512_sub_pd(_mm512_set1_pd(x[i].x()), g.x);
                    const __m512d dy = _mm512_sub_pd(_mm512_set1_pd(x[i].y()), g.y);
                    const __m512d r2 = _mm512_fmadd_pd(dx, dx, _mm512_mul_pd(dy, dy));
                    const __mmask8 in = _mm512_mask_cmp_pd_mask(live, r2, h2, _CMP_LT_OQ);
                    // A weight of a few instructions goes without a branch on in
                    // (whose mispredictions cost more); one with a square root not.
                    __m512d wv;
                    if constexpr (IsCheap<WeightOfR2>::value) {
                      wv = _mm512_maskz_mov_pd(in, w.unscaled(r2));
                    } else {
                      if (!in) continue;
                      wv = _mm512_maskz_mov_pd(in, w(r2));
                    }
                    acc[q] = _mm512_add_pd(acc[q], wv);
                    wj = _mm512_add_pd(wj, wv);
                    if (count) met += static_cast<unsigned>(__builtin_popcount(in));
                  }
                  if (scatter)
                    _mm512_mask_storeu_pd(
                        rho + j, g.lanes,
                        _mm512_add_pd(_mm512_maskz_loadu_pd(g.lanes, rho + j), wj));
                }
                return met;
              };
              row += run(q0 + 1, runs.own_end, true, true, true);
              row += run(runs.above0, runs.above1, false, runs.above_in_block, true);
              run(runs.below0, runs.below1, false, false, false);
              // Every pair of these particles is in now (no later cell adds to them).
              for (int q = 0; q < k; ++q) {
                const Index i = q0 + q;
                const Real sum = rho[i] + _mm512_reduce_add_pd(acc[q]);
                if constexpr (IsCheap<WeightOfR2>::value) {
                  rho[i] = m * (self + w.factor() * sum);
                } else {
                  rho[i] = m * (self + sum);
                }
              }
            });
          }
        }
        row_pairs[cy] = row;
        pairs += row;
      }
    }
    cut_pair_blocks(grid);
    return pairs;
  }

  // The pair passes' traversal: each block of rows by one thread, its a[]
  // zeroed first and finish(first, last) called on its particles at the end;
  // in it each cell's particles a tile of up to kPairTile at a time:
  // tile(k, q0, cx, cy, s0, s1, runs), k a std::integral_constant of the
  // tile's size.
  template <class Tile, class Finish>
  void for_each_pair_tile(const CellGrid& grid, Vec2* a, int threads, Tile&& tile,
                          Finish& finish) const {
    const Index nx = grid.nx(), ny = grid.ny();
    const Index* start = grid.cell_starts();
    const Index nb = pair_blocks();
#pragma omp parallel for schedule(static) num_threads(threads)
    for (Index b = 0; b < nb; ++b) {
      const Index y0 = pair_rows_[b], y1 = pair_rows_[b + 1];
      std::fill(a + start[y0 * nx], a + start[y1 * nx], Vec2::Zero());
      for (Index cy = y0; cy < y1; ++cy) {
        for (Index cx = 0; cx < nx; ++cx) {
          const Index c = cy * nx + cx, s0 = start[c], s1 = start[c + 1];
          const Runs runs = runs_of(start, nx, ny, cx, cy, y0, y1);
          for (Index q0 = s0; q0 < s1; q0 += kPairTile)
            with_tile<kPairTile>(s1 - q0,
                                 [&](auto k) { tile(k, q0, cx, cy, s0, s1, runs); });
        }
      }
      finish(start[y0 * nx], start[y1 * nx]);
    }
  }

  // Pair sums into a (overwritten) by the same cluster loop, in groups of
  // Pair::kLanes (8 or 4): pair.load(j, g) returns the per-group data of the
  // particles j; pair.add(i, data, in, dx, dy, r2, fi, fj) adds, on the lanes
  // in, i's share to fi and j's to fj (r = x_i - x_j).
  template <class Pair, class Finish = NoFinish>
  void pair_sums(const CellGrid& grid, const Vec2* x, Real h, Vec2* a, int threads,
                 const Pair& pair, Finish finish = {}) const {
    constexpr Index kW = Pair::kLanes;
    using V = typename Pair::V;
    using G = std::conditional_t<kW == 8, Group, Group4>;
    const V zero{}, h2 = splat(zero, h * h);
    Real* const ad = reinterpret_cast<Real*>(a);
    for_each_pair_tile(grid, a, threads, [&](auto tile, Index q0, Index, Index, Index, Index,
                                             const Runs& runs) {
      constexpr int k = decltype(tile)::value;
      V fx[k], fy[k];
      for (int q = 0; q < k; ++q) fx[q] = fy[q] = zero;
      auto run = [&](Index j0, Index j1, bool own, bool scatter) {
        for (Index j = j0; j < j1; j += kW) {
          const G g(x, j, j1);
          const auto data = pair.load(j, g);
          V fjx = zero, fjy = zero;
          for (int q = 0; q < k; ++q) {
            const Index i = q0 + q;
            const __mmask8 live = own ? g.lanes & after<kW>(i, j) : g.lanes;
            if (!live) continue;
            const V dx = minus(splat(zero, x[i].x()), g.x);
            const V dy = minus(splat(zero, x[i].y()), g.y);
            const V r2 = norm2(dx, dy);
            const __mmask8 in = below(live, r2, h2);
            if (!in) continue;
            pair.add(i, data, in, dx, dy, r2, fx[q], fy[q], fjx, fjy);
          }
          if (scatter) add_shares(ad + 2 * static_cast<std::size_t>(j), g, fjx, fjy);
        }
      };
      run(q0 + 1, runs.own_end, true, true);
      run(runs.above0, runs.above1, false, runs.above_in_block);
      run(runs.below0, runs.below1, false, false);
      if constexpr (kW == 8) {
        __m512d sx[4], sy[4];
        for (int q = 0; q < 4; ++q) {
          sx[q] = q < k ? fx[q] : zero;
          sy[q] = q < k ? fy[q] : zero;
        }
        // (1 * sums + a: one rounding, the same bits as sums + a)
        add_tile_sums(ad + 2 * static_cast<std::size_t>(q0), k, sx, sy, _mm512_set1_pd(1));
      } else {
        for (int q = 0; q < k; ++q) {
          Vec2& ai = a[q0 + q];
          ai.x() += sum_lanes(fx[q]);
          ai.y() += sum_lanes(fy[q]);
        }
      }
    }, finish);
  }

  // The seed's pressure and viscosity pair terms (eqs. 14, 17): with
  // d = max(h - r, 0), t = (p_i + p_j) d^2 / r r_ij + l d (v_j - v_i); i gets
  // t / rho_j, j gets -t / rho_i, and the sums times s = -m/2 spiky_grad are
  // the force densities (l = eta m visc_lap / s).
  // With RecipRoot, 1/r comes from rsqrt14 and two Newton steps (a few ulp
  // off the correctly rounded root) instead of a square root and a division:
  // prefers_recip_root() says where that pays.
  template <bool Viscosity, bool RecipRoot = false>
  struct SeedPair {
    static constexpr Index kLanes = 8;
    using V = __m512d;
    const Vec2* v;
    const Real* p;
    const Real* inv_rho;
    __m512d h, lap_c;  // h, l
    struct Data {
      __m512d p, ir, vx, vy;
    };
    Data load(Index j, const Group& g) const {
      Data d{};
      d.p = _mm512_maskz_loadu_pd(g.lanes, p + j);
      d.ir = _mm512_maskz_loadu_pd(g.lanes, inv_rho + j);
      if constexpr (Viscosity) {
        const Pairs8 vj = deinterleave(v, j, g);
        d.vx = vj.x;
        d.vy = vj.y;
      }
      return d;
    }
    void add(Index i, const Data& dj, __mmask8 in, __m512d dx, __m512d dy, __m512d r2,
             __m512d& fix, __m512d& fiy, __m512d& fjx, __m512d& fjy) const {
      const __m512d zero = _mm512_setzero_pd();
      // d = h - r, at least 0 (r may round up to just past h);
      // grad = spiky_grad d^2 / r, zero at r = 0 (coincident particles)
      const __mmask8 nz = _mm512_mask_cmp_pd_mask(in, r2, zero, _CMP_GT_OQ);
      __m512d d, grad;
      if constexpr (RecipRoot) {
        // y = 1/r (0 off nz): 14 bits, then y (3 - r^2 y^2) / 2 twice
        const __m512d half_r2 = _mm512_mul_pd(_mm512_set1_pd(0.5), r2);
        const __m512d three_halves = _mm512_set1_pd(1.5);
        __m512d y = _mm512_maskz_rsqrt14_pd(nz, r2);
        for (int step = 0; step < 2; ++step)
          y = _mm512_mul_pd(y, _mm512_fnmadd_pd(_mm512_mul_pd(half_r2, y), y, three_halves));
        d = _mm512_max_pd(_mm512_sub_pd(h, _mm512_mul_pd(r2, y)), zero);
        grad = _mm512_mul_pd(_mm512_mul_pd(d, d), y);
      } else {
        const __m512d rl = _mm512_sqrt_pd(r2);
        d = _mm512_max_pd(_mm512_sub_pd(h, rl), zero);
        grad = _mm512_maskz_div_pd(nz, _mm512_mul_pd(d, d), rl);
      }
      // fp = (p_i + p_j) d^2 / r
      const __m512d fp = _mm512_mul_pd(_mm512_add_pd(_mm512_set1_pd(p[i]), dj.p), grad);
      // t = fp r + lap (v_j - v_i): i gets t / rho_j, j gets -t / rho_i
      // (lanes outside the support are zero by mask, not by product)
      __m512d tx = _mm512_maskz_mul_pd(in, fp, dx);
      __m512d ty = _mm512_maskz_mul_pd(in, fp, dy);
      if constexpr (Viscosity) {
        const __m512d lap = _mm512_maskz_mul_pd(in, lap_c, d);
        const __m512d dvx = _mm512_sub_pd(dj.vx, _mm512_set1_pd(v[i].x()));
        const __m512d dvy = _mm512_sub_pd(dj.vy, _mm512_set1_pd(v[i].y()));
        tx = _mm512_mask_fmadd_pd(lap, in, dvx, tx);
        ty = _mm512_mask_fmadd_pd(lap, in, dvy, ty);
      }
      fix = _mm512_fmadd_pd(dj.ir, tx, fix);
      fiy = _mm512_fmadd_pd(dj.ir, ty, fiy);
      const __m512d iri = _mm512_set1_pd(inv_rho[i]);
      fjx = _mm512_fnmadd_pd(iri, tx, fjx);
      fjy = _mm512_fnmadd_pd(iri, ty, fjy);
    }
  };

  // wcsph's pair force (solver_wcsph.cpp, wcsph_pairs_once), as
  // accelerations: -m (p_i/rho_i^2 + p_j/rho_j^2 + Pi_ij) grad W(r_ij), with
  // Monaghan's Pi_ij on approaching pairs, plus Morris's viscosity; it is
  // antisymmetric, so j gets minus what i gets.
  template <bool Viscosity>
  struct WcsphPair {
    static constexpr Index kLanes = 4;  // its arithmetic outweighs the traversal
    using V = __m256d;
    const Vec2* v;
    const Real* rho;
    const Real* por2;     // p / rho^2
    const Real* inv_rho;
    // Wendland's 1/h and gradient factor, m, eps^2, alpha c0 hs, 2 m eta
    __m256d inv_h, grad, m, eps2, av, m_eta2;
    WcsphPair(const Vec2* v_, const Real* rho_, const Real* por2_, const Real* inv_rho_,
              Real inv_h_, Real grad_, Real m_, Real eps2_, Real av_, Real m_eta2_)
        : v(v_), rho(rho_), por2(por2_), inv_rho(inv_rho_), inv_h(_mm256_set1_pd(inv_h_)),
          grad(_mm256_set1_pd(grad_)), m(_mm256_set1_pd(m_)), eps2(_mm256_set1_pd(eps2_)),
          av(_mm256_set1_pd(av_)), m_eta2(_mm256_set1_pd(m_eta2_)) {}
    struct Data {
      __m256d rho, por2, ir, vx, vy;
    };
    Data load(Index j, const Group4& g) const {
      Data d{};
      d.rho = _mm256_maskz_loadu_pd(g.lanes, rho + j);
      d.por2 = _mm256_maskz_loadu_pd(g.lanes, por2 + j);
      if constexpr (Viscosity) d.ir = _mm256_maskz_loadu_pd(g.lanes, inv_rho + j);
      const Pairs4 vj = deinterleave(v, j, g);
      d.vx = vj.x;
      d.vy = vj.y;
      return d;
    }
    void add(Index i, const Data& dj, __mmask8 in, __m256d dx, __m256d dy, __m256d r2,
             __m256d& fix, __m256d& fiy, __m256d& fjx, __m256d& fjy) const {
      const __m256d zero = _mm256_setzero_pd();
      // grad W = grad (1 - q)^3 r, q = r / h (zero from q = 1 on)
      const __m256d q = _mm256_mul_pd(_mm256_sqrt_pd(r2), inv_h);
      const __m256d a = _mm256_max_pd(_mm256_sub_pd(_mm256_set1_pd(1), q), zero);
      const __m256d s = _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(grad, a), a), a);
      const __m256d gwx = _mm256_mul_pd(s, dx), gwy = _mm256_mul_pd(s, dy);
      const __m256d vijx = _mm256_sub_pd(_mm256_set1_pd(v[i].x()), dj.vx);
      const __m256d vijy = _mm256_sub_pd(_mm256_set1_pd(v[i].y()), dj.vy);
      const __m256d vr = _mm256_fmadd_pd(vijx, dx, _mm256_mul_pd(vijy, dy));
      // one division for both viscosities
      const __m256d inv_r2e =
          _mm256_maskz_div_pd(in, _mm256_set1_pd(1), _mm256_add_pd(r2, eps2));
      __m256d coef = _mm256_add_pd(_mm256_set1_pd(por2[i]), dj.por2);
      // + Pi_ij = -av vr / (r^2 + eps^2) * 2 / (rho_i + rho_j) when approaching
      const __mmask8 closing = _mm256_mask_cmp_pd_mask(in, vr, zero, _CMP_LT_OQ);
      if (closing) {
        const __m256d t = _mm256_mul_pd(
            _mm256_mul_pd(_mm256_mul_pd(av, vr), inv_r2e), _mm256_set1_pd(2));
        coef = _mm256_mask_sub_pd(
            coef, closing, coef,
            _mm256_maskz_div_pd(closing, t, _mm256_add_pd(_mm256_set1_pd(rho[i]), dj.rho)));
      }
      const __m256d mc = _mm256_mul_pd(m, coef);
      __m256d fx = _mm256_maskz_fnmadd_pd(in, mc, gwx, zero);
      __m256d fy = _mm256_maskz_fnmadd_pd(in, mc, gwy, zero);
      if constexpr (Viscosity) {  // Morris, Fox & Zhu (1997)
        const __m256d rgw = _mm256_fmadd_pd(dx, gwx, _mm256_mul_pd(dy, gwy));
        const __m256d mi = _mm256_mul_pd(m_eta2, _mm256_set1_pd(inv_rho[i]));
        const __m256d c = _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(mi, dj.ir), rgw), inv_r2e);
        fx = _mm256_mask3_fmadd_pd(c, vijx, fx, in);
        fy = _mm256_mask3_fmadd_pd(c, vijy, fy, in);
      }
      fix = _mm256_add_pd(fix, fx);
      fiy = _mm256_add_pd(fiy, fy);
      fjx = _mm256_sub_pd(fjx, fx);
      fjy = _mm256_sub_pd(fjy, fy);
    }
  };

  // SeedFloats' positions and velocities of the sorted particles [i0, i1) (the
  // cell of each from the same arithmetic as the sort's), their j shares
  // zeroed; f sized beforehand.
  static void fill_floats(const CellGrid& grid, const Vec2* x, const Vec2* v, Index i0,
                          Index i1, SeedFloats& f) {
    const Vec2 lo = grid.origin();
    const Real inv = grid.inv_width();
    const Index nx = grid.nx(), ny = grid.ny();
    float *ux = f.ux.data(), *uy = f.uy.data(), *vx = f.vx.data(), *vy = f.vy.data();
    std::fill(f.jx.begin() + i0, f.jx.begin() + i1, 0.0f);
    std::fill(f.jy.begin() + i0, f.jy.begin() + i1, 0.0f);
    Index i = i0;
    const __m512d lox = _mm512_set1_pd(lo.x()), loy = _mm512_set1_pd(lo.y());
    const __m512d iv = _mm512_set1_pd(inv);
    const __m256i zero = _mm256_setzero_si256();
    const __m256i last_x = _mm256_set1_epi32(nx - 1), last_y = _mm256_set1_epi32(ny - 1);
    for (; i + 8 <= i1; i += 8) {
      const double* p = reinterpret_cast<const double*>(x + i);
      const __m512d a = _mm512_loadu_pd(p), b = _mm512_loadu_pd(p + 8);
      const __m512d tx = _mm512_mul_pd(_mm512_sub_pd(x_of8(a, b), lox), iv);
      const __m512d ty = _mm512_mul_pd(_mm512_sub_pd(y_of8(a, b), loy), iv);
      const __m256i cx =
          _mm256_min_epi32(_mm256_max_epi32(_mm512_cvttpd_epi32(tx), zero), last_x);
      const __m256i cy =
          _mm256_min_epi32(_mm256_max_epi32(_mm512_cvttpd_epi32(ty), zero), last_y);
      _mm256_storeu_ps(ux + i, _mm512_cvtpd_ps(_mm512_sub_pd(tx, _mm512_cvtepi32_pd(cx))));
      _mm256_storeu_ps(uy + i, _mm512_cvtpd_ps(_mm512_sub_pd(ty, _mm512_cvtepi32_pd(cy))));
      const double* q = reinterpret_cast<const double*>(v + i);
      const __m512d c = _mm512_loadu_pd(q), d = _mm512_loadu_pd(q + 8);
      _mm256_storeu_ps(vx + i, _mm512_cvtpd_ps(x_of8(c, d)));
      _mm256_storeu_ps(vy + i, _mm512_cvtpd_ps(y_of8(c, d)));
    }
    for (; i < i1; ++i) {
      const Real tx = (x[i].x() - lo.x()) * inv, ty = (x[i].y() - lo.y()) * inv;
      ux[i] = static_cast<float>(tx - std::clamp<Index>(static_cast<Index>(tx), 0, nx - 1));
      uy[i] = static_cast<float>(ty - std::clamp<Index>(static_cast<Index>(ty), 0, ny - 1));
      vx[i] = static_cast<float>(v[i].x());
      vy[i] = static_cast<float>(v[i].y());
    }
  }

  static float float_not_above(Real v) {
    const float f = static_cast<float>(v);
    return static_cast<Real>(f) > v ? std::nextafter(f, 0.0f) : f;
  }

  // A float group of eight from j of the run [j.., j1) of the row dy cells
  // above i's (dy in -1, 0, 1): x and y relative to the corner of i's cell, in
  // cells. Its particles before `left` lie a cell to the left of i's, from
  // `right` on a cell to the right.
  struct GroupF : Lanes8 {
    __m256 x, y;
    GroupF(const SeedFloats& f, Index j, Index j1, Index left, Index right, __m256 dy)
        : Lanes8(j, j1) {
      const __m256i idx =
          _mm256_add_epi32(_mm256_set1_epi32(j), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
      const __m256 one = _mm256_set1_ps(1);
      x = _mm256_maskz_loadu_ps(lanes, f.ux.data() + j);
      x = _mm256_mask_sub_ps(x, _mm256_cmplt_epi32_mask(idx, _mm256_set1_epi32(left)), x, one);
      x = _mm256_mask_add_ps(x, _mm256_cmpge_epi32_mask(idx, _mm256_set1_epi32(right)), x, one);
      y = _mm256_add_ps(_mm256_maskz_loadu_ps(lanes, f.uy.data() + j), dy);
    }
  };
  // body(j0, j1, own, scatter, left, right, rows_up) on the runs of a tile of
  // cell (cx, cy) as in the double loops, with GroupF's cell bounds.
  template <class Body>
  static void float_runs(const Index* start, Index nx, Index cx, Index cy, Index q0, Index s0,
                         Index s1, const Runs& runs, Body&& body) {
    body(q0 + 1, runs.own_end, true, true, s0, s1, 0.f);
    if (runs.above1 > runs.above0) {
      const Index r = (cy + 1) * nx + cx;
      body(runs.above0, runs.above1, false, runs.above_in_block, start[r], start[r + 1], 1.f);
    }
    if (runs.below1 > runs.below0) {
      const Index r = (cy - 1) * nx + cx;
      body(runs.below0, runs.below1, false, false, start[r], start[r + 1], -1.f);
    }
  }

  // The seed's pair forces in float: with u in cells, hc = h / w, p^ = p / rho0
  // and r^ = rho0 / rho, f_i = s sum_j r^_j t_ij and f_j = -s sum_i r^_i t_ij,
  // t = (p^_i + p^_j) (hc - |u|)^2 / |u| u + l (hc - |u|) (v_j - v_i), where
  // s = -m/2 spiky_grad w^2 and l = eta m visc_lap w / (rho0 s) (eqs. 14, 17).
  // a gets the sums without the factor s (the finish applies it); the j
  // shares go to f.jx and f.jy (zeroed by fill_floats), and into a when the
  // block is done.
  template <bool Viscosity, class Finish>
  void seed_forces_float(const CellGrid& grid, SeedFloats& f, Real h, Real l, Vec2* a,
                         int threads, Finish finish) const {
    const Index nx = grid.nx();
    const Index* start = grid.cell_starts();
    const __m256 zero = _mm256_setzero_ps();
    // h in cells (a hair below 1: the cells are a hair wider than h), and its
    // square, each the largest float not above it, so that no pair at r >= h
    // counts
    const Real hc = h * grid.inv_width();
    const __m256 hv = _mm256_set1_ps(float_not_above(hc));
    const __m256 h2 = _mm256_set1_ps(float_not_above(hc * hc));
    const __m256 lap_c = _mm256_set1_ps(static_cast<float>(l));
    const __m512d one = _mm512_set1_pd(1);
    const float *ux = f.ux.data(), *uy = f.uy.data(), *vx = f.vx.data(), *vy = f.vy.data();
    const float *pp = f.p.data(), *ir = f.ir.data();
    float *jx = f.jx.data(), *jy = f.jy.data();
    Real* const ad = reinterpret_cast<Real*>(a);
    // A block's j shares are all in once its tiles are done.
    auto add_shares_then_finish = [&](Index i0, Index i1) {
      for (Index i = i0; i < i1; ++i) {
        ad[2 * i] += static_cast<Real>(jx[i]);
        ad[2 * i + 1] += static_cast<Real>(jy[i]);
      }
      finish(i0, i1);
    };
    for_each_pair_tile(grid, a, threads, [&](auto tile, Index q0, Index cx, Index cy, Index s0,
                                             Index s1, const Runs& runs) {
      constexpr int k = decltype(tile)::value;
      __m256 fx[k], fy[k];
      for (int q = 0; q < k; ++q) fx[q] = fy[q] = zero;
      float_runs(start, nx, cx, cy, q0, s0, s1, runs,
                 [&](Index j0, Index j1, bool own, bool scatter, Index left,
                     Index right, float rows_up) {
        const __m256 shift = _mm256_set1_ps(rows_up);
        for (Index j = j0; j < j1; j += 8) {
          const GroupF g(f, j, j1, left, right, shift);
          const __m256 pj = _mm256_maskz_loadu_ps(g.lanes, pp + j);
          const __m256 irj = _mm256_maskz_loadu_ps(g.lanes, ir + j);
          __m256 vxj = zero, vyj = zero;
          if constexpr (Viscosity) {
            vxj = _mm256_maskz_loadu_ps(g.lanes, vx + j);
            vyj = _mm256_maskz_loadu_ps(g.lanes, vy + j);
          }
          __m256 fjx = zero, fjy = zero;
          for (int q = 0; q < k; ++q) {
            const Index i = q0 + q;
            const __mmask8 live = own ? g.lanes & after<8>(i, j) : g.lanes;
            if (!live) continue;
            const __m256 dx = _mm256_sub_ps(_mm256_set1_ps(ux[i]), g.x);
            const __m256 dy = _mm256_sub_ps(_mm256_set1_ps(uy[i]), g.y);
            const __m256 r2 = _mm256_fmadd_ps(dx, dx, _mm256_mul_ps(dy, dy));
            const __mmask8 in = _mm256_mask_cmp_ps_mask(live, r2, h2, _CMP_LT_OQ);
            if (!in) continue;
            // as SeedPair::add: d = hc - r at least 0, zero at r = 0
            const __m256 rl = _mm256_sqrt_ps(r2);
            const __m256 d = _mm256_max_ps(_mm256_sub_ps(hv, rl), zero);
            const __mmask8 nz = _mm256_mask_cmp_ps_mask(in, r2, zero, _CMP_GT_OQ);
            const __m256 grad = _mm256_maskz_div_ps(nz, _mm256_mul_ps(d, d), rl);
            const __m256 fp = _mm256_mul_ps(_mm256_add_ps(_mm256_set1_ps(pp[i]), pj), grad);
            __m256 tx = _mm256_maskz_mul_ps(in, fp, dx);
            __m256 ty = _mm256_maskz_mul_ps(in, fp, dy);
            if constexpr (Viscosity) {
              const __m256 lap = _mm256_maskz_mul_ps(in, lap_c, d);
              const __m256 dvx = _mm256_sub_ps(vxj, _mm256_set1_ps(vx[i]));
              const __m256 dvy = _mm256_sub_ps(vyj, _mm256_set1_ps(vy[i]));
              tx = _mm256_mask_fmadd_ps(lap, in, dvx, tx);
              ty = _mm256_mask_fmadd_ps(lap, in, dvy, ty);
            }
            fx[q] = _mm256_fmadd_ps(irj, tx, fx[q]);
            fy[q] = _mm256_fmadd_ps(irj, ty, fy[q]);
            const __m256 iri = _mm256_set1_ps(ir[i]);
            fjx = _mm256_fnmadd_ps(iri, tx, fjx);
            fjy = _mm256_fnmadd_ps(iri, ty, fjy);
          }
          if (scatter) {
            float* const sx = jx + j;
            float* const sy = jy + j;
            _mm256_mask_storeu_ps(sx, g.lanes,
                                  _mm256_add_ps(_mm256_maskz_loadu_ps(g.lanes, sx), fjx));
            _mm256_mask_storeu_ps(sy, g.lanes,
                                  _mm256_add_ps(_mm256_maskz_loadu_ps(g.lanes, sy), fjy));
          }
        }
      });
      // a_i += s (sum of i's lanes, widened to double)
      __m512d wx[4], wy[4];
      for (int q = 0; q < 4; ++q) {
        wx[q] = q < k ? _mm512_cvtps_pd(fx[q]) : _mm512_setzero_pd();
        wy[q] = q < k ? _mm512_cvtps_pd(fy[q]) : _mm512_setzero_pd();
      }
      // (1 * sums + a: one rounding, the same bits as sums + a)
      add_tile_sums(ad + 2 * static_cast<std::size_t>(q0), k, wx, wy, one);
    }, add_shares_then_finish);
  }

  template <bool Viscosity>
  void wcsph_forces(const CellGrid& grid, const Vec2* x, Real h,
                    const WcsphPair<Viscosity>& pair, Vec2* a, int threads) const {
    pair_sums(grid, x, h, a, threads, pair);
  }

  template <bool Viscosity, bool RecipRoot = false, class Finish = NoFinish>
  void seed_forces(const CellGrid& grid, const Vec2* x, const Vec2* v, const Real* p,
                   const Real* inv_rho, Real h, Real l, Vec2* a, int threads,
                   Finish finish = {}) const {
    const SeedPair<Viscosity, RecipRoot> pair{v, p, inv_rho, _mm512_set1_pd(h),
                                              _mm512_set1_pd(l)};
    pair_sums(grid, x, h, a, threads, pair, finish);
  }
#endif

 private:
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
