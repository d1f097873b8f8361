/* The throughput of one square root and one division in double precision,
 * the core of every SPH pair force (|r| and r/|r|): a bound on how fast a
 * scalar pair loop can go on this machine (BENCHMARKS.md, "Roofline").
 *
 *   gcc -O2 -fno-tree-vectorize benchmarks/experiments/sqrt_div.c -o /tmp/sqrt_div -lm && /tmp/sqrt_div
 */
#include <math.h>
#include <stdio.h>
#include <time.h>

static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

int main(void) {
  enum { N = 4096, SWEEPS = 2000, REPEATS = 20 };
  static double r2[N], out[N];
  for (int i = 0; i < N; i++) r2[i] = 1e-4 * (1 + i % 97);
  double best = 1e9;
  for (int rep = 0; rep < REPEATS; rep++) {
    const double t0 = now();
    for (int k = 0; k < SWEEPS; k++)
      for (int i = 0; i < N; i++) {  /* independent pairs: throughput, not latency */
        const double r = sqrt(r2[i]);
        out[i] += (0.05 - r) * (0.05 - r) / r;
      }
    const double dt = (now() - t0) / ((double)SWEEPS * N);
    if (dt < best) best = dt;
  }
  printf("one sqrt + one division per pair: %.2f ns (best of %d; checksum %g)\n", best * 1e9,
         REPEATS, out[5]);
  return 0;
}
