// Ways to evaluate the seed's pair force (spiky pressure gradient plus the
// viscosity Laplacian) on a jittered lattice of 10,000 particles sorted by
// cells of h = 2 dx, as in the 10k dam break: the scalar neighbour-list loop, the
// same list eight lanes at a time with AVX-512 gathers, only the square roots
// and divisions on AVX-512 lanes with scalar sums, each pair once with its terms
// scattered to both particles (with 1/r computed in the loop, or stored per
// list entry beforehand, in double or in float refined by a Newton step), each
// pair once by cell clusters (a cell's particles against 8-lane groups of the
// half stencil's contiguous runs, no list; with the square root and division
// or with rsqrt14 and two Newton steps; the cell's particles four at a time
// with their sums in registers, as the solver runs it, with one test per
// particle or per tile, or behind a float prefilter; and probes that leave out
// the square root and division, the viscosity, or all but the traversal, to
// see where its time goes), the same clusters in float on 16 lanes (converted
// from the doubles per group, or from float copies) and on 8 lanes of a 256-bit
// register (what solver.pair_precision "float" runs: positions relative to the
// cell's corner, moved by whole cells), and AVX-512 over the full stencil's runs
// for each particle. First, the fluid density (poly6 of r^2) by cell clusters
// against a sum over a full neighbour list, in double and in float.
// BENCHMARKS.md, "What was tried" and "Roofline", quotes its output.
//
//   g++ -O3 -march=native -fno-math-errno benchmarks/experiments/pair_loop.cpp -o /tmp/pair_loop
//   /tmp/pair_loop
#include <immintrin.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

namespace {

struct Cloud {
  int n = 0, nc = 0;
  double h = 0;
  std::vector<double> x, v, p, inv_rho;  // x, v interleaved (x0, y0, x1, y1, ...)
  std::vector<int> cell, start;          // sorted by cell; start: cell ranges
  std::vector<int> row, nbr;             // neighbour list (CSR)
};

Cloud make_cloud() {
  Cloud c;
  const int side = 100;
  const double dx = 0.01;
  c.n = side * side;
  c.h = 2 * dx;
  std::mt19937 gen(1);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  std::vector<double> px(c.n), py(c.n);
  for (int i = 0; i < c.n; ++i) {
    px[i] = (i % side + 0.5 + u(gen)) * dx;
    py[i] = (i / side + 0.5 + u(gen)) * dx;
  }
  c.nc = static_cast<int>(side * dx / c.h) + 1;
  std::vector<int> cell(c.n), order(c.n);
  for (int i = 0; i < c.n; ++i) {
    cell[i] = static_cast<int>(py[i] / c.h) * c.nc + static_cast<int>(px[i] / c.h);
    order[i] = i;
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return cell[a] < cell[b]; });
  c.x.resize(2 * c.n);
  c.v.resize(2 * c.n);
  c.p.resize(c.n);
  c.inv_rho.resize(c.n);
  c.cell.resize(c.n);
  for (int k = 0; k < c.n; ++k) {
    c.x[2 * k] = px[order[k]];
    c.x[2 * k + 1] = py[order[k]];
    c.v[2 * k] = u(gen);
    c.v[2 * k + 1] = u(gen);
    c.p[k] = 1000 * (1 + u(gen));
    c.inv_rho[k] = 1e-3;
    c.cell[k] = cell[order[k]];
  }
  c.start.assign(c.nc * c.nc + 1, 0);
  for (int k = 0; k < c.n; ++k) ++c.start[c.cell[k] + 1];
  for (int k = 0; k < c.nc * c.nc; ++k) c.start[k + 1] += c.start[k];
  c.row.assign(c.n + 1, 0);
  for (int i = 0; i < c.n; ++i) {
    c.row[i] = static_cast<int>(c.nbr.size());
    const int cy = c.cell[i] / c.nc, cx = c.cell[i] % c.nc;
    for (int yy = std::max(cy - 1, 0); yy <= std::min(cy + 1, c.nc - 1); ++yy) {
      const int j0 = c.start[yy * c.nc + std::max(cx - 1, 0)];
      const int j1 = c.start[yy * c.nc + std::min(cx + 1, c.nc - 1) + 1];
      for (int j = j0; j < j1; ++j) {
        const double ex = c.x[2 * i] - c.x[2 * j], ey = c.x[2 * i + 1] - c.x[2 * j + 1];
        if (j != i && ex * ex + ey * ey < c.h * c.h) c.nbr.push_back(j);
      }
    }
  }
  c.row[c.n] = static_cast<int>(c.nbr.size());
  return c;
}

struct Coefficients {
  double grad, lap, eta;
};

void scalar_list(const Cloud& c, const Coefficients& k, double* f) {
  for (int i = 0; i < c.n; ++i) {
    const double xi = c.x[2 * i], yi = c.x[2 * i + 1], pi = c.p[i];
    const double vxi = c.v[2 * i], vyi = c.v[2 * i + 1];
    double fx = 0, fy = 0;
    for (int q = c.row[i]; q < c.row[i + 1]; ++q) {
      const int j = c.nbr[q];
      const double dx = xi - c.x[2 * j], dy = yi - c.x[2 * j + 1];
      const double r = std::sqrt(dx * dx + dy * dy), d = c.h - r;
      const double g = (d > 0 && r > 0) ? k.grad * d * d / r : 0;
      const double fp = 0.5 * (pi + c.p[j]) * c.inv_rho[j] * g;
      const double fv = k.eta * c.inv_rho[j] * (d > 0 ? k.lap * d : 0);
      fx += fv * (c.v[2 * j] - vxi) - fp * dx;
      fy += fv * (c.v[2 * j + 1] - vyi) - fp * dy;
    }
    f[2 * i] = fx;
    f[2 * i + 1] = fy;
  }
}

void gather_list(const Cloud& c, const Coefficients& k, double* f) {
  const __m512d zero = _mm512_setzero_pd(), h = _mm512_set1_pd(c.h), half = _mm512_set1_pd(0.5);
  const __m512d grad = _mm512_set1_pd(k.grad), lap = _mm512_set1_pd(k.eta * k.lap);
  for (int i = 0; i < c.n; ++i) {
    const __m512d xi = _mm512_set1_pd(c.x[2 * i]), yi = _mm512_set1_pd(c.x[2 * i + 1]);
    const __m512d pi = _mm512_set1_pd(c.p[i]);
    const __m512d vxi = _mm512_set1_pd(c.v[2 * i]), vyi = _mm512_set1_pd(c.v[2 * i + 1]);
    __m512d fx = zero, fy = zero;
    const int first = c.row[i], count = c.row[i + 1] - first;
    for (int q = 0; q < count; q += 8) {
      const int left = count - q;
      const __mmask8 lanes = left >= 8 ? 0xFF : static_cast<__mmask8>((1u << left) - 1);
      const __m256i j = _mm256_maskz_loadu_epi32(lanes, &c.nbr[first + q]);
      const __m256i j2 = _mm256_add_epi32(j, j);
      const __m512d dx = _mm512_sub_pd(xi, _mm512_mask_i32gather_pd(zero, lanes, j2, c.x.data(), 8));
      const __m512d dy =
          _mm512_sub_pd(yi, _mm512_mask_i32gather_pd(zero, lanes, j2, c.x.data() + 1, 8));
      const __m512d r = _mm512_sqrt_pd(_mm512_fmadd_pd(dx, dx, _mm512_mul_pd(dy, dy)));
      const __m512d d = _mm512_sub_pd(h, r);
      const __mmask8 in = _mm512_mask_cmp_pd_mask(lanes, d, zero, _CMP_GT_OQ) &
                          _mm512_mask_cmp_pd_mask(lanes, r, zero, _CMP_GT_OQ);
      const __m512d ir = _mm512_mask_i32gather_pd(zero, lanes, j, c.inv_rho.data(), 8);
      const __m512d pj = _mm512_mask_i32gather_pd(zero, lanes, j, c.p.data(), 8);
      const __m512d g = _mm512_maskz_div_pd(in, _mm512_mul_pd(_mm512_mul_pd(d, d), grad), r);
      const __m512d fp = _mm512_mul_pd(_mm512_mul_pd(half, _mm512_add_pd(pi, pj)), _mm512_mul_pd(ir, g));
      const __m512d fv = _mm512_maskz_mul_pd(in, _mm512_mul_pd(lap, ir), d);
      const __m512d vxj = _mm512_mask_i32gather_pd(zero, lanes, j2, c.v.data(), 8);
      const __m512d vyj = _mm512_mask_i32gather_pd(zero, lanes, j2, c.v.data() + 1, 8);
      fx = _mm512_fnmadd_pd(fp, dx, _mm512_fmadd_pd(fv, _mm512_sub_pd(vxj, vxi), fx));
      fy = _mm512_fnmadd_pd(fp, dy, _mm512_fmadd_pd(fv, _mm512_sub_pd(vyj, vyi), fy));
    }
    f[2 * i] = _mm512_reduce_add_pd(fx);
    f[2 * i + 1] = _mm512_reduce_add_pd(fy);
  }
}

// The kernel factors (one sqrt and one division each) of up to 8 lanes from
// two gathers, stored to short arrays; then the scalar sums over the list.
void hybrid_list(const Cloud& c, const Coefficients& k, double* f) {
  const __m512d zero = _mm512_setzero_pd(), h = _mm512_set1_pd(c.h);
  const __m512d grad = _mm512_set1_pd(k.grad), lap = _mm512_set1_pd(k.eta * k.lap);
  alignas(64) double gs[64], ls[64];
  for (int i = 0; i < c.n; ++i) {
    const double xi = c.x[2 * i], yi = c.x[2 * i + 1], pi = c.p[i];
    const double vxi = c.v[2 * i], vyi = c.v[2 * i + 1];
    const __m512d xv = _mm512_set1_pd(xi), yv = _mm512_set1_pd(yi);
    const int first = c.row[i], count = std::min(c.row[i + 1] - first, 64);
    for (int q = 0; q < count; q += 8) {
      const int left = count - q;
      const __mmask8 lanes = left >= 8 ? 0xFF : static_cast<__mmask8>((1u << left) - 1);
      const __m256i j2 = _mm256_slli_epi32(_mm256_maskz_loadu_epi32(lanes, &c.nbr[first + q]), 1);
      const __m512d dx = _mm512_sub_pd(xv, _mm512_mask_i32gather_pd(zero, lanes, j2, c.x.data(), 8));
      const __m512d dy = _mm512_sub_pd(yv, _mm512_mask_i32gather_pd(zero, lanes, j2, c.x.data() + 1, 8));
      const __m512d r = _mm512_sqrt_pd(_mm512_fmadd_pd(dx, dx, _mm512_mul_pd(dy, dy)));
      const __m512d d = _mm512_sub_pd(h, r);
      const __mmask8 in = _mm512_mask_cmp_pd_mask(lanes, d, zero, _CMP_GT_OQ) &
                          _mm512_mask_cmp_pd_mask(lanes, r, zero, _CMP_GT_OQ);
      _mm512_store_pd(gs + q, _mm512_maskz_div_pd(in, _mm512_mul_pd(_mm512_mul_pd(d, d), grad), r));
      _mm512_store_pd(ls + q, _mm512_maskz_mul_pd(in, lap, d));
    }
    double fx = 0, fy = 0;
    for (int q = 0; q < count; ++q) {
      const int j = c.nbr[first + q];
      const double dx = xi - c.x[2 * j], dy = yi - c.x[2 * j + 1];
      const double fp = 0.5 * (pi + c.p[j]) * c.inv_rho[j] * gs[q];
      const double fv = c.inv_rho[j] * ls[q];
      fx += fv * (c.v[2 * j] - vxi) - fp * dx;
      fy += fv * (c.v[2 * j + 1] - vyi) - fp * dy;
    }
    f[2 * i] = fx;
    f[2 * i + 1] = fy;
  }
}

// Each pair once (j > i), its square root and division shared by both
// particles and its terms scattered to both (serial; the solver's threads would
// need the scatter made independent of their number).
void symmetric_list(const Cloud& c, const Coefficients& k, double* f) {
  std::fill(f, f + 2 * c.n, 0.0);
  for (int i = 0; i < c.n; ++i) {
    const double xi = c.x[2 * i], yi = c.x[2 * i + 1], pi = c.p[i], iri = c.inv_rho[i];
    const double vxi = c.v[2 * i], vyi = c.v[2 * i + 1];
    double fx = 0, fy = 0;
    for (int q = c.row[i]; q < c.row[i + 1]; ++q) {
      const int j = c.nbr[q];
      if (j < i) continue;
      const double dx = xi - c.x[2 * j], dy = yi - c.x[2 * j + 1];
      const double r = std::sqrt(dx * dx + dy * dy), d = c.h - r;
      const double g = (d > 0 && r > 0) ? k.grad * d * d / r : 0;
      const double l = d > 0 ? k.eta * k.lap * d : 0;
      const double pp = 0.5 * (pi + c.p[j]) * g, irj = c.inv_rho[j];
      const double dvx = c.v[2 * j] - vxi, dvy = c.v[2 * j + 1] - vyi;
      fx += irj * (l * dvx - pp * dx);
      fy += irj * (l * dvy - pp * dy);
      f[2 * j] += iri * (pp * dx - l * dvx);
      f[2 * j + 1] += iri * (pp * dy - l * dvy);
    }
    f[2 * i] += fx;
    f[2 * i + 1] += fy;
  }
}


// The same with 1/r of each list entry stored beforehand (as the neighbour
// filter could write it next to the index): no square root or division here.
std::vector<double> g_inv_r;
void symmetric_stored(const Cloud& c, const Coefficients& k, double* f) {
  std::fill(f, f + 2 * c.n, 0.0);
  const double* inv_r = g_inv_r.data();
  for (int i = 0; i < c.n; ++i) {
    const double xi = c.x[2 * i], yi = c.x[2 * i + 1], pi = c.p[i], iri = c.inv_rho[i];
    const double vxi = c.v[2 * i], vyi = c.v[2 * i + 1];
    double fx = 0, fy = 0;
    for (int q = c.row[i]; q < c.row[i + 1]; ++q) {
      const int j = c.nbr[q];
      if (j < i) continue;
      const double dx = xi - c.x[2 * j], dy = yi - c.x[2 * j + 1];
      const double ir = inv_r[q], r = (dx * dx + dy * dy) * ir, d = c.h - r;
      const double g = k.grad * d * d * ir;
      const double l = k.eta * k.lap * d;
      const double pp = 0.5 * (pi + c.p[j]) * g, irj = c.inv_rho[j];
      const double dvx = c.v[2 * j] - vxi, dvy = c.v[2 * j + 1] - vyi;
      fx += irj * (l * dvx - pp * dx);
      fy += irj * (l * dvy - pp * dy);
      f[2 * j] += iri * (pp * dx - l * dvx);
      f[2 * j + 1] += iri * (pp * dy - l * dvy);
    }
    f[2 * i] += fx;
    f[2 * i + 1] += fy;
  }
}


std::vector<float> g_inv_rf;
void symmetric_stored_f(const Cloud& c, const Coefficients& k, double* f) {
  std::fill(f, f + 2 * c.n, 0.0);
  const float* inv_r = g_inv_rf.data();
  for (int i = 0; i < c.n; ++i) {
    const double xi = c.x[2 * i], yi = c.x[2 * i + 1], pi = c.p[i], iri = c.inv_rho[i];
    const double vxi = c.v[2 * i], vyi = c.v[2 * i + 1];
    double fx = 0, fy = 0;
    for (int q = c.row[i]; q < c.row[i + 1]; ++q) {
      const int j = c.nbr[q];
      if (j < i) continue;
      const double dx = xi - c.x[2 * j], dy = yi - c.x[2 * j + 1];
      const double r2 = dx * dx + dy * dy, y0 = inv_r[q];
      const double ir = y0 * (1.5 - 0.5 * r2 * y0 * y0), r = r2 * ir, d = c.h - r;
      const double g = k.grad * d * d * ir;
      const double l = k.eta * k.lap * d;
      const double pp = 0.5 * (pi + c.p[j]) * g, irj = c.inv_rho[j];
      const double dvx = c.v[2 * j] - vxi, dvy = c.v[2 * j + 1] - vyi;
      fx += irj * (l * dvx - pp * dx);
      fy += irj * (l * dvy - pp * dy);
      f[2 * j] += iri * (pp * dx - l * dvx);
      f[2 * j + 1] += iri * (pp * dy - l * dvy);
    }
    f[2 * i] += fx;
    f[2 * i + 1] += fy;
  }
}


// Cell-cluster pair loop: for each cell, its particles i against 8-lane groups of
// the contiguous candidate runs of half the stencil (own row from the cell on,
// j > i; the row above in full); j's data loaded once per group for all i of
// the cell, j's share summed in registers and added once per group.
static inline __m512d rinv(__m512d r2) {  // 1/sqrt(r2), masked outside
  const __m512d h = _mm512_mul_pd(r2, _mm512_set1_pd(0.5)), t = _mm512_set1_pd(1.5);
  __m512d y = _mm512_rsqrt14_pd(r2);
  y = _mm512_mul_pd(y, _mm512_fnmadd_pd(h, _mm512_mul_pd(y, y), t));
  y = _mm512_mul_pd(y, _mm512_fnmadd_pd(h, _mm512_mul_pd(y, y), t));
  return y;
}
// What the loop does for each particle and group: all of it (Full), or, to see
// where its time goes, without the square root and division (NoRoot: r2
// stands in for them), without the viscosity (NoViscosity), or only the
// traversal: loads, r^2, the masks, and the sums' loads and stores (Traversal).
// Only Full gives the forces.
enum class Probe { Full, NoRoot, NoViscosity, Traversal };
template <bool Exact, Probe P = Probe::Full>
void cluster_pairs(const Cloud& c, const Coefficients& k, double* f) {
  std::fill(f, f + 2 * c.n, 0.0);
  const __m512i even = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14);
  const __m512i odd = _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
  const __m512i ilo = _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11);
  const __m512i ihi = _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15);
  const __m512d H = _mm512_set1_pd(c.h), H2 = _mm512_set1_pd(c.h * c.h), zero = _mm512_setzero_pd();
  const __m512d G = _mm512_set1_pd(k.grad * 0.5), L = _mm512_set1_pd(k.eta * k.lap);
  alignas(64) double fix[16][8], fiy[16][8];
  const int nc = c.nc;
  for (int cell = 0; cell < nc * nc; ++cell) {
    const int s0 = c.start[cell], s1 = c.start[cell + 1];
    if (s0 == s1) continue;
    const int m = s1 - s0;
    const int cy = cell / nc, cx = cell % nc;
    const int r1 = c.start[cy * nc + std::min(cx + 1, nc - 1) + 1];
    int a0 = 0, a1 = 0;
    if (cy + 1 < nc) {
      a0 = c.start[(cy + 1) * nc + std::max(cx - 1, 0)];
      a1 = c.start[(cy + 1) * nc + std::min(cx + 1, nc - 1) + 1];
    }
    for (int q = 0; q < m; ++q) {
      _mm512_store_pd(fix[q], zero);
      _mm512_store_pd(fiy[q], zero);
    }
    auto run = [&](int j0, int j1, bool own) {
      for (int j = j0; j < j1; j += 8) {
        const int left = j1 - j;
        const __mmask8 lanes = left >= 8 ? 0xFF : static_cast<__mmask8>((1u << left) - 1);
        const unsigned doubles = 2u * static_cast<unsigned>(std::min(left, 8));
        const __mmask8 lo_mask = static_cast<__mmask8>((1u << std::min(doubles, 8u)) - 1);
        const __mmask8 hi_mask = static_cast<__mmask8>((1u << (doubles > 8 ? doubles - 8 : 0u)) - 1);
        const __m512d xlo = _mm512_maskz_loadu_pd(lo_mask, &c.x[2 * j]);
        const __m512d xhi = _mm512_maskz_loadu_pd(hi_mask, &c.x[2 * j + 8]);
        const __m512d xj = _mm512_permutex2var_pd(xlo, even, xhi), yj = _mm512_permutex2var_pd(xlo, odd, xhi);
        const __m512d vlo = _mm512_maskz_loadu_pd(lo_mask, &c.v[2 * j]);
        const __m512d vhi = _mm512_maskz_loadu_pd(hi_mask, &c.v[2 * j + 8]);
        const __m512d vxj = _mm512_permutex2var_pd(vlo, even, vhi), vyj = _mm512_permutex2var_pd(vlo, odd, vhi);
        const __m512d pj = _mm512_maskz_loadu_pd(lanes, &c.p[j]);
        const __m512d irj = _mm512_maskz_loadu_pd(lanes, &c.inv_rho[j]);
        __m512d fjx = zero, fjy = zero;
        for (int q = 0; q < m; ++q) {
          const int i = s0 + q;
          __mmask8 live = lanes;
          if (own) {  // j > i
            const int d = i + 1 - j;  // lanes below d are j <= i
            live &= d <= 0 ? 0xFF : d >= 8 ? 0 : static_cast<__mmask8>(0xFFu << d);
            if (!live) continue;
          }
          const __m512d dx = _mm512_sub_pd(_mm512_set1_pd(c.x[2 * i]), xj);
          const __m512d dy = _mm512_sub_pd(_mm512_set1_pd(c.x[2 * i + 1]), yj);
          const __m512d r2 = _mm512_fmadd_pd(dx, dx, _mm512_mul_pd(dy, dy));
          const __mmask8 in = _mm512_mask_cmp_pd_mask(live, r2, H2, _CMP_LT_OQ) &
                              _mm512_mask_cmp_pd_mask(live, r2, zero, _CMP_GT_OQ);
          if (!in) continue;
          if constexpr (P == Probe::Traversal) {
            _mm512_store_pd(fix[q], _mm512_mask_add_pd(_mm512_load_pd(fix[q]), in, _mm512_load_pd(fix[q]), r2));
            fjx = _mm512_mask_add_pd(fjx, in, fjx, r2);
            continue;
          }
          __m512d ir, r;
          if constexpr (P == Probe::NoRoot) {
            r = ir = r2;
          } else if constexpr (Exact) {
            r = _mm512_sqrt_pd(r2);
            ir = _mm512_div_pd(_mm512_set1_pd(1.0), r);
          } else {
            ir = rinv(r2);
            r = _mm512_mul_pd(r2, ir);
          }
          const __m512d d = _mm512_sub_pd(H, r);
          // pp = 0.5 (pi + pj) grad d^2 / r ; l = eta lap d
          const __m512d pp = _mm512_maskz_mul_pd(in, _mm512_mul_pd(_mm512_add_pd(_mm512_set1_pd(c.p[i]), pj), G),
                                                 _mm512_mul_pd(_mm512_mul_pd(d, d), ir));
          const __m512d l = _mm512_maskz_mul_pd(in, L, d);
          const __m512d dvx = _mm512_sub_pd(vxj, _mm512_set1_pd(c.v[2 * i]));
          const __m512d dvy = _mm512_sub_pd(vyj, _mm512_set1_pd(c.v[2 * i + 1]));
          __m512d tx, ty;
          if constexpr (P == Probe::NoViscosity) {
            tx = _mm512_mul_pd(pp, dx);
            ty = _mm512_mul_pd(pp, dy);
          } else {
            tx = _mm512_fmsub_pd(l, dvx, _mm512_mul_pd(pp, dx));  // l dv - pp dx
            ty = _mm512_fmsub_pd(l, dvy, _mm512_mul_pd(pp, dy));
          }
          _mm512_store_pd(fix[q], _mm512_fmadd_pd(irj, tx, _mm512_load_pd(fix[q])));
          _mm512_store_pd(fiy[q], _mm512_fmadd_pd(irj, ty, _mm512_load_pd(fiy[q])));
          const __m512d iri = _mm512_set1_pd(c.inv_rho[i]);
          fjx = _mm512_fnmadd_pd(iri, tx, fjx);
          fjy = _mm512_fnmadd_pd(iri, ty, fjy);
        }
        // add j's share, interleaved back
        const __m512d flo = _mm512_permutex2var_pd(fjx, ilo, fjy), fhi = _mm512_permutex2var_pd(fjx, ihi, fjy);
        _mm512_mask_storeu_pd(&f[2 * j], lo_mask, _mm512_add_pd(_mm512_maskz_loadu_pd(lo_mask, &f[2 * j]), flo));
        _mm512_mask_storeu_pd(&f[2 * j + 8], hi_mask, _mm512_add_pd(_mm512_maskz_loadu_pd(hi_mask, &f[2 * j + 8]), fhi));
      }
    };
    run(s0, r1, true);
    run(a0, a1, false);
    for (int q = 0; q < m; ++q) {
      f[2 * (s0 + q)] += _mm512_reduce_add_pd(_mm512_load_pd(fix[q]));
      f[2 * (s0 + q) + 1] += _mm512_reduce_add_pd(_mm512_load_pd(fiy[q]));
    }
  }
}

// The same clusters with a cell's particles taken K <= 4 at a time, their sums
// in registers (what the solver runs): after each i's test (PerI) or, to see
// what the branches cost, one test per group and tile and all K computed.
template <int K, bool PerI>
static inline void tile_run(const Cloud& c, const Coefficients& k, double* f, int t0, int j0, int j1, bool own,
                            __m512d* fix, __m512d* fiy) {
  const __m512i even = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14);
  const __m512i odd = _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
  const __m512i ilo = _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11);
  const __m512i ihi = _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15);
  const __m512d H = _mm512_set1_pd(c.h), H2 = _mm512_set1_pd(c.h * c.h), zero = _mm512_setzero_pd();
  const __m512d G = _mm512_set1_pd(k.grad * 0.5), L = _mm512_set1_pd(k.eta * k.lap);
  for (int j = j0; j < j1; j += 8) {
    const int left = j1 - j;
    const __mmask8 lanes = left >= 8 ? 0xFF : static_cast<__mmask8>((1u << left) - 1);
    const unsigned doubles = 2u * static_cast<unsigned>(std::min(left, 8));
    const __mmask8 lo_mask = static_cast<__mmask8>((1u << std::min(doubles, 8u)) - 1);
    const __mmask8 hi_mask = static_cast<__mmask8>((1u << (doubles > 8 ? doubles - 8 : 0u)) - 1);
    const __m512d xlo = _mm512_maskz_loadu_pd(lo_mask, &c.x[2 * j]);
    const __m512d xhi = _mm512_maskz_loadu_pd(hi_mask, &c.x[2 * j + 8]);
    const __m512d xj = _mm512_permutex2var_pd(xlo, even, xhi), yj = _mm512_permutex2var_pd(xlo, odd, xhi);
    __m512d dx[K], dy[K], r2[K];
    __mmask8 in[K];
    unsigned any = 0;
    for (int q = 0; q < K; ++q) {
      const int i = t0 + q;
      __mmask8 live = lanes;
      if (own) {
        const int d = i + 1 - j;
        live &= d <= 0 ? 0xFF : d >= 8 ? 0 : static_cast<__mmask8>(0xFFu << d);
      }
      dx[q] = _mm512_sub_pd(_mm512_set1_pd(c.x[2 * i]), xj);
      dy[q] = _mm512_sub_pd(_mm512_set1_pd(c.x[2 * i + 1]), yj);
      r2[q] = _mm512_fmadd_pd(dx[q], dx[q], _mm512_mul_pd(dy[q], dy[q]));
      in[q] = _mm512_mask_cmp_pd_mask(live, r2[q], H2, _CMP_LT_OQ) &
              _mm512_mask_cmp_pd_mask(live, r2[q], zero, _CMP_GT_OQ);
      any |= in[q];
    }
    if (!any) continue;
    const __m512d vlo = _mm512_maskz_loadu_pd(lo_mask, &c.v[2 * j]);
    const __m512d vhi = _mm512_maskz_loadu_pd(hi_mask, &c.v[2 * j + 8]);
    const __m512d vxj = _mm512_permutex2var_pd(vlo, even, vhi), vyj = _mm512_permutex2var_pd(vlo, odd, vhi);
    const __m512d pj = _mm512_maskz_loadu_pd(lanes, &c.p[j]);
    const __m512d irj = _mm512_maskz_loadu_pd(lanes, &c.inv_rho[j]);
    __m512d fjx = zero, fjy = zero;
    for (int q = 0; q < K; ++q) {
      if (PerI && !in[q]) continue;
      const int i = t0 + q;
      const __m512d r = _mm512_sqrt_pd(r2[q]);
      const __m512d ir = _mm512_div_pd(_mm512_set1_pd(1.0), r);
      const __m512d d = _mm512_sub_pd(H, r);
      const __m512d pp = _mm512_maskz_mul_pd(in[q], _mm512_mul_pd(_mm512_add_pd(_mm512_set1_pd(c.p[i]), pj), G),
                                             _mm512_mul_pd(_mm512_mul_pd(d, d), ir));
      const __m512d l = _mm512_maskz_mul_pd(in[q], L, d);
      const __m512d dvx = _mm512_sub_pd(vxj, _mm512_set1_pd(c.v[2 * i]));
      const __m512d dvy = _mm512_sub_pd(vyj, _mm512_set1_pd(c.v[2 * i + 1]));
      const __m512d tx = _mm512_fmsub_pd(l, dvx, _mm512_mul_pd(pp, dx[q]));
      const __m512d ty = _mm512_fmsub_pd(l, dvy, _mm512_mul_pd(pp, dy[q]));
      fix[q] = _mm512_fmadd_pd(irj, tx, fix[q]);
      fiy[q] = _mm512_fmadd_pd(irj, ty, fiy[q]);
      const __m512d iri = _mm512_set1_pd(c.inv_rho[i]);
      fjx = _mm512_fnmadd_pd(iri, tx, fjx);
      fjy = _mm512_fnmadd_pd(iri, ty, fjy);
    }
    const __m512d flo = _mm512_permutex2var_pd(fjx, ilo, fjy), fhi = _mm512_permutex2var_pd(fjx, ihi, fjy);
    _mm512_mask_storeu_pd(&f[2 * j], lo_mask, _mm512_add_pd(_mm512_maskz_loadu_pd(lo_mask, &f[2 * j]), flo));
    _mm512_mask_storeu_pd(&f[2 * j + 8], hi_mask, _mm512_add_pd(_mm512_maskz_loadu_pd(hi_mask, &f[2 * j + 8]), fhi));
  }
}
template <int K, bool PerI>
static inline void tile(const Cloud& c, const Coefficients& k, double* f, int t0, int r1, int a0, int a1) {
  __m512d fix[K], fiy[K];
  for (int q = 0; q < K; ++q) fix[q] = fiy[q] = _mm512_setzero_pd();
  tile_run<K, PerI>(c, k, f, t0, t0 + 1, r1, true, fix, fiy);
  tile_run<K, PerI>(c, k, f, t0, a0, a1, false, fix, fiy);
  for (int q = 0; q < K; ++q) {
    f[2 * (t0 + q)] += _mm512_reduce_add_pd(fix[q]);
    f[2 * (t0 + q) + 1] += _mm512_reduce_add_pd(fiy[q]);
  }
}
template <bool PerI>
void cluster_tiled(const Cloud& c, const Coefficients& k, double* f) {
  std::fill(f, f + 2 * c.n, 0.0);
  const int nc = c.nc;
  for (int cell = 0; cell < nc * nc; ++cell) {
    const int s0 = c.start[cell], s1 = c.start[cell + 1];
    if (s0 == s1) continue;
    const int cy = cell / nc, cx = cell % nc;
    const int r1 = c.start[cy * nc + std::min(cx + 1, nc - 1) + 1];
    int a0 = 0, a1 = 0;
    if (cy + 1 < nc) {
      a0 = c.start[(cy + 1) * nc + std::max(cx - 1, 0)];
      a1 = c.start[(cy + 1) * nc + std::min(cx + 1, nc - 1) + 1];
    }
    for (int t0 = s0; t0 < s1;) {
      const int m = std::min(s1 - t0, 4);
      switch (m) {
        case 4: tile<4, PerI>(c, k, f, t0, r1, a0, a1); break;
        case 3: tile<3, PerI>(c, k, f, t0, r1, a0, a1); break;
        case 2: tile<2, PerI>(c, k, f, t0, r1, a0, a1); break;
        default: tile<1, PerI>(c, k, f, t0, r1, a0, a1); break;
      }
      t0 += m;
    }
  }
}


// What the tiled loop does, counted (scalar, not timed): group loads, the
// evaluations of a particle against a group (with a lane after it), those
// with a pair within h, and their lanes that hold one.
void count_tiled(const Cloud& c) {
  const int nc = c.nc;
  const double h2 = c.h * c.h;
  long groups = 0, evals = 0, hits = 0, lanes = 0;
  for (int cell = 0; cell < nc * nc; ++cell) {
    const int s0 = c.start[cell], s1 = c.start[cell + 1];
    const int cy = cell / nc, cx = cell % nc;
    const int r1 = c.start[cy * nc + std::min(cx + 1, nc - 1) + 1];
    int a0 = 0, a1 = 0;
    if (cy + 1 < nc) {
      a0 = c.start[(cy + 1) * nc + std::max(cx - 1, 0)];
      a1 = c.start[(cy + 1) * nc + std::min(cx + 1, nc - 1) + 1];
    }
    for (int t0 = s0; t0 < s1; t0 += 4) {
      const int t1 = std::min(s1, t0 + 4);
      auto run = [&](int j0, int j1, bool own) {
        for (int j = j0; j < j1; j += 8) {
          ++groups;
          for (int i = t0; i < t1; ++i) {
            int live = 0, in = 0;
            for (int l = j; l < std::min(j1, j + 8); ++l) {
              if (own && l <= i) continue;
              ++live;
              const double dx = c.x[2 * i] - c.x[2 * l], dy = c.x[2 * i + 1] - c.x[2 * l + 1];
              const double r2 = dx * dx + dy * dy;
              in += r2 < h2 && r2 > 0;
            }
            evals += live > 0;
            hits += in > 0;
            lanes += in;
          }
        }
      };
      run(t0 + 1, r1, true);
      run(a0, a1, false);
    }
  }
  std::printf("tiles of 4: %.2f group loads, %.2f evaluations and %.2f with a pair per particle; "
              "%.2f of 8 lanes hold a pair in those\n",
              double(groups) / c.n, double(evals) / c.n, double(hits) / c.n, double(lanes) / hits);
}

// A float prefilter on 16 lanes: float copies of x and y (not timed) decide,
// with a margin, which 8-lane halves and which i go to the exact double test
// and the compute.
std::vector<float> g_fx, g_fy;
void cluster_prefilter(const Cloud& c, const Coefficients& k, double* f) {
  std::fill(f, f + 2 * c.n, 0.0);
  const __m512i even = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14);
  const __m512i odd = _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
  const __m512i ilo = _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11);
  const __m512i ihi = _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15);
  const __m512d H = _mm512_set1_pd(c.h), H2 = _mm512_set1_pd(c.h * c.h), zero = _mm512_setzero_pd();
  const __m512d G = _mm512_set1_pd(k.grad * 0.5), L = _mm512_set1_pd(k.eta * k.lap);
  const float hf = float(c.h * (1 + 1e-4) + 1e-6);
  const __m512 H2f = _mm512_set1_ps(hf * hf);
  alignas(64) double fix[16][8], fiy[16][8];
  const float* fxp = g_fx.data();
  const float* fyp = g_fy.data();
  const int nc = c.nc;
  for (int cell = 0; cell < nc * nc; ++cell) {
    const int s0 = c.start[cell], s1 = c.start[cell + 1];
    if (s0 == s1) continue;
    const int m = std::min(s1 - s0, 16);
    const int cy = cell / nc, cx = cell % nc;
    const int r1 = c.start[cy * nc + std::min(cx + 1, nc - 1) + 1];
    int a0 = 0, a1 = 0;
    if (cy + 1 < nc) {
      a0 = c.start[(cy + 1) * nc + std::max(cx - 1, 0)];
      a1 = c.start[(cy + 1) * nc + std::min(cx + 1, nc - 1) + 1];
    }
    for (int q = 0; q < m; ++q) {
      _mm512_store_pd(fix[q], zero);
      _mm512_store_pd(fiy[q], zero);
    }
    auto run = [&](int j0, int j1, bool own) {
      for (int j16 = j0; j16 < j1; j16 += 16) {
        const int left16 = j1 - j16;
        const __mmask16 lanes16 = left16 >= 16 ? 0xFFFF : static_cast<__mmask16>((1u << left16) - 1);
        const __m512 xj16 = _mm512_maskz_loadu_ps(lanes16, fxp + j16), yj16 = _mm512_maskz_loadu_ps(lanes16, fyp + j16);
        __mmask16 hit[16];
        unsigned any = 0;
        for (int q = 0; q < m; ++q) {
          const int i = s0 + q;
          __mmask16 live = lanes16;
          if (own) {
            const int d = i + 1 - j16;
            live &= d <= 0 ? 0xFFFF : d >= 16 ? 0 : static_cast<__mmask16>(0xFFFFu << d);
          }
          const __m512 dx = _mm512_sub_ps(_mm512_set1_ps(fxp[i]), xj16);
          const __m512 dy = _mm512_sub_ps(_mm512_set1_ps(fyp[i]), yj16);
          const __m512 r2 = _mm512_fmadd_ps(dx, dx, _mm512_mul_ps(dy, dy));
          hit[q] = _mm512_mask_cmp_ps_mask(live, r2, H2f, _CMP_LT_OQ);
          any |= hit[q];
        }
        for (int half = 0; half < 2; ++half) {
          if (!((any >> (8 * half)) & 0xFF)) continue;
          const int j = j16 + 8 * half;
          const int left = j1 - j;
          const __mmask8 lanes = left >= 8 ? 0xFF : static_cast<__mmask8>((1u << left) - 1);
          const unsigned doubles = 2u * static_cast<unsigned>(std::min(left, 8));
          const __mmask8 lo_mask = static_cast<__mmask8>((1u << std::min(doubles, 8u)) - 1);
          const __mmask8 hi_mask = static_cast<__mmask8>((1u << (doubles > 8 ? doubles - 8 : 0u)) - 1);
          const __m512d xlo = _mm512_maskz_loadu_pd(lo_mask, &c.x[2 * j]);
          const __m512d xhi = _mm512_maskz_loadu_pd(hi_mask, &c.x[2 * j + 8]);
          const __m512d xj = _mm512_permutex2var_pd(xlo, even, xhi), yj = _mm512_permutex2var_pd(xlo, odd, xhi);
          const __m512d vlo = _mm512_maskz_loadu_pd(lo_mask, &c.v[2 * j]);
          const __m512d vhi = _mm512_maskz_loadu_pd(hi_mask, &c.v[2 * j + 8]);
          const __m512d vxj = _mm512_permutex2var_pd(vlo, even, vhi), vyj = _mm512_permutex2var_pd(vlo, odd, vhi);
          const __m512d pj = _mm512_maskz_loadu_pd(lanes, &c.p[j]);
          const __m512d irj = _mm512_maskz_loadu_pd(lanes, &c.inv_rho[j]);
          __m512d fjx = zero, fjy = zero;
          for (int q = 0; q < m; ++q) {
            const __mmask8 h8 = static_cast<__mmask8>(hit[q] >> (8 * half));
            if (!h8) continue;
            const int i = s0 + q;
            const __m512d dx = _mm512_sub_pd(_mm512_set1_pd(c.x[2 * i]), xj);
            const __m512d dy = _mm512_sub_pd(_mm512_set1_pd(c.x[2 * i + 1]), yj);
            const __m512d r2 = _mm512_fmadd_pd(dx, dx, _mm512_mul_pd(dy, dy));
            const __mmask8 in = _mm512_mask_cmp_pd_mask(h8, r2, H2, _CMP_LT_OQ) &
                                _mm512_mask_cmp_pd_mask(h8, r2, zero, _CMP_GT_OQ);
            if (!in) continue;
            const __m512d r = _mm512_sqrt_pd(r2);
            const __m512d ir = _mm512_div_pd(_mm512_set1_pd(1.0), r);
            const __m512d d = _mm512_sub_pd(H, r);
            const __m512d pp = _mm512_maskz_mul_pd(in, _mm512_mul_pd(_mm512_add_pd(_mm512_set1_pd(c.p[i]), pj), G),
                                                   _mm512_mul_pd(_mm512_mul_pd(d, d), ir));
            const __m512d l = _mm512_maskz_mul_pd(in, L, d);
            const __m512d dvx = _mm512_sub_pd(vxj, _mm512_set1_pd(c.v[2 * i]));
            const __m512d dvy = _mm512_sub_pd(vyj, _mm512_set1_pd(c.v[2 * i + 1]));
            const __m512d tx = _mm512_fmsub_pd(l, dvx, _mm512_mul_pd(pp, dx));
            const __m512d ty = _mm512_fmsub_pd(l, dvy, _mm512_mul_pd(pp, dy));
            _mm512_store_pd(fix[q], _mm512_fmadd_pd(irj, tx, _mm512_load_pd(fix[q])));
            _mm512_store_pd(fiy[q], _mm512_fmadd_pd(irj, ty, _mm512_load_pd(fiy[q])));
            const __m512d iri = _mm512_set1_pd(c.inv_rho[i]);
            fjx = _mm512_fnmadd_pd(iri, tx, fjx);
            fjy = _mm512_fnmadd_pd(iri, ty, fjy);
          }
          const __m512d flo = _mm512_permutex2var_pd(fjx, ilo, fjy), fhi = _mm512_permutex2var_pd(fjx, ihi, fjy);
          _mm512_mask_storeu_pd(&f[2 * j], lo_mask, _mm512_add_pd(_mm512_maskz_loadu_pd(lo_mask, &f[2 * j]), flo));
          _mm512_mask_storeu_pd(&f[2 * j + 8], hi_mask, _mm512_add_pd(_mm512_maskz_loadu_pd(hi_mask, &f[2 * j + 8]), fhi));
        }
      }
    };
    run(s0, r1, true);
    run(a0, a1, false);
    for (int q = 0; q < m; ++q) {
      f[2 * (s0 + q)] += _mm512_reduce_add_pd(_mm512_load_pd(fix[q]));
      f[2 * (s0 + q) + 1] += _mm512_reduce_add_pd(_mm512_load_pd(fiy[q]));
    }
  }
}

// The same cell clusters in float, 16 lanes a group. Converted: positions
// taken relative to the cell's corner in double and rounded to float (the
// differences keep the pair's own scale, not the domain's), v, p and 1/rho
// rounded per group; j's share added to the double sums. Copies: from float
// copies of x, v, p and 1/rho made beforehand (not timed; the positions
// absolute, so their differences lose digits), the best float could do.
std::vector<float> g_xf, g_vf, g_pf, g_irf;
template <bool Copies>
void cluster_pairs_f(const Cloud& c, const Coefficients& k, double* f) {
  std::fill(f, f + 2 * c.n, 0.0);
  const __m512i even = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14);
  const __m512i odd = _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
  const __m512i ilo = _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11);
  const __m512i ihi = _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15);
  const __m512i fe = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
  const __m512i fo = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
  const __m512 H = _mm512_set1_ps(float(c.h)), H2 = _mm512_set1_ps(float(c.h * c.h)), zero = _mm512_setzero_ps();
  const __m512 G = _mm512_set1_ps(float(k.grad * 0.5)), L = _mm512_set1_ps(float(k.eta * k.lap));
  alignas(64) float fix[16][16], fiy[16][16];
  float xi[16], yi[16], vxi[16], vyi[16], pi_[16], iri_[16];
  auto tof = [](__m512d a, __m512d b) {  // 8 + 8 doubles -> 16 floats
    return _mm512_insertf32x8(_mm512_castps256_ps512(_mm512_cvtpd_ps(a)), _mm512_cvtpd_ps(b), 1);
  };
  const int nc = c.nc;
  for (int cell = 0; cell < nc * nc; ++cell) {
    const int s0 = c.start[cell], s1 = c.start[cell + 1];
    if (s0 == s1) continue;
    const int m = s1 - s0;
    const int cy = cell / nc, cx = cell % nc;
    const double X0 = cx * c.h, Y0 = cy * c.h;
    const __m512d ox = _mm512_set1_pd(X0), oy = _mm512_set1_pd(Y0);
    const int r1 = c.start[cy * nc + std::min(cx + 1, nc - 1) + 1];
    int a0 = 0, a1 = 0;
    if (cy + 1 < nc) {
      a0 = c.start[(cy + 1) * nc + std::max(cx - 1, 0)];
      a1 = c.start[(cy + 1) * nc + std::min(cx + 1, nc - 1) + 1];
    }
    for (int q = 0; q < m; ++q) {
      const int i = s0 + q;
      _mm512_store_ps(fix[q], zero);
      _mm512_store_ps(fiy[q], zero);
      xi[q] = float(c.x[2 * i] - X0);
      yi[q] = float(c.x[2 * i + 1] - Y0);
      vxi[q] = float(c.v[2 * i]);
      vyi[q] = float(c.v[2 * i + 1]);
      pi_[q] = float(c.p[i]);
      iri_[q] = float(c.inv_rho[i]);
    }
    auto run = [&](int j0, int j1, bool own) {
      for (int j = j0; j < j1; j += 16) {
        const int left = std::min(j1 - j, 16);
        const __mmask16 lanes = left >= 16 ? 0xFFFF : static_cast<__mmask16>((1u << left) - 1);
        // the four groups of 8 doubles of j's interleaved (x, y) pairs
        const int d0 = std::min(2 * left, 8), d1 = std::min(std::max(2 * left - 8, 0), 8),
                  d2 = std::min(std::max(2 * left - 16, 0), 8), d3 = std::max(2 * left - 24, 0);
        const __mmask8 m0 = (1u << d0) - 1, m1 = (1u << d1) - 1, m2 = (1u << d2) - 1, m3 = (1u << d3) - 1;
        __m512 xj, yj, vxj, vyj, pj, irj;
        if constexpr (Copies) {
          const __mmask16 h0 = left >= 8 ? 0xFFFF : (1u << (2 * left)) - 1;
          const __mmask16 h1 = left <= 8 ? 0 : (1u << (2 * (left - 8))) - 1;
          const __m512 xa = _mm512_maskz_loadu_ps(h0, &g_xf[2 * j]), xb = _mm512_maskz_loadu_ps(h1, &g_xf[2 * j + 16]);
          xj = _mm512_sub_ps(_mm512_permutex2var_ps(xa, fe, xb), _mm512_set1_ps(float(X0)));
          yj = _mm512_sub_ps(_mm512_permutex2var_ps(xa, fo, xb), _mm512_set1_ps(float(Y0)));
          const __m512 va = _mm512_maskz_loadu_ps(h0, &g_vf[2 * j]), vb = _mm512_maskz_loadu_ps(h1, &g_vf[2 * j + 16]);
          vxj = _mm512_permutex2var_ps(va, fe, vb);
          vyj = _mm512_permutex2var_ps(va, fo, vb);
          pj = _mm512_maskz_loadu_ps(lanes, &g_pf[j]);
          irj = _mm512_maskz_loadu_ps(lanes, &g_irf[j]);
        } else {
          const double* px = &c.x[2 * j];
          const __m512d x0 = _mm512_maskz_loadu_pd(m0, px), x1 = _mm512_maskz_loadu_pd(m1, px + 8);
          const __m512d x2 = _mm512_maskz_loadu_pd(m2, px + 16), x3 = _mm512_maskz_loadu_pd(m3, px + 24);
          xj = tof(_mm512_sub_pd(_mm512_permutex2var_pd(x0, even, x1), ox),
                   _mm512_sub_pd(_mm512_permutex2var_pd(x2, even, x3), ox));
          yj = tof(_mm512_sub_pd(_mm512_permutex2var_pd(x0, odd, x1), oy),
                   _mm512_sub_pd(_mm512_permutex2var_pd(x2, odd, x3), oy));
          const double* pv = &c.v[2 * j];
          const __m512d v0 = _mm512_maskz_loadu_pd(m0, pv), v1 = _mm512_maskz_loadu_pd(m1, pv + 8);
          const __m512d v2 = _mm512_maskz_loadu_pd(m2, pv + 16), v3 = _mm512_maskz_loadu_pd(m3, pv + 24);
          vxj = tof(_mm512_permutex2var_pd(v0, even, v1), _mm512_permutex2var_pd(v2, even, v3));
          vyj = tof(_mm512_permutex2var_pd(v0, odd, v1), _mm512_permutex2var_pd(v2, odd, v3));
          const __mmask8 l0 = lanes & 0xFF, l1 = lanes >> 8;
          pj = tof(_mm512_maskz_loadu_pd(l0, &c.p[j]), _mm512_maskz_loadu_pd(l1, &c.p[j + 8]));
          irj = tof(_mm512_maskz_loadu_pd(l0, &c.inv_rho[j]), _mm512_maskz_loadu_pd(l1, &c.inv_rho[j + 8]));
        }
        __m512 fjx = zero, fjy = zero;
        for (int q = 0; q < m; ++q) {
          const int i = s0 + q;
          __mmask16 live = lanes;
          if (own) {
            const int d = i + 1 - j;
            live &= d <= 0 ? 0xFFFF : d >= 16 ? 0 : static_cast<__mmask16>(0xFFFFu << d);
            if (!live) continue;
          }
          const __m512 dx = _mm512_sub_ps(_mm512_set1_ps(xi[q]), xj);
          const __m512 dy = _mm512_sub_ps(_mm512_set1_ps(yi[q]), yj);
          const __m512 r2 = _mm512_fmadd_ps(dx, dx, _mm512_mul_ps(dy, dy));
          const __mmask16 in = _mm512_mask_cmp_ps_mask(live, r2, H2, _CMP_LT_OQ);
          if (!in) continue;
          const __mmask16 nz = _mm512_mask_cmp_ps_mask(in, r2, zero, _CMP_GT_OQ);
          const __m512 r = _mm512_sqrt_ps(r2);
          const __m512 d = _mm512_max_ps(_mm512_sub_ps(H, r), zero);
          const __m512 grad = _mm512_maskz_div_ps(nz, _mm512_mul_ps(d, d), r);
          const __m512 pp = _mm512_mul_ps(_mm512_mul_ps(_mm512_add_ps(_mm512_set1_ps(pi_[q]), pj), G), grad);
          const __m512 l = _mm512_maskz_mul_ps(in, L, d);
          const __m512 dvx = _mm512_sub_ps(vxj, _mm512_set1_ps(vxi[q]));
          const __m512 dvy = _mm512_sub_ps(vyj, _mm512_set1_ps(vyi[q]));
          const __m512 tx = _mm512_fmadd_ps(l, dvx, _mm512_maskz_fnmadd_ps(in, pp, dx, zero));
          const __m512 ty = _mm512_fmadd_ps(l, dvy, _mm512_maskz_fnmadd_ps(in, pp, dy, zero));
          _mm512_store_ps(fix[q], _mm512_fmadd_ps(irj, tx, _mm512_load_ps(fix[q])));
          _mm512_store_ps(fiy[q], _mm512_fmadd_ps(irj, ty, _mm512_load_ps(fiy[q])));
          const __m512 iri = _mm512_set1_ps(iri_[q]);
          fjx = _mm512_fnmadd_ps(iri, tx, fjx);
          fjy = _mm512_fnmadd_ps(iri, ty, fjy);
        }
        const __m512d fx0 = _mm512_cvtps_pd(_mm512_castps512_ps256(fjx));
        const __m512d fx1 = _mm512_cvtps_pd(_mm512_extractf32x8_ps(fjx, 1));
        const __m512d fy0 = _mm512_cvtps_pd(_mm512_castps512_ps256(fjy));
        const __m512d fy1 = _mm512_cvtps_pd(_mm512_extractf32x8_ps(fjy, 1));
        double* o = &f[2 * j];
        _mm512_mask_storeu_pd(o, m0, _mm512_add_pd(_mm512_maskz_loadu_pd(m0, o), _mm512_permutex2var_pd(fx0, ilo, fy0)));
        _mm512_mask_storeu_pd(o + 8, m1, _mm512_add_pd(_mm512_maskz_loadu_pd(m1, o + 8), _mm512_permutex2var_pd(fx0, ihi, fy0)));
        _mm512_mask_storeu_pd(o + 16, m2, _mm512_add_pd(_mm512_maskz_loadu_pd(m2, o + 16), _mm512_permutex2var_pd(fx1, ilo, fy1)));
        _mm512_mask_storeu_pd(o + 24, m3, _mm512_add_pd(_mm512_maskz_loadu_pd(m3, o + 24), _mm512_permutex2var_pd(fx1, ihi, fy1)));
      }
    };
    run(s0, r1, true);
    run(a0, a1, false);
    for (int q = 0; q < m; ++q) {
      f[2 * (s0 + q)] += _mm512_reduce_add_ps(_mm512_load_ps(fix[q]));
      f[2 * (s0 + q) + 1] += _mm512_reduce_add_ps(_mm512_load_ps(fiy[q]));
    }
  }
}

// Density by cell clusters (poly6 of r^2, half stencil, j's share carried).
void cluster_density(const Cloud& c, const Coefficients&, double* rho) {
  std::fill(rho, rho + c.n, 0.0);
  const __m512i even = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14);
  const __m512i odd = _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
  const __m512d H2 = _mm512_set1_pd(c.h * c.h), zero = _mm512_setzero_pd();
  alignas(64) double acc[16][8];
  const int nc = c.nc;
  for (int cell = 0; cell < nc * nc; ++cell) {
    const int s0 = c.start[cell], s1 = c.start[cell + 1];
    if (s0 == s1) continue;
    const int m = s1 - s0;
    const int cy = cell / nc, cx = cell % nc;
    const int r1 = c.start[cy * nc + std::min(cx + 1, nc - 1) + 1];
    int a0 = 0, a1 = 0;
    if (cy + 1 < nc) {
      a0 = c.start[(cy + 1) * nc + std::max(cx - 1, 0)];
      a1 = c.start[(cy + 1) * nc + std::min(cx + 1, nc - 1) + 1];
    }
    for (int q = 0; q < m; ++q) _mm512_store_pd(acc[q], zero);
    auto run = [&](int j0, int j1, bool own) {
      for (int j = j0; j < j1; j += 8) {
        const int left = j1 - j;
        const __mmask8 lanes = left >= 8 ? 0xFF : static_cast<__mmask8>((1u << left) - 1);
        const unsigned doubles = 2u * static_cast<unsigned>(std::min(left, 8));
        const __mmask8 lo_mask = static_cast<__mmask8>((1u << std::min(doubles, 8u)) - 1);
        const __mmask8 hi_mask = static_cast<__mmask8>((1u << (doubles > 8 ? doubles - 8 : 0u)) - 1);
        const __m512d xlo = _mm512_maskz_loadu_pd(lo_mask, &c.x[2 * j]);
        const __m512d xhi = _mm512_maskz_loadu_pd(hi_mask, &c.x[2 * j + 8]);
        const __m512d xj = _mm512_permutex2var_pd(xlo, even, xhi), yj = _mm512_permutex2var_pd(xlo, odd, xhi);
        __m512d wj = zero;
        for (int q = 0; q < m; ++q) {
          const int i = s0 + q;
          __mmask8 live = lanes;
          if (own) {
            const int d = i + 1 - j;
            live &= d <= 0 ? 0xFF : d >= 8 ? 0 : static_cast<__mmask8>(0xFFu << d);
          }
          const __m512d dx = _mm512_sub_pd(_mm512_set1_pd(c.x[2 * i]), xj);
          const __m512d dy = _mm512_sub_pd(_mm512_set1_pd(c.x[2 * i + 1]), yj);
          const __m512d r2 = _mm512_fmadd_pd(dx, dx, _mm512_mul_pd(dy, dy));
          const __mmask8 in = _mm512_mask_cmp_pd_mask(live, r2, H2, _CMP_LT_OQ);
          const __m512d e = _mm512_sub_pd(H2, r2);
          const __m512d w = _mm512_maskz_mul_pd(in, _mm512_mul_pd(e, e), e);
          _mm512_store_pd(acc[q], _mm512_add_pd(_mm512_load_pd(acc[q]), w));
          wj = _mm512_add_pd(wj, w);
        }
        _mm512_mask_storeu_pd(&rho[j], lanes, _mm512_add_pd(_mm512_maskz_loadu_pd(lanes, &rho[j]), wj));
      }
    };
    run(s0, r1, true);
    run(a0, a1, false);
    for (int q = 0; q < m; ++q) rho[s0 + q] += _mm512_reduce_add_pd(_mm512_load_pd(acc[q]));
  }
}
// The clusters in float, eight lanes in a 256-bit register (what the solver's
// float pair sums run): float copies made beforehand (not timed), positions
// relative to the corner of their cell; a candidate in the cell to the left or
// right of i's, or in the row above, is moved by a cell width.
struct Floats {
  std::vector<float> ux, uy, vx, vy, p, ir;
};
Floats g_f8;
void make_f8(const Cloud& c) {
  g_f8 = {};
  for (int i = 0; i < c.n; ++i) {
    const int cy = c.cell[i] / c.nc, cx = c.cell[i] % c.nc;
    g_f8.ux.push_back(float(c.x[2 * i] - cx * c.h));
    g_f8.uy.push_back(float(c.x[2 * i + 1] - cy * c.h));
    g_f8.vx.push_back(float(c.v[2 * i]));
    g_f8.vy.push_back(float(c.v[2 * i + 1]));
    g_f8.p.push_back(float(c.p[i]));
    g_f8.ir.push_back(float(c.inv_rho[i]));
  }
}
// A group of eight from j of the run to j1: the lanes before xl lie a cell to
// the left, from xr on a cell to the right; ys moves the row.
struct GroupF8 {
  __mmask8 lanes;
  __m256 x, y;
  GroupF8(int j, int j1, int xl, int xr, float ys, float w) {
    const int left = j1 - j;
    lanes = left >= 8 ? 0xFF : static_cast<__mmask8>((1u << left) - 1);
    const __m256i idx = _mm256_add_epi32(_mm256_set1_epi32(j), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    x = _mm256_maskz_loadu_ps(lanes, &g_f8.ux[j]);
    x = _mm256_mask_add_ps(x, _mm256_cmpge_epi32_mask(idx, _mm256_set1_epi32(xr)), x, _mm256_set1_ps(w));
    x = _mm256_mask_sub_ps(x, _mm256_cmplt_epi32_mask(idx, _mm256_set1_epi32(xl)), x, _mm256_set1_ps(w));
    y = _mm256_add_ps(_mm256_maskz_loadu_ps(lanes, &g_f8.uy[j]), _mm256_set1_ps(ys));
  }
};
template <int K>
static inline void tile_run_f8(const Cloud& c, const Coefficients& k, double* f, int t0, int j0, int j1,
                               bool own, int xl, int xr, float ys, __m256* fix, __m256* fiy) {
  const Floats& F = g_f8;
  const __m512i ilo = _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11);
  const __m512i ihi = _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15);
  const __m256 H = _mm256_set1_ps(float(c.h)), H2 = _mm256_set1_ps(float(c.h * c.h));
  const __m256 zero = _mm256_setzero_ps();
  const __m256 G = _mm256_set1_ps(float(k.grad * 0.5)), L = _mm256_set1_ps(float(k.eta * k.lap));
  for (int j = j0; j < j1; j += 8) {
    const GroupF8 g(j, j1, xl, xr, ys, float(c.h));
    const __m256 pj = _mm256_maskz_loadu_ps(g.lanes, &F.p[j]);
    const __m256 irj = _mm256_maskz_loadu_ps(g.lanes, &F.ir[j]);
    const __m256 vxj = _mm256_maskz_loadu_ps(g.lanes, &F.vx[j]);
    const __m256 vyj = _mm256_maskz_loadu_ps(g.lanes, &F.vy[j]);
    __m256 fjx = zero, fjy = zero;
    for (int q = 0; q < K; ++q) {
      const int i = t0 + q;
      __mmask8 live = g.lanes;
      if (own) {
        const int d = i + 1 - j;
        live &= d <= 0 ? 0xFF : d >= 8 ? 0 : static_cast<__mmask8>(0xFFu << d);
      }
      if (!live) continue;
      const __m256 dx = _mm256_sub_ps(_mm256_set1_ps(F.ux[i]), g.x);
      const __m256 dy = _mm256_sub_ps(_mm256_set1_ps(F.uy[i]), g.y);
      const __m256 r2 = _mm256_fmadd_ps(dx, dx, _mm256_mul_ps(dy, dy));
      const __mmask8 in = _mm256_mask_cmp_ps_mask(live, r2, H2, _CMP_LT_OQ);
      if (!in) continue;
      const __m256 r = _mm256_sqrt_ps(r2);
      const __m256 d = _mm256_max_ps(_mm256_sub_ps(H, r), zero);
      const __mmask8 nz = _mm256_mask_cmp_ps_mask(in, r2, zero, _CMP_GT_OQ);
      const __m256 gr = _mm256_maskz_div_ps(nz, _mm256_mul_ps(d, d), r);
      const __m256 fp = _mm256_mul_ps(_mm256_mul_ps(_mm256_add_ps(_mm256_set1_ps(F.p[i]), pj), G), gr);
      __m256 tx = _mm256_maskz_fnmadd_ps(in, fp, dx, zero);
      __m256 ty = _mm256_maskz_fnmadd_ps(in, fp, dy, zero);
      const __m256 l = _mm256_maskz_mul_ps(in, L, d);
      tx = _mm256_mask_fmadd_ps(l, in, _mm256_sub_ps(vxj, _mm256_set1_ps(F.vx[i])), tx);
      ty = _mm256_mask_fmadd_ps(l, in, _mm256_sub_ps(vyj, _mm256_set1_ps(F.vy[i])), ty);
      fix[q] = _mm256_fmadd_ps(irj, tx, fix[q]);
      fiy[q] = _mm256_fmadd_ps(irj, ty, fiy[q]);
      const __m256 iri = _mm256_set1_ps(F.ir[i]);
      fjx = _mm256_fnmadd_ps(iri, tx, fjx);
      fjy = _mm256_fnmadd_ps(iri, ty, fjy);
    }
    const int left = j1 - j;
    const unsigned doubles = 2u * static_cast<unsigned>(std::min(left, 8));
    const __mmask8 lo_mask = static_cast<__mmask8>((1u << std::min(doubles, 8u)) - 1);
    const __mmask8 hi_mask = static_cast<__mmask8>((1u << (doubles > 8 ? doubles - 8 : 0u)) - 1);
    const __m512d dfx = _mm512_cvtps_pd(fjx), dfy = _mm512_cvtps_pd(fjy);
    const __m512d flo = _mm512_permutex2var_pd(dfx, ilo, dfy), fhi = _mm512_permutex2var_pd(dfx, ihi, dfy);
    _mm512_mask_storeu_pd(&f[2 * j], lo_mask, _mm512_add_pd(_mm512_maskz_loadu_pd(lo_mask, &f[2 * j]), flo));
    _mm512_mask_storeu_pd(&f[2 * j + 8], hi_mask, _mm512_add_pd(_mm512_maskz_loadu_pd(hi_mask, &f[2 * j + 8]), fhi));
  }
}
template <int K>
static inline void tile_f8(const Cloud& c, const Coefficients& k, double* f, int t0, int r1, int a0, int a1,
                           int cx, int cy) {
  const int nc = c.nc;
  __m256 fix[K], fiy[K];
  for (int q = 0; q < K; ++q) fix[q] = fiy[q] = _mm256_setzero_ps();
  tile_run_f8<K>(c, k, f, t0, t0 + 1, r1, true, -1, c.start[cy * nc + cx + 1], 0.f, fix, fiy);
  if (a1 > a0)
    tile_run_f8<K>(c, k, f, t0, a0, a1, false, c.start[(cy + 1) * nc + cx], c.start[(cy + 1) * nc + cx + 1],
                   float(c.h), fix, fiy);
  for (int q = 0; q < K; ++q) {
    f[2 * (t0 + q)] += _mm512_reduce_add_pd(_mm512_cvtps_pd(fix[q]));
    f[2 * (t0 + q) + 1] += _mm512_reduce_add_pd(_mm512_cvtps_pd(fiy[q]));
  }
}
void cluster_f8(const Cloud& c, const Coefficients& k, double* f) {
  std::fill(f, f + 2 * c.n, 0.0);
  const int nc = c.nc;
  for (int cell = 0; cell < nc * nc; ++cell) {
    const int s0 = c.start[cell], s1 = c.start[cell + 1];
    if (s0 == s1) continue;
    const int cy = cell / nc, cx = cell % nc;
    const int r1 = c.start[cy * nc + std::min(cx + 1, nc - 1) + 1];
    int a0 = 0, a1 = 0;
    if (cy + 1 < nc) {
      a0 = c.start[(cy + 1) * nc + std::max(cx - 1, 0)];
      a1 = c.start[(cy + 1) * nc + std::min(cx + 1, nc - 1) + 1];
    }
    for (int t0 = s0; t0 < s1;) {
      const int m = std::min(s1 - t0, 4);
      switch (m) {
        case 4: tile_f8<4>(c, k, f, t0, r1, a0, a1, cx, cy); break;
        case 3: tile_f8<3>(c, k, f, t0, r1, a0, a1, cx, cy); break;
        case 2: tile_f8<2>(c, k, f, t0, r1, a0, a1, cx, cy); break;
        default: tile_f8<1>(c, k, f, t0, r1, a0, a1, cx, cy); break;
      }
      t0 += m;
    }
  }
}
// The density the same way in float (eight lanes, no branch on the lanes
// within h: a few instructions cost less than the mispredictions).
void density_f8(const Cloud& c, const Coefficients&, double* rho) {
  std::fill(rho, rho + c.n, 0.0);
  const int nc = c.nc;
  const __m256 H2 = _mm256_set1_ps(float(c.h * c.h)), zero = _mm256_setzero_ps();
  for (int cell = 0; cell < nc * nc; ++cell) {
    const int s0 = c.start[cell], s1 = c.start[cell + 1];
    if (s0 == s1) continue;
    const int m = s1 - s0;
    const int cy = cell / nc, cx = cell % nc;
    const int r1 = c.start[cy * nc + std::min(cx + 1, nc - 1) + 1];
    int a0 = 0, a1 = 0;
    if (cy + 1 < nc) {
      a0 = c.start[(cy + 1) * nc + std::max(cx - 1, 0)];
      a1 = c.start[(cy + 1) * nc + std::min(cx + 1, nc - 1) + 1];
    }
    __m256 acc[16];
    for (int q = 0; q < m; ++q) acc[q] = zero;
    auto run = [&](int j0, int j1, bool own, int xl, int xr, float ys) {
      for (int j = j0; j < j1; j += 8) {
        const GroupF8 g(j, j1, xl, xr, ys, float(c.h));
        __m256 wj = zero;
        for (int q = 0; q < m; ++q) {
          const int i = s0 + q;
          __mmask8 live = g.lanes;
          if (own) {
            const int d = i + 1 - j;
            live &= d <= 0 ? 0xFF : d >= 8 ? 0 : static_cast<__mmask8>(0xFFu << d);
          }
          const __m256 dx = _mm256_sub_ps(_mm256_set1_ps(g_f8.ux[i]), g.x);
          const __m256 dy = _mm256_sub_ps(_mm256_set1_ps(g_f8.uy[i]), g.y);
          const __m256 r2 = _mm256_fmadd_ps(dx, dx, _mm256_mul_ps(dy, dy));
          const __mmask8 in = _mm256_mask_cmp_ps_mask(live, r2, H2, _CMP_LT_OQ);
          const __m256 e = _mm256_sub_ps(H2, r2);
          const __m256 w = _mm256_maskz_mul_ps(in, _mm256_mul_ps(e, e), e);
          acc[q] = _mm256_add_ps(acc[q], w);
          wj = _mm256_add_ps(wj, w);
        }
        _mm512_mask_storeu_pd(&rho[j], g.lanes,
                              _mm512_add_pd(_mm512_maskz_loadu_pd(g.lanes, &rho[j]), _mm512_cvtps_pd(wj)));
      }
    };
    run(s0, r1, true, -1, c.start[cy * nc + cx + 1], 0.f);
    if (a1 > a0) run(a0, a1, false, c.start[(cy + 1) * nc + cx], c.start[(cy + 1) * nc + cx + 1], float(c.h));
    for (int q = 0; q < m; ++q) rho[s0 + q] += _mm512_reduce_add_pd(_mm512_cvtps_pd(acc[q]));
  }
}
void list_density(const Cloud& c, const Coefficients&, double* rho) {
  const double h2 = c.h * c.h;
  for (int i = 0; i < c.n; ++i) {
    double s = 0;
    for (int q = c.row[i]; q < c.row[i + 1]; ++q) {
      const int j = c.nbr[q];
      const double dx = c.x[2 * i] - c.x[2 * j], dy = c.x[2 * i + 1] - c.x[2 * j + 1];
      const double e = h2 - (dx * dx + dy * dy);
      s += e * e * e;
    }
    rho[i] = s;
  }
}

void cell_runs(const Cloud& c, const Coefficients& k, double* f) {
  const __m512i even = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14);
  const __m512i odd = _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
  const __m512d zero = _mm512_setzero_pd(), h = _mm512_set1_pd(c.h), h2 = _mm512_set1_pd(c.h * c.h);
  const __m512d half = _mm512_set1_pd(0.5), grad = _mm512_set1_pd(k.grad);
  const __m512d lap = _mm512_set1_pd(k.eta * k.lap);
  for (int i = 0; i < c.n; ++i) {
    const __m512d xi = _mm512_set1_pd(c.x[2 * i]), yi = _mm512_set1_pd(c.x[2 * i + 1]);
    const __m512d pi = _mm512_set1_pd(c.p[i]);
    const __m512d vxi = _mm512_set1_pd(c.v[2 * i]), vyi = _mm512_set1_pd(c.v[2 * i + 1]);
    __m512d fx = zero, fy = zero;
    const int cy = c.cell[i] / c.nc, cx = c.cell[i] % c.nc;
    for (int yy = std::max(cy - 1, 0); yy <= std::min(cy + 1, c.nc - 1); ++yy) {
      const int j0 = c.start[yy * c.nc + std::max(cx - 1, 0)];
      const int j1 = c.start[yy * c.nc + std::min(cx + 1, c.nc - 1) + 1];
      for (int j = j0; j < j1; j += 8) {
        const int left = j1 - j;
        const __mmask8 lanes = left >= 8 ? 0xFF : static_cast<__mmask8>((1u << left) - 1);
        const unsigned doubles = 2u * static_cast<unsigned>(std::min(left, 8));
        const __mmask8 lo_mask = static_cast<__mmask8>((1u << std::min(doubles, 8u)) - 1);
        const __mmask8 hi_mask = static_cast<__mmask8>((1u << (doubles > 8 ? doubles - 8 : 0u)) - 1);
        const __m512d xlo = _mm512_maskz_loadu_pd(lo_mask, &c.x[2 * j]);
        const __m512d xhi = _mm512_maskz_loadu_pd(hi_mask, &c.x[2 * j + 8]);
        const __m512d dx = _mm512_sub_pd(xi, _mm512_permutex2var_pd(xlo, even, xhi));
        const __m512d dy = _mm512_sub_pd(yi, _mm512_permutex2var_pd(xlo, odd, xhi));
        const __m512d r2 = _mm512_fmadd_pd(dx, dx, _mm512_mul_pd(dy, dy));
        const __mmask8 in = _mm512_mask_cmp_pd_mask(lanes, r2, h2, _CMP_LT_OQ) &
                            _mm512_mask_cmp_pd_mask(lanes, r2, zero, _CMP_GT_OQ);
        const __m512d r = _mm512_sqrt_pd(r2), d = _mm512_sub_pd(h, r);
        const __m512d g = _mm512_maskz_div_pd(in, _mm512_mul_pd(_mm512_mul_pd(d, d), grad), r);
        const __m512d ir = _mm512_maskz_loadu_pd(lanes, &c.inv_rho[j]);
        const __m512d pj = _mm512_maskz_loadu_pd(lanes, &c.p[j]);
        const __m512d fp = _mm512_mul_pd(_mm512_mul_pd(half, _mm512_add_pd(pi, pj)), _mm512_mul_pd(ir, g));
        const __m512d fv = _mm512_maskz_mul_pd(in, _mm512_mul_pd(lap, ir), d);
        const __m512d vlo = _mm512_maskz_loadu_pd(lo_mask, &c.v[2 * j]);
        const __m512d vhi = _mm512_maskz_loadu_pd(hi_mask, &c.v[2 * j + 8]);
        const __m512d dvx = _mm512_sub_pd(_mm512_permutex2var_pd(vlo, even, vhi), vxi);
        const __m512d dvy = _mm512_sub_pd(_mm512_permutex2var_pd(vlo, odd, vhi), vyi);
        fx = _mm512_fnmadd_pd(fp, dx, _mm512_fmadd_pd(fv, dvx, fx));
        fy = _mm512_fnmadd_pd(fp, dy, _mm512_fmadd_pd(fv, dvy, fy));
      }
    }
    f[2 * i] = _mm512_reduce_add_pd(fx);
    f[2 * i + 1] = _mm512_reduce_add_pd(fy);
  }
}

}  // namespace

int main() {
  const Cloud c = make_cloud();
  const double h5 = std::pow(c.h, 5);
  const Coefficients k{-30 / (M_PI * h5), 40 / (M_PI * h5), 1.0};
  std::vector<double> ref(2 * c.n), out(2 * c.n);
  scalar_list(c, k, ref.data());
  std::printf("%d particles, %.2f neighbours and %.2f candidates per particle\n", c.n,
              double(c.nbr.size()) / c.n, [&] {
                long sum = 0;
                for (int i = 0; i < c.n; ++i) {
                  const int cy = c.cell[i] / c.nc, cx = c.cell[i] % c.nc;
                  for (int yy = std::max(cy - 1, 0); yy <= std::min(cy + 1, c.nc - 1); ++yy)
                    sum += c.start[yy * c.nc + std::min(cx + 1, c.nc - 1) + 1] -
                           c.start[yy * c.nc + std::max(cx - 1, 0)];
                }
                return double(sum) / c.n;
              }());
  count_tiled(c);
  g_inv_r.resize(c.nbr.size());
  for (int i = 0; i < c.n; ++i)
    for (int q = c.row[i]; q < c.row[i + 1]; ++q) {
      const int j = c.nbr[q];
      const double dx = c.x[2 * i] - c.x[2 * j], dy = c.x[2 * i + 1] - c.x[2 * j + 1];
      g_inv_r[q] = 1 / std::sqrt(dx * dx + dy * dy);
    }
  g_inv_rf.assign(g_inv_r.begin(), g_inv_r.end());
  g_xf.assign(c.x.begin(), c.x.end());
  g_vf.assign(c.v.begin(), c.v.end());
  g_pf.assign(c.p.begin(), c.p.end());
  g_irf.assign(c.inv_rho.begin(), c.inv_rho.end());
  for (int i = 0; i < c.n; ++i) {
    g_fx.push_back(static_cast<float>(c.x[2 * i]));
    g_fy.push_back(static_cast<float>(c.x[2 * i + 1]));
  }
  struct Variant {
    const char* name;
    void (*run)(const Cloud&, const Coefficients&, double*);
  };
  {
    std::vector<double> r0(c.n), r1(c.n);
    list_density(c, k, r0.data());
    double best = 1e9;
    for (int rep = 0; rep < 5; ++rep) {
      const auto t0 = std::chrono::steady_clock::now();
      for (int s = 0; s < 50; ++s) cluster_density(c, k, r1.data());
      best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() * 1e9 / (50.0 * c.n));
    }
    double diff = 0;
    for (int i = 0; i < c.n; ++i) diff = std::max(diff, std::abs(r1[i] - r0[i]) / r0[i]);
    double bl = 1e9;
    for (int rep = 0; rep < 5; ++rep) {
      const auto t0 = std::chrono::steady_clock::now();
      for (int s = 0; s < 50; ++s) list_density(c, k, r0.data());
      bl = std::min(bl, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() * 1e9 / (50.0 * c.n));
    }
    std::printf("density: cluster %.1f ns per particle (max rel diff %.1e), over a full list %.1f ns\n", best, diff, bl);
    make_f8(c);
    double bf = 1e9;
    for (int rep = 0; rep < 5; ++rep) {
      const auto t0 = std::chrono::steady_clock::now();
      for (int s = 0; s < 50; ++s) density_f8(c, k, r1.data());
      bf = std::min(bf, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() * 1e9 / (50.0 * c.n));
    }
    diff = 0;
    for (int i = 0; i < c.n; ++i) diff = std::max(diff, std::abs(r1[i] - r0[i]) / r0[i]);
    std::printf("density: cluster in float, 8 lanes, %.1f ns per particle (max rel diff %.1e)\n", bf, diff);
  }
  for (const Variant& var : {Variant{"scalar, neighbour list", scalar_list},
                             Variant{"AVX-512, list with gathers", gather_list},
                             Variant{"AVX-512 roots, scalar sums", hybrid_list},
                             Variant{"scalar, each pair once", symmetric_list},
                             Variant{"each pair once, 1/r stored", symmetric_stored},
                             Variant{"once, float 1/r + Newton", symmetric_stored_f},
                             Variant{"cell clusters, sqrt + div", cluster_pairs<true>},
                             Variant{"cell clusters, rsqrt + Newton", cluster_pairs<false>},
                             Variant{"clusters, tiles of 4", cluster_tiled<true>},
                             Variant{"  tiles of 4, one test a tile", cluster_tiled<false>},
                             Variant{"  float prefilter x16", cluster_prefilter},
                             Variant{"  probe: no sqrt, no division", cluster_pairs<true, Probe::NoRoot>},
                             Variant{"  probe: no viscosity", cluster_pairs<true, Probe::NoViscosity>},
                             Variant{"  probe: traversal only", cluster_pairs<true, Probe::Traversal>},
                             Variant{"clusters, float x16, converted", cluster_pairs_f<false>},
                             Variant{"clusters, float x16, copies", cluster_pairs_f<true>},
                             Variant{"clusters, float x8 (256-bit)", cluster_f8},
                             Variant{"AVX-512, cell runs (no list)", cell_runs}}) {
    double best = 1e9;
    for (int rep = 0; rep < 5; ++rep) {
      const auto t0 = std::chrono::steady_clock::now();
      for (int s = 0; s < 50; ++s) var.run(c, k, out.data());
      const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      best = std::min(best, t * 1e9 / (50.0 * c.n));
    }
    double diff = 0, scale = 0;
    for (int i = 0; i < 2 * c.n; ++i) {
      diff = std::max(diff, std::abs(out[i] - ref[i]));
      scale = std::max(scale, std::abs(ref[i]));
    }
    std::printf("%-32s %6.1f ns per particle (best of 5; max difference %.1e of the largest force)\n",
                var.name, best, diff / scale);
  }
  return 0;
}
