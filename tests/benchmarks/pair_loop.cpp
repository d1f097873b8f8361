// Five ways to evaluate the seed's pair force (spiky pressure gradient plus the
// viscosity Laplacian) on a jittered lattice of 10,000 particles sorted by
// cells of h = 2 dx, as in the 10k dam break: the scalar neighbour-list loop the
// solver runs, the same list eight lanes at a time with AVX-512 gathers, only
// the square roots and divisions on AVX-512 lanes with scalar sums, each pair
// once with its terms scattered to both particles, and AVX-512 over the
// contiguous candidate runs of the 3 x 3 cells (no list, the r < h test as a
// mask). BENCHMARKS.md, "What was tried", quotes its output.
//
//   g++ -O3 -march=native -fno-math-errno tests/benchmarks/pair_loop.cpp -o /tmp/pair_loop
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
  struct Variant {
    const char* name;
    void (*run)(const Cloud&, const Coefficients&, double*);
  };
  for (const Variant& var : {Variant{"scalar, neighbour list", scalar_list},
                             Variant{"AVX-512, list with gathers", gather_list},
                             Variant{"AVX-512 roots, scalar sums", hybrid_list},
                             Variant{"scalar, each pair once", symmetric_list},
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
    std::printf("%-30s %6.1f ns per particle (best of 5; max difference %.1e of the largest force)\n",
                var.name, best, diff / scale);
  }
  return 0;
}
