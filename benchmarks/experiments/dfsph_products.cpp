// The two pair loops of a dfsph solve's product (docs/method-dfsph.md, D4
// and D5) over a pair table like the solver's: a 100 x 100 lattice, each
// particle's neighbours within 2 spacings in row order (the ring at exactly 2
// spacings half kept: about 10 a row, as in the 10k dam break). The rate loop
// sums (u_i - u_j) . mg over a row; the pressure loop -(k_i + k_j) mg.
// Each scalar, as the solver runs them; along each row eight lanes at a time
// with AVX-512 gathers (u in two arrays, or gathered from the pairs of
// doubles); and with the rows in groups of eight, the table stored slice by
// slice and padded to the group's longest row (SELL-8: one lane per row, no
// horizontal sum). Best of 200 runs each, one thread; docs/method-dfsph.md
// ("Speed") quotes it.
//
//   g++ -O3 -march=native -o /tmp/dfsph_products dfsph_products.cpp && /tmp/dfsph_products
#include <immintrin.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

namespace {

struct V2 {
  double x, y;
};

template <class F>
void best_of(const char* name, std::size_t pairs, const std::vector<double>& out, F f) {
  double best = 1e9;
  for (int rep = 0; rep < 200; ++rep) {
    const auto a = std::chrono::steady_clock::now();
    f();
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count());
  }
  double check = 0;
  for (double v : out) check += v;
  std::printf("%-28s %7.1f us  %5.2f ns/pair  (sum %.6f)\n", name, best * 1e6, best * 1e9 / pairs,
              check);
}

__mmask8 tail(int left) { return left >= 8 ? 0xFF : static_cast<__mmask8>((1u << left) - 1); }

}  // namespace

int main() {
  const int side = 100, n = side * side;
  std::vector<int> first(n + 1, 0), pj;
  std::vector<V2> mg;
  std::vector<double> mgx, mgy;
  unsigned seed = 1;
  for (int i = 0; i < n; ++i) {
    const int cx = i % side, cy = i / side;
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx) {
        const int d2 = dx * dx + dy * dy, x = cx + dx, y = cy + dy;
        if (d2 == 0 || d2 > 4 || x < 0 || y < 0 || x >= side || y >= side) continue;
        seed = seed * 1664525u + 1013904223u;
        if (d2 == 4 && (seed >> 16 & 1)) continue;
        pj.push_back(y * side + x);
        mg.push_back({0.1 * dx, 0.1 * dy});
        mgx.push_back(0.1 * dx);
        mgy.push_back(0.1 * dy);
      }
    first[i + 1] = static_cast<int>(pj.size());
  }
  const std::size_t pairs = pj.size();
  std::printf("%d particles, %.2f pairs a row\n", n, double(pairs) / n);
  std::vector<V2> u(n);
  std::vector<double> ux(n), uy(n), z(n), r(n);
  for (int i = 0; i < n; ++i) {
    u[i] = {std::sin(0.1 * i), std::cos(0.3 * i)};
    ux[i] = u[i].x;
    uy[i] = u[i].y;
    z[i] = std::sin(0.7 * i);
  }

  best_of("rate, scalar", pairs, r, [&] {
    for (int i = 0; i < n; ++i) {
      const V2 ui = u[i];
      double s = 0;
      for (int q = first[i]; q < first[i + 1]; ++q) {
        const V2& uj = u[pj[q]];
        s += (ui.x - uj.x) * mg[q].x + (ui.y - uj.y) * mg[q].y;
      }
      r[i] = s;
    }
  });
  auto rate_rows = [&](const double* bx, const double* by, int shift) {
    for (int i = 0; i < n; ++i) {
      __m512d ax = _mm512_setzero_pd(), ay = _mm512_setzero_pd();
      const __m512d uix = _mm512_set1_pd(ux[i]), uiy = _mm512_set1_pd(uy[i]);
      for (int q = first[i]; q < first[i + 1]; q += 8) {
        const __mmask8 m = tail(first[i + 1] - q);
        const __m256i j = _mm256_slli_epi32(_mm256_maskz_loadu_epi32(m, &pj[q]), shift);
        const __m512d gx = _mm512_mask_i32gather_pd(uix, m, j, bx, 8);
        const __m512d gy = _mm512_mask_i32gather_pd(uiy, m, j, by, 8);
        ax = _mm512_fmadd_pd(_mm512_sub_pd(uix, gx), _mm512_maskz_loadu_pd(m, &mgx[q]), ax);
        ay = _mm512_fmadd_pd(_mm512_sub_pd(uiy, gy), _mm512_maskz_loadu_pd(m, &mgy[q]), ay);
      }
      r[i] = _mm512_reduce_add_pd(_mm512_add_pd(ax, ay));
    }
  };
  best_of("rate, gathers along rows", pairs, r, [&] { rate_rows(ux.data(), uy.data(), 0); });
  best_of("rate, gathers from pairs", pairs, r, [&] { rate_rows(&u[0].x, &u[0].y, 1); });

  // SELL-8: slice k of group g holds the k-th pair of its eight rows; a
  // shorter row's padding points at the row itself with mg = 0.
  const int groups = (n + 7) / 8;
  std::vector<int> start(groups + 1, 0);
  for (int g = 0; g < groups; ++g) {
    int longest = 0;
    for (int i = 8 * g; i < std::min(n, 8 * g + 8); ++i) longest = std::max(longest, first[i + 1] - first[i]);
    start[g + 1] = start[g] + 8 * longest;
  }
  std::vector<int> sj(start[groups]);
  std::vector<double> sx(start[groups]), sy(start[groups]);
  for (int g = 0; g < groups; ++g)
    for (int k = 0; k < (start[g + 1] - start[g]) / 8; ++k)
      for (int l = 0; l < 8; ++l) {
        const int i = std::min(8 * g + l, n - 1), q = first[i] + k, o = start[g] + 8 * k + l;
        const bool real = 8 * g + l < n && q < first[i + 1];
        sj[o] = real ? pj[q] : i;
        sx[o] = real ? mgx[q] : 0;
        sy[o] = real ? mgy[q] : 0;
      }
  std::printf("SELL-8 padding: %.2f of the pairs\n", double(start[groups]) / pairs - 1);
  best_of("rate, SELL-8", pairs, r, [&] {
    for (int g = 0; g < groups; ++g) {
      const __m512d uix = _mm512_loadu_pd(&ux[8 * g]), uiy = _mm512_loadu_pd(&uy[8 * g]);
      __m512d a = _mm512_setzero_pd();
      for (int o = start[g]; o < start[g + 1]; o += 8) {
        const __m256i j = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(&sj[o]));
        const __m512d gx = _mm512_i32gather_pd(j, ux.data(), 8);
        const __m512d gy = _mm512_i32gather_pd(j, uy.data(), 8);
        a = _mm512_fmadd_pd(_mm512_sub_pd(uix, gx), _mm512_loadu_pd(&sx[o]), a);
        a = _mm512_fmadd_pd(_mm512_sub_pd(uiy, gy), _mm512_loadu_pd(&sy[o]), a);
      }
      _mm512_storeu_pd(&r[8 * g], a);  // (n is a multiple of 8 here)
    }
  });

  best_of("pressure, scalar", pairs, r, [&] {
    for (int i = 0; i < n; ++i) {
      double fx = 0, fy = 0;
      for (int q = first[i]; q < first[i + 1]; ++q) {
        const double k = z[i] + z[pj[q]];
        fx -= k * mg[q].x;
        fy -= k * mg[q].y;
      }
      r[i] = fx + fy;
    }
  });
  best_of("pressure, gathers along rows", pairs, r, [&] {
    for (int i = 0; i < n; ++i) {
      __m512d ax = _mm512_setzero_pd(), ay = _mm512_setzero_pd();
      const __m512d zi = _mm512_set1_pd(z[i]);
      for (int q = first[i]; q < first[i + 1]; q += 8) {
        const __mmask8 m = tail(first[i + 1] - q);
        const __m256i j = _mm256_maskz_loadu_epi32(m, &pj[q]);
        const __m512d k = _mm512_add_pd(zi, _mm512_mask_i32gather_pd(_mm512_setzero_pd(), m, j, z.data(), 8));
        ax = _mm512_fnmadd_pd(k, _mm512_maskz_loadu_pd(m, &mgx[q]), ax);
        ay = _mm512_fnmadd_pd(k, _mm512_maskz_loadu_pd(m, &mgy[q]), ay);
      }
      r[i] = _mm512_reduce_add_pd(ax) + _mm512_reduce_add_pd(ay);
    }
  });
  best_of("pressure, SELL-8", pairs, r, [&] {
    for (int g = 0; g < groups; ++g) {
      const __m512d zi = _mm512_loadu_pd(&z[8 * g]);
      __m512d ax = _mm512_setzero_pd(), ay = _mm512_setzero_pd();
      for (int o = start[g]; o < start[g + 1]; o += 8) {
        const __m256i j = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(&sj[o]));
        const __m512d k = _mm512_add_pd(zi, _mm512_i32gather_pd(j, z.data(), 8));
        ax = _mm512_fnmadd_pd(k, _mm512_loadu_pd(&sx[o]), ax);
        ay = _mm512_fnmadd_pd(k, _mm512_loadu_pd(&sy[o]), ay);
      }
      _mm512_storeu_pd(&r[8 * g], _mm512_add_pd(ax, ay));
    }
  });
}
