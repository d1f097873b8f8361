#include "methods/wcsph/surface_energy.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

namespace sphfluid {

namespace {

// Room for n entries, a quarter more when it must grow: the node window
// follows the fluid's bounding box, and a drop that spreads step by step
// should not reallocate at every step.
template <class T>
void room(std::vector<T>& v, std::size_t n) {
  if (v.capacity() < n) v.reserve(n + n / 4);
}

// Whether the volumes and their pair term run eight candidates at a time over
// runs of the bin order (AVX-512, and no periodic axis; see evaluate).
#if defined(__AVX512F__)
constexpr bool kVectorRuns = true;
#else
constexpr bool kVectorRuns = false;
#endif

// The nodes of a periodic axis of length len at about spacing g: a whole
// number of them, so that the lattice wraps onto itself.
Index periodic_nodes(Real len, Real g) {
  return std::max<Index>(1, static_cast<Index>(std::lround(len / g)));
}

}  // namespace

SurfaceEnergy::SurfaceEnergy(Real sigma, Real support, Real spacing, const Vec2& origin,
                             const PeriodicBox& box)
    : w_(support), g_(Real(0.5) * spacing), eps_(Real(0.05) / support), origin_(origin),
      box_(box) {
  // A periodic axis: nodes anchored on its box, a whole number of them.
  auto periodic_axis = [&](Real length, Real lo, const char* name, Index& period, Real& at) {
    if (length < 2 * support + g_)
      throw std::invalid_argument(std::string("surface tension with wcsph needs a periodic ") +
                                  name + " axis at least " + std::to_string(2 * support + g_) +
                                  " m long (4 h plus half a spacing)");
    period = periodic_nodes(length, g_);
    at = lo;
  };
  if (box.x) periodic_axis(box.length.x(), box.lo.x(), "x", period_x_, origin_.x());
  if (box.y) periodic_axis(box.length.y(), box.lo.y(), "y", period_y_, origin_.y());
  gx_ = box.x ? box.length.x() / period_x_ : g_;
  gy_ = box.y ? box.length.y() / period_y_ : g_;
  // Bins of whole nodes, at least H along each axis.
  bin_x_ = std::max<Index>(1, static_cast<Index>(std::ceil(support / gx_ - 1e-9)));
  bin_y_ = std::max<Index>(1, static_cast<Index>(std::ceil(support / gy_ - 1e-9)));
  run_ = 8 * ((static_cast<Index>(std::ceil(2 * support / g_ - 1e-9)) + 7) / 8);
  const Real flat = flat_length(spacing);
  if (!(flat > 0))
    throw std::invalid_argument("surface tension with wcsph needs a smoothing length h well "
                                "above the spacing (h = 2 spacings is the default)");
  scale_ = sigma / flat;
}

// For sigma' = 1, the surface energy per unit length of the flat surface
// y = 0 of the square lattice of particles (i dx, -k dx), k >= 0, each with
// its volume 1 / sum W_H: the nodes' sum over a strip one dx wide from H above
// the surface to 2 H below it, less the same number of node rows deep inside
// (the lattice's own ripple, which the bulk has everywhere); averaged over
// 4 x 4 positions of the node lattice against the particles.
Real SurfaceEnergy::flat_length(Real dx) const {
  const Real H = w_.h, g = g_;
  const int reach = static_cast<int>(std::ceil(H / dx)) + 1;
  const int rows = static_cast<int>(std::ceil((3 * H + 2 * g) / g));
  const Real drop = 4 * H + 4 * g;  // the bulk reference rows lie this much deeper
  const int depth = static_cast<int>(std::ceil((H + g + rows * g + drop + H) / dx)) + 2;
  std::vector<Real> vol(static_cast<std::size_t>(depth) + 1);  // per row k
  for (int k = 0; k <= depth; ++k) {
    Real sum = 0;
    for (int i = -reach; i <= reach; ++i)
      for (int l = std::max(0, k - reach); l <= k + reach; ++l)
        sum += w_.value(dx * std::sqrt(Real(i * i + (l - k) * (l - k))));
    vol[k] = 1 / sum;
  }
  auto node_value = [&](const Vec2& p) {
    Vec2 grad = Vec2::Zero();
    const int i0 = static_cast<int>(std::floor(p.x() / dx));
    for (int i = i0 - reach; i <= i0 + reach + 1; ++i)
      for (int k = 0; k <= depth; ++k) {
        const Vec2 r = p - Vec2(i * dx, -k * dx);
        const Real r2 = r.squaredNorm();
        if (r2 < H * H) grad += vol[k] * w_.gradient(r, std::sqrt(r2));
      }
    return std::sqrt(grad.squaredNorm() + eps_ * eps_) - eps_;
  };
  const int per_dx = std::max(1, static_cast<int>(std::lround(dx / g)));
  const int offsets = 4;
  Real total = 0;
  for (int ox = 0; ox < offsets; ++ox)
    for (int oy = 0; oy < offsets; ++oy) {
      const Real sx = g * ox / offsets, sy = g * oy / offsets;
      Real excess = 0;
      for (int a = 0; a < per_dx; ++a)
        for (int r = 0; r < rows; ++r) {
          const Vec2 p(sx + a * g, sy + H + g - r * g);
          excess += node_value(p) - node_value(p - Vec2(0, drop));
        }
      total += excess * g / per_dx;
    }
  return total / (offsets * offsets);
}

void SurfaceEnergy::bin_particles(const Vec2* x, Index n) {
  const Real gx = gx_, gy = gy_;
  bx_ = std::max<Index>(1, nx_ / bin_x_);  // the last bin takes the remainder
  by_ = std::max<Index>(1, ny_ / bin_y_);
  room(bin_start_, static_cast<std::size_t>(bx_ * by_) + 1);
  room(bin_fill_, static_cast<std::size_t>(bx_ * by_));
  bin_start_.assign(static_cast<std::size_t>(bx_ * by_) + 1, 0);
  bin_of_.resize(n);
  for (Index i = 0; i < n; ++i) {
    const Index a = static_cast<Index>(std::floor((x[i].x() - origin_.x()) / gx)) - ix0_;
    const Index b = static_cast<Index>(std::floor((x[i].y() - origin_.y()) / gy)) - iy0_;
    const Index p = std::clamp<Index>(a / bin_x_, 0, bx_ - 1);
    const Index q = std::clamp<Index>(b / bin_y_, 0, by_ - 1);
    bin_of_[i] = q * bx_ + p;
    ++bin_start_[bin_of_[i] + 1];
  }
  for (std::size_t k = 1; k < bin_start_.size(); ++k) bin_start_[k] += bin_start_[k - 1];
  bin_items_.resize(n);
  bin_fill_.assign(bin_start_.begin(), bin_start_.end() - 1);
  // The vector loops read the positions in bin order: copied on the way.
  const bool copy = kVectorRuns && !box_.any();
  if (copy) {
    room(bin_x_pos_, static_cast<std::size_t>(n));
    room(bin_y_pos_, static_cast<std::size_t>(n));
    bin_x_pos_.resize(n);
    bin_y_pos_.resize(n);
  }
  for (Index i = 0; i < n; ++i) {  // in index order within a bin
    const Index k = bin_fill_[bin_of_[i]]++;
    bin_items_[k] = i;
    if (copy) {
      bin_x_pos_[k] = x[i].x();
      bin_y_pos_[k] = x[i].y();
    }
  }
}

void SurfaceEnergy::evaluate(const Vec2* x, Index n, Real mass, int threads) {
  energy_ = 0;
  room(acc_, static_cast<std::size_t>(n));
  acc_.resize(n);
  if (n == 0) return;
  Vec2* acc = acc_.data();
  const Real H = w_.h, H2 = H * H;
  const Real gx = gx_, gy = gy_;
  // The window of nodes within H of a particle. The solver's guard keeps
  // positions finite; a NaN here would index nodes far outside the window.
  Vec2 lo = x[0], hi = x[0];
  for (Index i = 0; i < n; ++i) {
    if (!x[i].allFinite())
      throw std::invalid_argument("surface energy: particle " + std::to_string(i) +
                                  " has a non-finite position");
    lo = lo.cwiseMin(x[i]);
    hi = hi.cwiseMax(x[i]);
  }
  if (box_.x) {
    ix0_ = 0;
    nx_ = period_x_;
  } else {  // plus room for the fixed-width runs below
    ix0_ = static_cast<Index>(std::floor((lo.x() - H - origin_.x()) / gx));
    nx_ = static_cast<Index>(std::ceil((hi.x() + H - origin_.x()) / gx)) - ix0_ + 1 + run_;
  }
  if (box_.y) {
    iy0_ = 0;
    ny_ = period_y_;
  } else {
    iy0_ = static_cast<Index>(std::floor((lo.y() - H - origin_.y()) / gy));
    ny_ = static_cast<Index>(std::ceil((hi.y() + H - origin_.y()) / gy)) - iy0_ + 1;
  }
  bin_particles(x, n);
  const Real x0 = origin_.x() + ix0_ * gx, y0 = origin_.y() + iy0_ * gy;  // node (0, 0)
  const Index nx = nx_, ny = ny_;
  const Real inv_gx = 1 / gx, inv_gy = 1 / gy;
  auto wrap = [](Index k, Index len) { return ((k % len) + len) % len; };
  // row(c0, count, rx0, dy) for the nodes within H of x_j whose (wrapped) row
  // lies in [row_lo, row_hi), in runs of consecutive nodes c0, c0 + 1, ...:
  // rx0 + k gx and dy are node c0 + k's offset from x_j. Offsets come from the
  // unwrapped node indices, so they are the nearest image across a seam.
  auto visit_rows = [&](const Vec2& xj, Index row_lo, Index row_hi, auto row) {
    const Index b_lo = static_cast<Index>(std::ceil((xj.y() - H - y0) * inv_gy));
    const Index b_hi = static_cast<Index>(std::floor((xj.y() + H - y0) * inv_gy));
    for (Index b = b_lo; b <= b_hi; ++b) {
      const Index bw = box_.y ? wrap(b, ny) : b;
      if (bw < row_lo || bw >= row_hi) continue;
      const Real dy = y0 + b * gy - xj.y(), rest = H2 - dy * dy;
      if (rest <= 0) continue;
      const std::size_t base = static_cast<std::size_t>(bw) * nx;
      if (!box_.x) {
        // A fixed run of run_ nodes (a multiple of 8) from the first one past
        // x_j - H: it covers every node within H, and the vector loops over it
        // have no remainder; the nodes beyond H contribute exactly 0.
        const Index a0 = static_cast<Index>(std::floor((xj.x() - H - x0) * inv_gx)) + 1;
        row(base + a0, run_, x0 + a0 * gx - xj.x(), dy);
        continue;
      }
      const Real half = std::sqrt(rest);
      Index a_lo = static_cast<Index>(std::ceil((xj.x() - half - x0) * inv_gx));
      const Index a_hi = static_cast<Index>(std::floor((xj.x() + half - x0) * inv_gx)) + 1;
      while (a_lo < a_hi) {  // at most two runs: up to the seam, then from it
        const Index aw = wrap(a_lo, nx), len = std::min<Index>(a_hi - a_lo, nx - aw);
        row(base + aw, len, x0 + a_lo * gx - xj.x(), dy);
        a_lo += len;
      }
    }
  };
  auto sep = [&](const Vec2& p, const Vec2& q) {
    return box_.any() ? box_.delta(p, q) : Vec2(p - q);
  };
  // The bins around bin p along an axis of nb bins: p - 1, p, p + 1 (wrapped
  // on a periodic axis; each bin once when there are fewer than three).
  auto around = [](Index p, Index nb, bool periodic, Index out[3]) {
    Index k = 0;
    if (periodic && nb < 3) {
      for (Index q = 0; q < nb; ++q) out[k++] = q;
      return k;
    }
    for (Index d = -1; d <= 1; ++d) {
      Index q = p + d;
      if (periodic) q = (q + nb) % nb;
      if (q >= 0 && q < nb) out[k++] = q;
    }
    return k;
  };
  // f(l) for every particle l in the 3 x 3 bins around bin_of_[j], in a fixed order.
  auto for_near = [&](Index j, auto f) {
    Index bys[3], bxs[3];
    const Index nby = around(bin_of_[j] / bx_, by_, box_.y, bys);
    const Index nbx = around(bin_of_[j] % bx_, bx_, box_.x, bxs);
    for (Index s = 0; s < nby; ++s)
      for (Index t = 0; t < nbx; ++t) {
        const Index bin = bys[s] * bx_ + bxs[t];
        for (Index k = bin_start_[bin]; k < bin_start_[bin + 1]; ++k) f(bin_items_[k]);
      }
  };

  // The particles' volumes 1 / sum_l W_H(x_j - x_l), self included.
  vol_.resize(n);
  gamma_.resize(n);
  Real* vol = vol_.data();
  Real* gamma = gamma_.data();
  // Without periodic axes the 3 x 3 bins around a particle are three runs of
  // the bin order: with the positions in that order (bin_particles), eight
  // candidates at a time, no branch (a candidate beyond H weighs exactly 0).
  [[maybe_unused]] const bool runs = kVectorRuns && !box_.any();
#if defined(__AVX512F__)
  const __m512d v_one = _mm512_set1_pd(1), v_zero = _mm512_setzero_pd();
  const __m512d v_inv_h = _mm512_set1_pd(w_.inv_h);
  // f(mask, k, dx, dy, q, a) for eight candidates from bin position k on:
  // x_j minus their positions, q = |r| / H and a = max(1 - q, 0); mask marks
  // the lanes that hold a candidate.
  auto near_lanes = [&](Index j, auto f) {
    const Index q = bin_of_[j] / bx_, p = bin_of_[j] % bx_;
    const Index p0 = std::max<Index>(p - 1, 0), p1 = std::min<Index>(p + 1, bx_ - 1);
    const __m512d xj = _mm512_set1_pd(x[j].x()), yj = _mm512_set1_pd(x[j].y());
    for (Index s = std::max<Index>(q - 1, 0); s <= std::min<Index>(q + 1, by_ - 1); ++s) {
      const Index k1 = bin_start_[s * bx_ + p1 + 1];
      for (Index k = bin_start_[s * bx_ + p0]; k < k1; k += 8) {
        const __mmask8 m = k1 - k >= 8 ? 0xFF : static_cast<__mmask8>((1u << (k1 - k)) - 1);
        const __m512d dx = _mm512_sub_pd(xj, _mm512_maskz_loadu_pd(m, bin_x_pos_.data() + k));
        const __m512d dy = _mm512_sub_pd(yj, _mm512_maskz_loadu_pd(m, bin_y_pos_.data() + k));
        const __m512d q8 =
            _mm512_mul_pd(_mm512_sqrt_pd(_mm512_fmadd_pd(dx, dx, _mm512_mul_pd(dy, dy))), v_inv_h);
        f(m, k, dx, dy, q8, _mm512_max_pd(_mm512_sub_pd(v_one, q8), v_zero));
      }
    }
  };
#endif
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index j = 0; j < n; ++j) {
    Real sum = 0;
#if defined(__AVX512F__)
    if (runs) {
      const __m512d v_w = _mm512_set1_pd(w_.w), v_four = _mm512_set1_pd(4);
      __m512d lanes = _mm512_setzero_pd();
      near_lanes(j, [&](__mmask8 m, Index, __m512d, __m512d, __m512d q8, __m512d a) {
        const __m512d a2 = _mm512_mul_pd(a, a);
        const __m512d wv = _mm512_mul_pd(_mm512_mul_pd(v_w, _mm512_mul_pd(a2, a2)),
                                         _mm512_fmadd_pd(v_four, q8, v_one));
        lanes = _mm512_mask_add_pd(lanes, m, lanes, wv);
      });
      vol[j] = 1 / _mm512_reduce_add_pd(lanes);
      continue;
    }
#endif
    const Vec2 xj = x[j];
    for_near(j, [&](Index l) {
      const Real r2 = sep(xj, x[l]).squaredNorm();
      if (r2 < H2) sum += w_.value(std::sqrt(r2));
    });
    vol[j] = 1 / sum;
  }

  // grad c on the nodes, scattered from the particles: each bin row's nodes
  // are filled by one thread from the particles of the bin rows around it, in
  // a fixed order (so the sums do not depend on the thread count).
  const std::size_t nodes = static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny);
  room(node_x_, nodes);
  room(node_y_, nodes);
  node_x_.assign(nodes, 0);
  node_y_.assign(nodes, 0);
  Real* nxs = node_x_.data();
  Real* nys = node_y_.data();
  const Real inv_h = w_.inv_h, grad = w_.grad;
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index q = 0; q < by_; ++q) {
    const Index row_lo = q * bin_y_, row_hi = q == by_ - 1 ? ny : (q + 1) * bin_y_;
    Index qs[3];
    const Index nq = around(q, by_, box_.y, qs);
    for (Index s = 0; s < nq; ++s)
      for (Index bin = qs[s] * bx_; bin < (qs[s] + 1) * bx_; ++bin)
        for (Index k = bin_start_[bin]; k < bin_start_[bin + 1]; ++k) {
          const Index j = bin_items_[k];
          const Real vg = vol[j] * grad;
          visit_rows(x[j], row_lo, row_hi, [&](std::size_t c0, Index count, Real rx0, Real dy) {
            Real* gxr = nxs + c0;
            Real* gyr = nys + c0;
            const Real dy2 = dy * dy;
#pragma omp simd
            for (Index i = 0; i < count; ++i) {  // V_j grad W_H(x_c - x_j)
              const Real rx = rx0 + i * gx;
              const Real om = std::max(1 - std::sqrt(rx * rx + dy2) * inv_h, Real(0));
              const Real f = vg * om * om * om;
              gxr[i] += f * rx;
              gyr[i] += f * dy;
            }
          });
        }
  }
  // n_c and the length estimate, per row, summed in row order.
  room(row_sums_, static_cast<std::size_t>(ny));
  row_sums_.assign(static_cast<std::size_t>(ny), 0);
  const Real eps = eps_;
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index b = 0; b < ny; ++b) {
    Real len_sum = 0;
    for (std::size_t c = static_cast<std::size_t>(b) * nx; c < static_cast<std::size_t>(b + 1) * nx;
         ++c) {
      const Real len = std::sqrt(nxs[c] * nxs[c] + nys[c] * nys[c] + eps * eps);
      nxs[c] /= len;
      nys[c] /= len;
      len_sum += len - eps;
    }
    row_sums_[b] = len_sum;
  }
  Real sl = 0;
  for (Index b = 0; b < ny; ++b) sl += row_sums_[b];
  const Real k_area = scale_ * gx * gy;
  energy_ = k_area * sl;

  // Through the node positions: sigma' A V_j sum_c H_H(x_c - x_j) n_c / m, and
  // gamma_j = sigma' A V_j^2 sum_c n_c . grad W_H(x_c - x_j) for the volumes.
  // H_H d = grad (1 - q)^2 ((1 - q) d - 3 (r . d) r / (H |r|)).
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index j = 0; j < n; ++j) {
    Real fx = 0, fy = 0, ng = 0;
#if defined(__AVX512F__)
    // Runs whose length is a multiple of 8 (every run without a periodic x
    // axis, and any other run of such a length): eight nodes at a time into
    // lanes that are summed once per particle.
    __m512d lx = _mm512_setzero_pd(), ly = _mm512_setzero_pd(), ln = _mm512_setzero_pd();
    const __m512d iota = _mm512_setr_pd(0, 1, 2, 3, 4, 5, 6, 7);
    const __m512d v_gx = _mm512_set1_pd(gx);  // v_inv_h, v_one, v_zero: above
    const __m512d v_3inv_h = _mm512_set1_pd(3 * inv_h), v_grad = _mm512_set1_pd(grad);
    const __m512d v_tiny = _mm512_set1_pd(1e-300);
#endif
    visit_rows(x[j], 0, ny, [&](std::size_t c0, Index count, Real rx0, Real dy) {
      const Real* ncx = nxs + c0;
      const Real* ncy = nys + c0;
#if defined(__AVX512F__)
      if (count % 8 == 0) {
        const __m512d v_dy = _mm512_set1_pd(dy), v_dy2 = _mm512_set1_pd(dy * dy);
        const __m512d v_rx0 = _mm512_set1_pd(rx0);
        for (Index i = 0; i < count; i += 8) {
          const __m512d rx =
              _mm512_fmadd_pd(_mm512_add_pd(_mm512_set1_pd(Real(i)), iota), v_gx, v_rx0);
          const __m512d rl = _mm512_sqrt_pd(_mm512_fmadd_pd(rx, rx, v_dy2));
          const __m512d om = _mm512_max_pd(_mm512_fnmadd_pd(rl, v_inv_h, v_one), v_zero);
          const __m512d cx = _mm512_loadu_pd(ncx + i), cy = _mm512_loadu_pd(ncy + i);
          const __m512d rd = _mm512_fmadd_pd(rx, cx, _mm512_mul_pd(v_dy, cy));
          const __m512d t =
              _mm512_div_pd(_mm512_mul_pd(v_3inv_h, rd), _mm512_max_pd(rl, v_tiny));
          const __m512d c2 = _mm512_mul_pd(v_grad, _mm512_mul_pd(om, om));
          lx = _mm512_fmadd_pd(c2, _mm512_fmsub_pd(om, cx, _mm512_mul_pd(t, rx)), lx);
          ly = _mm512_fmadd_pd(c2, _mm512_fmsub_pd(om, cy, _mm512_mul_pd(t, v_dy)), ly);
          ln = _mm512_fmadd_pd(_mm512_mul_pd(c2, om), rd, ln);
        }
        return;
      }
#endif
      const Real dy2 = dy * dy;
      // Sums of the row in locals (reduced straight into the references, the
      // vector loop's lanes were added one by one through memory).
      Real sx = 0, sy = 0, sn = 0;
#pragma omp simd reduction(+ : sx, sy, sn)
      for (Index i = 0; i < count; ++i) {
        const Real rx = rx0 + i * gx;
        const Real rl = std::sqrt(rx * rx + dy2);
        const Real om = std::max(1 - rl * inv_h, Real(0));
        const Real rd = rx * ncx[i] + dy * ncy[i];
        const Real t = 3 * rd * inv_h / std::max(rl, Real(1e-300));
        const Real c2 = grad * om * om;
        sx += c2 * (om * ncx[i] - t * rx);
        sy += c2 * (om * ncy[i] - t * dy);
        sn += c2 * om * rd;
      }
      fx += sx;
      fy += sy;
      ng += sn;
    });
#if defined(__AVX512F__)
    fx += _mm512_reduce_add_pd(lx);
    fy += _mm512_reduce_add_pd(ly);
    ng += _mm512_reduce_add_pd(ln);
#endif
    acc[j] = Vec2(fx, fy) * (k_area * vol[j] / mass);
    gamma[j] = k_area * vol[j] * vol[j] * ng;
  }
  // Through the volumes: sum_l (gamma_j + gamma_l) grad W_H(x_j - x_l) / m.
#if defined(__AVX512F__)
  if (runs) {
    room(bin_gamma_, static_cast<std::size_t>(n));
    bin_gamma_.resize(n);
    for (Index k = 0; k < n; ++k) bin_gamma_[k] = gamma[bin_items_[k]];
  }
#endif
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index j = 0; j < n; ++j) {
    const Vec2 xj = x[j];
    const Real gj = gamma[j];
    Vec2 f = Vec2::Zero();
#if defined(__AVX512F__)
    if (runs) {  // (gamma_j + gamma_l) grad (1 - q)^3 r, eight candidates at a time
      const __m512d v_gj = _mm512_set1_pd(gj), v_grad = _mm512_set1_pd(w_.grad);
      __m512d lx = _mm512_setzero_pd(), ly = _mm512_setzero_pd();
      near_lanes(j, [&](__mmask8 m, Index k, __m512d dx, __m512d dy, __m512d, __m512d a) {
        const __m512d g = _mm512_add_pd(v_gj, _mm512_maskz_loadu_pd(m, bin_gamma_.data() + k));
        const __m512d c = _mm512_mul_pd(_mm512_mul_pd(g, v_grad),
                                        _mm512_mul_pd(_mm512_mul_pd(a, a), a));
        lx = _mm512_mask3_fmadd_pd(c, dx, lx, m);
        ly = _mm512_mask3_fmadd_pd(c, dy, ly, m);
      });
      acc[j] += Vec2(_mm512_reduce_add_pd(lx), _mm512_reduce_add_pd(ly)) / mass;
      continue;
    }
#endif
    for_near(j, [&](Index l) {
      const Vec2 r = sep(xj, x[l]);
      const Real r2 = r.squaredNorm();
      if (r2 < H2) f += (gj + gamma[l]) * w_.gradient(r, std::sqrt(r2));
    });
    acc[j] += f / mass;
  }
}

std::size_t SurfaceEnergy::bytes() const {
  return (node_x_.capacity() + node_y_.capacity() + row_sums_.capacity() + vol_.capacity() +
          gamma_.capacity() + bin_x_pos_.capacity() + bin_y_pos_.capacity() +
          bin_gamma_.capacity()) *
             sizeof(Real) +
         acc_.capacity() * sizeof(Vec2) +
         (bin_start_.capacity() + bin_items_.capacity() + bin_of_.capacity() +
          bin_fill_.capacity()) *
             sizeof(Index);
}

}  // namespace sphfluid
