// The frames of the cell-cluster pair sums (cell_pairs.hpp): where a
// traversal's positions come from, in which lanes, and where the second
// particle's shares and the tile's sums go. PositionFrame reads the particles'
// positions in double (eight or four lanes) and adds every share to a[];
// CellFloatFrame reads float positions taken relative to the corner of each
// particle's cell (so a separation keeps float's precision at any resolution
// and anywhere in the domain) and keeps the second particle's shares in float
// until its block is done. No physics here.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/types.hpp"
#include "neighbours/cell_pairs.hpp"
#include "neighbours/grid.hpp"
#include "simd/ints.hpp"
#include "simd/points.hpp"

namespace sphfluid {

// The float positions of the sorted particles: u = (x - corner of its cell) /
// w, the cell width (0 <= u < 1), and the second particle's shares, in float.
// A candidate's u is moved by the whole cells between the two particles'
// cells, so a separation is exact to about 6e-8 w.
struct CellFloats {
  std::vector<float> ux, uy;  // position in its cell / w
  std::vector<float> jx, jy;  // j's shares of the pair sums (zeroed with the positions)
  void resize(Index n) {
    for (auto* a : {&ux, &uy, &jx, &jy}) a->resize(static_cast<std::size_t>(n));
  }
  std::size_t bytes() const {
    std::size_t sum = 0;
    for (const auto* a : {&ux, &uy, &jx, &jy}) sum += a->capacity();
    return sum * sizeof(float);
  }
  // The positions of particles [i0, i1) (each cell from the same arithmetic
  // as the sort's), their shares zeroed; sized beforehand.
  void fill(const CellGrid& grid, const Vec2* x, Index i0, Index i1) {
    const Vec2 lo = grid.origin();
    const Real inv = grid.inv_width();
    const Index nx = grid.nx(), ny = grid.ny();
    std::fill(jx.begin() + i0, jx.begin() + i1, 0.0f);
    std::fill(jy.begin() + i0, jy.begin() + i1, 0.0f);
    Index i = i0;
#if SPHFLUID_AVX512
    using simd::D8;
    using simd::I8;
    const D8 lox = D8::splat(lo.x()), loy = D8::splat(lo.y()), iv = D8::splat(inv);
    const I8 zero = I8::splat(0), last_x = I8::splat(nx - 1), last_y = I8::splat(ny - 1);
    for (; i + 8 <= i1; i += 8) {
      D8 px, py;
      simd::load_xy8(x[i].data(), px, py);
      const D8 tx = (px - lox) * iv, ty = (py - loy) * iv;
      const I8 cx = min(max(simd::truncate(tx), zero), last_x);
      const I8 cy = min(max(simd::truncate(ty), zero), last_y);
      simd::narrow(tx - simd::to_double(cx)).store(ux.data() + i, 0xFF);
      simd::narrow(ty - simd::to_double(cy)).store(uy.data() + i, 0xFF);
    }
#endif
    for (; i < i1; ++i) {
      const Real tx = (x[i].x() - lo.x()) * inv, ty = (x[i].y() - lo.y()) * inv;
      ux[i] = static_cast<float>(tx - clamp_cell(tx, nx - 1));
      uy[i] = static_cast<float>(ty - clamp_cell(ty, ny - 1));
    }
  }
};

// The largest float not above v.
inline float float_not_above(Real v) {
  const float f = static_cast<float>(v);
  return static_cast<Real>(f) > v ? std::nextafter(f, 0.0f) : f;
}

#if SPHFLUID_AVX512
// Positions in double from the particles' array, on L = D8 or D4.
template <class L>
class PositionFrame {
 public:
  using Lane = L;
  using Span = simd::Span<L>;
  static constexpr std::size_t kMaxOutputs = 8;  // every share goes to its output
  PositionFrame(const Vec2* x, Real h) : x_(x), h2_(simd::splat<L>(h * h)) {}

  SPHFLUID_INLINE L support2() const { return h2_; }
  SPHFLUID_INLINE void position(Index i, L& x, L& y) const {
    x = simd::splat<L>(x_[i].x());
    y = simd::splat<L>(x_[i].y());
  }
  struct Run {
    const Vec2* x;
    SPHFLUID_INLINE void positions(Index j, const Span& s, L& px, L& py) const {
      simd::load_xy(x[j].data(), s, px, py);
    }
  };
  // body(run, j0, j1, own, scatter) for the tile's three runs.
  template <class Body>
  SPHFLUID_INLINE void for_runs(const CellGrid&, Index, Index, Index q0, Index, Index,
                const CellPairs::Runs& runs, Body&& body) const {
    const Run run{x_};
    body(run, q0 + 1, runs.own_end, true, true);
    body(run, runs.above0, runs.above1, false, runs.above_in_block);
    body(run, runs.below0, runs.below1, false, false);
  }
  SPHFLUID_INLINE void add_shares(Index j, const Span& s, L fjx, L fjy, Vec2* a) const {
    simd::add_xy(a[j].data(), s, fjx, fjy);
  }
  // The tile's k particles from q0 get their lane sums.
  template <int K>
  SPHFLUID_INLINE void add_tile(Index q0, int k, const L (&fx)[K], const L (&fy)[K], Vec2* a) const {
    if constexpr (std::is_same_v<L, simd::D8>) {
      simd::D8 sx[4], sy[4];
      for (int q = 0; q < 4; ++q) {
        sx[q] = q < k ? fx[q] : simd::zero<L>();
        sy[q] = q < k ? fy[q] : simd::zero<L>();
      }
      // (1 * sums + a: one rounding, the same bits as sums + a)
      simd::add_lane_sums4(a[q0].data(), k, sx, sy, simd::D8::splat(1));
    } else {
      for (int q = 0; q < k; ++q) {
        Vec2& ai = a[q0 + q];
        ai.x() += reduce_add(fx[q]);
        ai.y() += reduce_add(fy[q]);
      }
    }
  }
  void block_done(Index, Index, Vec2*) const {}

 private:
  const Vec2* x_;
  L h2_;
};

// Float positions in cells (CellFloats), on eight float lanes; the j shares
// into the frame's jx, jy, and into a[] when their block is done.
class CellFloatFrame {
 public:
  using Lane = simd::F8;
  using Span = simd::Span8;
  static constexpr std::size_t kMaxOutputs = 1;  // j's shares in the frame's jx, jy
  // h: the support in metres; the frame takes it in cells (a hair below 1:
  // the cells are a hair wider than h), squared, as the largest float not
  // above it, so that no pair at r >= h counts.
  CellFloatFrame(CellFloats& f, const CellGrid& grid, Real h)
      : ux_(f.ux.data()), uy_(f.uy.data()), jx_(f.jx.data()), jy_(f.jy.data()),
        h2_(simd::F8::splat(float_not_above(support(grid, h) * support(grid, h)))) {}
  // The support in cells, as the frame's terms take it.
  static Real support(const CellGrid& grid, Real h) { return h * grid.inv_width(); }

  simd::F8 support2() const { return h2_; }
  SPHFLUID_INLINE void position(Index i, simd::F8& x, simd::F8& y) const {
    x = simd::F8::splat(ux_[i]);
    y = simd::F8::splat(uy_[i]);
  }
  // A run of the row dy cells above i's (dy in -1, 0, 1): its particles
  // before `left` lie a cell to the left of i's, from `right` on a cell to
  // the right.
  struct Run {
    const float* ux;
    const float* uy;
    Index left, right;
    simd::F8 shift;
    SPHFLUID_INLINE void positions(Index j, const Span& s, simd::F8& px, simd::F8& py) const {
      const simd::F8 one = simd::F8::splat(1);
      const simd::I8 index = simd::I8::splat(j) + simd::I8::iota();
      simd::F8 x = simd::F8::load(ux + j, s.lanes);
      x = mask_sub(x, lt(index, simd::I8::splat(left)), x, one);
      x = mask_add(x, ge(index, simd::I8::splat(right)), x, one);
      px = x;
      py = simd::F8::load(uy + j, s.lanes) + shift;
    }
  };
  template <class Body>
  SPHFLUID_INLINE void for_runs(const CellGrid& grid, Index cx, Index cy, Index q0, Index s0, Index s1,
                const CellPairs::Runs& runs, Body&& body) const {
    const Index nx = grid.nx();
    const Index* start = grid.cell_starts();
    body(Run{ux_, uy_, s0, s1, simd::F8::splat(0.f)}, q0 + 1, runs.own_end, true, true);
    if (runs.above1 > runs.above0) {
      const Index r = (cy + 1) * nx + cx;
      body(Run{ux_, uy_, start[r], start[r + 1], simd::F8::splat(1.f)}, runs.above0,
           runs.above1, false, runs.above_in_block);
    }
    if (runs.below1 > runs.below0) {
      const Index r = (cy - 1) * nx + cx;
      body(Run{ux_, uy_, start[r], start[r + 1], simd::F8::splat(-1.f)}, runs.below0,
           runs.below1, false, false);
    }
  }
  SPHFLUID_INLINE void add_shares(Index j, const Span& s, simd::F8 fjx, simd::F8 fjy, Vec2*) const {
    (simd::F8::load(jx_ + j, s.lanes) + fjx).store(jx_ + j, s.lanes);
    (simd::F8::load(jy_ + j, s.lanes) + fjy).store(jy_ + j, s.lanes);
  }
  // a_i += the sum of i's lanes, widened to double.
  template <int K>
  SPHFLUID_INLINE void add_tile(Index q0, int k, const simd::F8 (&fx)[K], const simd::F8 (&fy)[K],
                Vec2* a) const {
    simd::D8 wx[4], wy[4];
    for (int q = 0; q < 4; ++q) {
      wx[q] = q < k ? simd::widen(fx[q]) : simd::zero<simd::D8>();
      wy[q] = q < k ? simd::widen(fy[q]) : simd::zero<simd::D8>();
    }
    simd::add_lane_sums4(a[q0].data(), k, wx, wy, simd::D8::splat(1));
  }
  // A block's j shares are all in once its tiles are done.
  void block_done(Index i0, Index i1, Vec2* a) const {
    Real* const ad = reinterpret_cast<Real*>(a);
    for (Index i = i0; i < i1; ++i) {
      ad[2 * i] += static_cast<Real>(jx_[i]);
      ad[2 * i + 1] += static_cast<Real>(jy_[i]);
    }
  }

 private:
  const float* ux_;
  const float* uy_;
  float* jx_;
  float* jy_;
  simd::F8 h2_;
};
#endif  // SPHFLUID_AVX512

}  // namespace sphfluid
