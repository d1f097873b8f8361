// wcsph's surface tension (surface_energy.hpp): the node lattice, the
// particles binned around it, and the phases of an evaluation, each a loop
// over particles or nodes with the terms of terms/surface_energy.hpp.
#include "methods/wcsph/surface_energy.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/room.hpp"
#include "simd/lanes.hpp"
#include "terms/surface_energy.hpp"

namespace sphfluid {

namespace {

// Whether the volumes and their pair term run eight candidates at a time over
// runs of the bin order (where the lanes run, and without a periodic axis).
constexpr bool kVectorRuns = SPHFLUID_AVX512;

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
  place_window(x, n);
  bin_particles(x, n);
  volumes(x, n, threads);
  scatter_gradient(x, threads);
  normalise_nodes(threads);
  node_forces(x, n, mass, threads);
  volume_forces(x, n, mass, threads);
}

// The window of nodes within H of a particle. The solver's guard keeps
// positions finite; a NaN here would index nodes far outside the window.
void SurfaceEnergy::place_window(const Vec2* x, Index n) {
  const Real H = w_.h;
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
  } else {  // plus room for the fixed-width runs of visit_rows
    ix0_ = static_cast<Index>(std::floor((lo.x() - H - origin_.x()) / gx_));
    nx_ = static_cast<Index>(std::ceil((hi.x() + H - origin_.x()) / gx_)) - ix0_ + 1 + run_;
  }
  if (box_.y) {
    iy0_ = 0;
    ny_ = period_y_;
  } else {
    iy0_ = static_cast<Index>(std::floor((lo.y() - H - origin_.y()) / gy_));
    ny_ = static_cast<Index>(std::ceil((hi.y() + H - origin_.y()) / gy_)) - iy0_ + 1;
  }
}

namespace {

Index wrap(Index k, Index len) { return ((k % len) + len) % len; }

// The bins around bin p along an axis of nb bins: p - 1, p, p + 1 (wrapped
// on a periodic axis; each bin once when there are fewer than three).
Index around(Index p, Index nb, bool periodic, Index out[3]) {
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
}

}  // namespace

// row(c0, count, rx0, dy) for the nodes within H of x_j whose (wrapped) row
// lies in [row_lo, row_hi), in runs of consecutive nodes c0, c0 + 1, ...:
// rx0 + k gx and dy are node c0 + k's offset from x_j. Offsets come from the
// unwrapped node indices, so they are the nearest image across a seam.
template <class Row>
void SurfaceEnergy::visit_rows(const Vec2& xj, Index row_lo, Index row_hi, Row&& row) const {
  const Real H = w_.h, H2 = H * H;
  const Real x0 = origin_.x() + ix0_ * gx_, y0 = origin_.y() + iy0_ * gy_;  // node (0, 0)
  const Real inv_gx = 1 / gx_, inv_gy = 1 / gy_;
  const Index b_lo = static_cast<Index>(std::ceil((xj.y() - H - y0) * inv_gy));
  const Index b_hi = static_cast<Index>(std::floor((xj.y() + H - y0) * inv_gy));
  for (Index b = b_lo; b <= b_hi; ++b) {
    const Index bw = box_.y ? wrap(b, ny_) : b;
    if (bw < row_lo || bw >= row_hi) continue;
    const Real dy = y0 + b * gy_ - xj.y(), rest = H2 - dy * dy;
    if (rest <= 0) continue;
    const std::size_t base = static_cast<std::size_t>(bw) * nx_;
    if (!box_.x) {
      // A fixed run of run_ nodes (a multiple of 8) from the first one past
      // x_j - H: it covers every node within H, and the lane loops over it
      // have no remainder; the nodes beyond H contribute exactly 0.
      const Index a0 = static_cast<Index>(std::floor((xj.x() - H - x0) * inv_gx)) + 1;
      row(base + a0, run_, x0 + a0 * gx_ - xj.x(), dy);
      continue;
    }
    const Real half = std::sqrt(rest);
    Index a_lo = static_cast<Index>(std::ceil((xj.x() - half - x0) * inv_gx));
    const Index a_hi = static_cast<Index>(std::floor((xj.x() + half - x0) * inv_gx)) + 1;
    while (a_lo < a_hi) {  // at most two runs: up to the seam, then from it
      const Index aw = wrap(a_lo, nx_), len = std::min<Index>(a_hi - a_lo, nx_ - aw);
      row(base + aw, len, x0 + a_lo * gx_ - xj.x(), dy);
      a_lo += len;
    }
  }
}

// f(l) for every particle l in the 3 x 3 bins around bin_of_[j], in a fixed
// order; across a periodic seam sep() gives the nearest image.
template <class F>
void SurfaceEnergy::for_near(Index j, F&& f) const {
  Index bys[3], bxs[3];
  const Index nby = around(bin_of_[j] / bx_, by_, box_.y, bys);
  const Index nbx = around(bin_of_[j] % bx_, bx_, box_.x, bxs);
  for (Index s = 0; s < nby; ++s)
    for (Index t = 0; t < nbx; ++t) {
      const Index bin = bys[s] * bx_ + bxs[t];
      for (Index k = bin_start_[bin]; k < bin_start_[bin + 1]; ++k) f(bin_items_[k]);
    }
}

#if SPHFLUID_AVX512
// Without periodic axes the 3 x 3 bins around a particle are three runs of
// the bin order: with the positions in that order (bin_particles), eight
// candidates at a time, no branch (a candidate beyond H weighs exactly 0):
// f(mask, k, dx, dy, r2) for eight candidates from bin position k on, x_j
// minus their positions; mask marks the lanes that hold a candidate.
template <class F>
void SurfaceEnergy::near_lanes(const Vec2& xj, Index j, F&& f) const {
  using simd::D8;
  const Index q = bin_of_[j] / bx_, p = bin_of_[j] % bx_;
  const Index p0 = std::max<Index>(p - 1, 0), p1 = std::min<Index>(p + 1, bx_ - 1);
  const D8 x = D8::splat(xj.x()), y = D8::splat(xj.y());
  for (Index s = std::max<Index>(q - 1, 0); s <= std::min<Index>(q + 1, by_ - 1); ++s) {
    const Index k1 = bin_start_[s * bx_ + p1 + 1];
    for (Index k = bin_start_[s * bx_ + p0]; k < k1; k += 8) {
      const simd::Mask8 m = simd::first_lanes(k1 - k);
      const D8 dx = x - D8::load(bin_x_pos_.data() + k, m);
      const D8 dy = y - D8::load(bin_y_pos_.data() + k, m);
      f(m, k, dx, dy, simd::fmadd(dx, dx, dy * dy));
    }
  }
}
#endif

// W10: the particles' volumes 1 / sum_l W_H(x_j - x_l), self included.
void SurfaceEnergy::volumes(const Vec2* x, Index n, int threads) {
  vol_.resize(n);
  gamma_.resize(n);
  Real* vol = vol_.data();
  const WendlandWeight weight(w_);
  const Real H2 = w_.h * w_.h;
  [[maybe_unused]] const bool runs = kVectorRuns && !box_.any();
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index j = 0; j < n; ++j) {
#if SPHFLUID_AVX512
    if (runs) {
      simd::D8 lanes = simd::zero<simd::D8>();
      near_lanes(x[j], j, [&](simd::Mask8 m, Index, simd::D8, simd::D8, simd::D8 r2) {
        lanes = mask_add(lanes, m, lanes, weight(r2));
      });
      vol[j] = 1 / reduce_add(lanes);
      continue;
    }
#endif
    Real sum = 0;
    const Vec2 xj = x[j];
    for_near(j, [&](Index l) {
      const Real r2 = sep(xj, x[l]).squaredNorm();
      if (r2 < H2) sum += weight(r2);
    });
    vol[j] = 1 / sum;
  }
}

// W10: grad c on the nodes, scattered from the particles: each bin row's
// nodes are filled by one thread from the particles of the bin rows around
// it, in a fixed order (so the sums do not depend on the thread count).
void SurfaceEnergy::scatter_gradient(const Vec2* x, int threads) {
  const std::size_t nodes = static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_);
  room(node_x_, nodes);
  room(node_y_, nodes);
  node_x_.assign(nodes, 0);
  node_y_.assign(nodes, 0);
  Real* nxs = node_x_.data();
  Real* nys = node_y_.data();
  const Real* vol = vol_.data();
  const Wendland W = w_;
  const Real gx = gx_;
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index q = 0; q < by_; ++q) {
    const Index row_lo = q * bin_y_, row_hi = q == by_ - 1 ? ny_ : (q + 1) * bin_y_;
    Index qs[3];
    const Index nq = around(q, by_, box_.y, qs);
    for (Index s = 0; s < nq; ++s)
      for (Index bin = qs[s] * bx_; bin < (qs[s] + 1) * bx_; ++bin)
        for (Index k = bin_start_[bin]; k < bin_start_[bin + 1]; ++k) {
          const Index j = bin_items_[k];
          const Real vg = vol[j] * W.grad;
          visit_rows(x[j], row_lo, row_hi, [&](std::size_t c0, Index count, Real rx0, Real dy) {
            Real* gxr = nxs + c0;
            Real* gyr = nys + c0;
            const Real dy2 = dy * dy;
#pragma omp simd
            for (Index i = 0; i < count; ++i) {  // V_j grad W_H(x_c - x_j)
              const Real rx = rx0 + i * gx;
              const Real f = W.gradient_times(vg, std::sqrt(rx * rx + dy2));
              gxr[i] += f * rx;
              gyr[i] += f * dy;
            }
          });
        }
  }
}

// W11: n_c = grad c / sqrt(|grad c|^2 + eps^2) and the energy, the length
// estimate summed per row, in row order.
void SurfaceEnergy::normalise_nodes(int threads) {
  room(row_sums_, static_cast<std::size_t>(ny_));
  row_sums_.assign(static_cast<std::size_t>(ny_), 0);
  Real* nxs = node_x_.data();
  Real* nys = node_y_.data();
  const Real eps = eps_;
  const Index nx = nx_, ny = ny_;
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
  energy_ = scale_ * gx_ * gy_ * sl;
}

// W12 through the node positions: sigma' A V_j sum_c H_H(x_c - x_j) n_c / m,
// and gamma_j = sigma' A V_j^2 sum_c n_c . grad W_H(x_c - x_j) for the
// volumes (A = gx gy, a node's area). Runs whose length is a multiple of 8
// (every run without a periodic x axis, and any other run of such a length)
// take eight nodes at a time into lanes that are summed once per particle.
void SurfaceEnergy::node_forces(const Vec2* x, Index n, Real mass, int threads) {
  const Real* nxs = node_x_.data();
  const Real* nys = node_y_.data();
  const Real* vol = vol_.data();
  Real* gamma = gamma_.data();
  Vec2* acc = acc_.data();
  const Wendland W = w_;
  const Real gx = gx_;
  const Real k_area = scale_ * gx_ * gy_;
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index j = 0; j < n; ++j) {
    Real fx = 0, fy = 0, ng = 0;
#if SPHFLUID_AVX512
    using simd::D8;
    D8 lx = simd::zero<D8>(), ly = lx, ln = lx;
    const D8 iota = simd::iota8();
    const D8 v_gx = D8::splat(gx);
#endif
    visit_rows(x[j], 0, ny_, [&](std::size_t c0, Index count, Real rx0, Real dy) {
      const Real* ncx = nxs + c0;
      const Real* ncy = nys + c0;
#if SPHFLUID_AVX512
      if (count % 8 == 0) {
        const D8 v_dy = D8::splat(dy), v_dy2 = D8::splat(dy * dy), v_rx0 = D8::splat(rx0);
        for (Index i = 0; i < count; i += 8) {
          const D8 rx = simd::fmadd(D8::splat(Real(i)) + iota, v_gx, v_rx0);
          surface::node_force(W, rx, v_dy, v_dy2, D8::loadu(ncx + i), D8::loadu(ncy + i), lx, ly,
                              ln);
        }
        return;
      }
#endif
      const Real dy2 = dy * dy;
      // Sums of the row in locals (reduced straight into the references, the
      // lane loop's sums were added one by one through memory).
      Real sx = 0, sy = 0, sn = 0;
#pragma omp simd reduction(+ : sx, sy, sn)
      for (Index i = 0; i < count; ++i)
        surface::node_force(W, rx0 + i * gx, dy, dy2, ncx[i], ncy[i], sx, sy, sn);
      fx += sx;
      fy += sy;
      ng += sn;
    });
#if SPHFLUID_AVX512
    fx += reduce_add(lx);
    fy += reduce_add(ly);
    ng += reduce_add(ln);
#endif
    acc[j] = Vec2(fx, fy) * (k_area * vol[j] / mass);
    gamma[j] = k_area * vol[j] * vol[j] * ng;
  }
}

// W12 through the volumes: sum_l (gamma_j + gamma_l) grad W_H(x_j - x_l) / m.
void SurfaceEnergy::volume_forces(const Vec2* x, Index n, Real mass, int threads) {
  const Real* gamma = gamma_.data();
  Vec2* acc = acc_.data();
  const Wendland W = w_;
  const Real H2 = W.h2;
  [[maybe_unused]] const bool runs = kVectorRuns && !box_.any();
#if SPHFLUID_AVX512
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
#if SPHFLUID_AVX512
    if (runs) {  // eight candidates at a time
      using simd::D8;
      const D8 v_gj = D8::splat(gj);
      D8 lx = simd::zero<D8>(), ly = lx;
      near_lanes(xj, j, [&](simd::Mask8 m, Index k, D8 dx, D8 dy, D8 r2) {
        const D8 c = (v_gj + D8::load(bin_gamma_.data() + k, m)) * W.gradient_factor(sqrt(r2));
        lx = mask3_fmadd(c, dx, lx, m);
        ly = mask3_fmadd(c, dy, ly, m);
      });
      acc[j] += Vec2(reduce_add(lx), reduce_add(ly)) / mass;
      continue;
    }
#endif
    Real fx = 0, fy = 0;
    for_near(j, [&](Index l) {
      const Vec2 r = sep(xj, x[l]);
      const Real r2 = r.squaredNorm();
      if (!(r2 < H2)) return;
      const Real c = (gj + gamma[l]) * W.gradient_factor(std::sqrt(r2));
      fx = simd::fmadd(c, r.x(), fx);
      fy = simd::fmadd(c, r.y(), fy);
    });
    acc[j] += Vec2(fx, fy) / mass;
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
