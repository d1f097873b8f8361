// A plain SPH loop: the yardstick `sphfluid bench` divides our speed by. The seed's
// physics (SPEC.md) written the way a competent programmer writes it in an afternoon:
// scalar C++17, one OpenMP `parallel for` per pass, no intrinsics, no tricks.
//
//   density    rho_i = sum_j m W_poly6(r_ij), j = i included           (seed eq. 10)
//   pressure   p_i = k (rho_i - rho0)                                   (seed eq. 15)
//   forces     F_i = -sum_j m (p_i + p_j) / (2 rho_j) grad W_spiky(r_ij)  (seed eq. 14)
//                  + eta sum_j m (v_j - v_i) / rho_j lap W_visc(r_ij)      (seed eq. 17)
//   motion     a_i = F_i / rho_i + g; v += a dt; x += v dt  (semi-implicit Euler)
//
// Neighbours: a cell list of cells h wide over the particles' bounding box, rebuilt
// every step by a counting sort (the particles' arrays are reordered into cell
// order), and a gather over the 3 x 3 cells around each particle's cell.
// Walls: NOT the seed's ghost particles. After each step a particle past the floor
// (y = 0) or a side wall (x = 0, x = tank) is put back on it and its velocity's
// normal component made to point inwards (a reflection). tank = 0: no walls.
//
// Reads an input file (benchmarks/reference_loop.py writes it for `sphfluid bench`):
//   sphfluid-reference-loop/1
//   n N  mass M  h H  k K  rho0 R  eta E  gx GX  gy GY  tank L  dt DT
//   warmup W  steps S  threads T
//   particles
//   x y vx vy          (N lines)
// the keys in any order, one "key value" pair after another. Prints, after W untimed
// steps and S timed ones:  steps_per_s X  (and the seconds, particles and threads).
// With --dump FILE: no steps; one evaluation of the density and the acceleration
// at the initial state, written as "rho ax ay" per particle in input order.
//
//   c++ -O3 -march=native -fopenmp -std=c++17 benchmarks/reference_loop.cpp -o /tmp/reference_loop
//   /tmp/reference_loop INPUT [--dump FILE]
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Params {
  double mass = 0, h = 0, k = 0, rho0 = 0, eta = 0, gx = 0, gy = 0, tank = 0, dt = 0;
  long warmup = 0, steps = 0;
  int threads = 1;
};

struct Particles {  // one array per field, kept in cell order
  std::vector<double> x, y, vx, vy, rho, p, ax, ay;
  std::vector<long> id;  // the particle's line in the input
  void resize(std::size_t n) {
    for (auto* f : {&x, &y, &vx, &vy, &rho, &p, &ax, &ay}) f->resize(n);
    id.resize(n);
  }
};

class ReferenceLoop {
 public:
  ReferenceLoop(const Params& prm, Particles& s) : prm_(prm), s_(s) {
    h2_ = prm.h * prm.h;
    poly6_ = 4.0 / (kPi * std::pow(prm.h, 8));   // W = poly6 (h^2 - r^2)^3
    spiky_ = -30.0 / (kPi * std::pow(prm.h, 5));  // grad W = spiky (h - r)^2 r_ij / r
    visc_ = 40.0 / (kPi * std::pow(prm.h, 5));    // lap W = visc (h - r)
  }

  void step() {
    sort();
    density();
    forces();
    integrate();
  }

  void evaluate() {  // density and acceleration, no motion
    sort();
    density();
    forces();
  }

  // Counting sort of the particles into cells h wide over their bounding box.
  void sort() {
    const std::size_t n = s_.x.size();
    x0_ = *std::min_element(s_.x.begin(), s_.x.end());
    y0_ = *std::min_element(s_.y.begin(), s_.y.end());
    const double x1 = *std::max_element(s_.x.begin(), s_.x.end());
    const double y1 = *std::max_element(s_.y.begin(), s_.y.end());
    nx_ = static_cast<long>((x1 - x0_) / prm_.h) + 1;
    ny_ = static_cast<long>((y1 - y0_) / prm_.h) + 1;
    start_.assign(nx_ * ny_ + 1, 0);
    cell_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      cell_[i] = cell_of(s_.x[i], s_.y[i]);
      ++start_[cell_[i] + 1];
    }
    for (long c = 0; c < nx_ * ny_; ++c) start_[c + 1] += start_[c];
    std::vector<long> next(start_.begin(), start_.end() - 1);
    order_.resize(n);
    for (std::size_t i = 0; i < n; ++i) order_[next[cell_[i]]++] = static_cast<long>(i);
    permute(s_.x);
    permute(s_.y);
    permute(s_.vx);
    permute(s_.vy);
    std::vector<long> id(n);
    for (std::size_t i = 0; i < n; ++i) id[i] = s_.id[order_[i]];
    s_.id.swap(id);
  }

  void density() {
    const long n = static_cast<long>(s_.x.size());
#pragma omp parallel for schedule(static)
    for (long i = 0; i < n; ++i) {
      double rho = 0.0;
      for_neighbours(i, [&](long, double r2) {
        const double d = h2_ - r2;
        rho += prm_.mass * poly6_ * d * d * d;  // seed eq. 10
      });
      s_.rho[i] = rho;
      s_.p[i] = prm_.k * (rho - prm_.rho0);  // seed eq. 15
    }
  }

  void forces() {
    const long n = static_cast<long>(s_.x.size());
    const double m = prm_.mass;
#pragma omp parallel for schedule(static)
    for (long i = 0; i < n; ++i) {
      double fx = 0.0, fy = 0.0;
      for_neighbours(i, [&](long j, double r2) {
        if (j == i) return;
        const double r = std::sqrt(r2);
        const double q = prm_.h - r;
        if (r > 0.0) {  // seed eq. 14; grad W_spiky is zero at r = 0
          const double c = -m * (s_.p[i] + s_.p[j]) / (2.0 * s_.rho[j]) * spiky_ * q * q / r;
          fx += c * (s_.x[i] - s_.x[j]);
          fy += c * (s_.y[i] - s_.y[j]);
        }
        const double v = prm_.eta * m / s_.rho[j] * visc_ * q;  // seed eq. 17
        fx += v * (s_.vx[j] - s_.vx[i]);
        fy += v * (s_.vy[j] - s_.vy[i]);
      });
      s_.ax[i] = fx / s_.rho[i] + prm_.gx;
      s_.ay[i] = fy / s_.rho[i] + prm_.gy;
    }
  }

  void integrate() {
    const long n = static_cast<long>(s_.x.size());
    const double dt = prm_.dt, tank = prm_.tank;
#pragma omp parallel for schedule(static)
    for (long i = 0; i < n; ++i) {
      s_.vx[i] += s_.ax[i] * dt;
      s_.vy[i] += s_.ay[i] * dt;
      s_.x[i] += s_.vx[i] * dt;
      s_.y[i] += s_.vy[i] * dt;
      if (tank <= 0.0) continue;
      if (s_.x[i] < 0.0) {  // reflect at the walls: back on the wall, moving inwards
        s_.x[i] = 0.0;
        s_.vx[i] = std::abs(s_.vx[i]);
      } else if (s_.x[i] > tank) {
        s_.x[i] = tank;
        s_.vx[i] = -std::abs(s_.vx[i]);
      }
      if (s_.y[i] < 0.0) {
        s_.y[i] = 0.0;
        s_.vy[i] = std::abs(s_.vy[i]);
      }
    }
  }

 private:
  long cell_of(double x, double y) const {
    const long cx = std::min(nx_ - 1, static_cast<long>((x - x0_) / prm_.h));
    const long cy = std::min(ny_ - 1, static_cast<long>((y - y0_) / prm_.h));
    return cy * nx_ + cx;
  }

  void permute(std::vector<double>& field) {
    std::vector<double> out(field.size());
    for (std::size_t i = 0; i < field.size(); ++i) out[i] = field[order_[i]];
    field.swap(out);
  }

  // Calls f(j, r2) for every particle j within h of particle i (i itself included).
  template <class F>
  void for_neighbours(long i, F&& f) const {
    const long c = cell_of(s_.x[i], s_.y[i]);
    const long cx = c % nx_, cy = c / nx_;
    for (long yy = std::max(0L, cy - 1); yy <= std::min(ny_ - 1, cy + 1); ++yy) {
      for (long xx = std::max(0L, cx - 1); xx <= std::min(nx_ - 1, cx + 1); ++xx) {
        const long cell = yy * nx_ + xx;
        for (long j = start_[cell]; j < start_[cell + 1]; ++j) {
          const double dx = s_.x[i] - s_.x[j], dy = s_.y[i] - s_.y[j];
          const double r2 = dx * dx + dy * dy;
          if (r2 < h2_) f(j, r2);
        }
      }
    }
  }

  const Params& prm_;
  Particles& s_;
  double h2_, poly6_, spiky_, visc_;
  double x0_ = 0, y0_ = 0;
  long nx_ = 1, ny_ = 1;
  std::vector<long> start_, cell_, order_;
};

void read_input(const std::string& path, Params& prm, Particles& s) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::string word;
  in >> word;
  if (word != "sphfluid-reference-loop/1") throw std::runtime_error(path + ": not an input file");
  std::map<std::string, double> v;
  while (in >> word && word != "particles") {
    double value;
    if (!(in >> value)) throw std::runtime_error(path + ": no value for " + word);
    v[word] = value;
  }
  for (const char* key : {"n", "mass", "h", "k", "rho0", "eta", "gx", "gy", "tank", "dt",
                          "warmup", "steps", "threads"}) {
    if (!v.count(key)) throw std::runtime_error(path + ": missing " + key);
  }
  prm = {v["mass"], v["h"], v["k"], v["rho0"], v["eta"], v["gx"], v["gy"], v["tank"], v["dt"],
         static_cast<long>(v["warmup"]), static_cast<long>(v["steps"]),
         static_cast<int>(v["threads"])};
  const auto n = static_cast<std::size_t>(v["n"]);
  if (n == 0 || prm.h <= 0 || prm.threads < 1) throw std::runtime_error(path + ": bad values");
  s.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!(in >> s.x[i] >> s.y[i] >> s.vx[i] >> s.vy[i]))
      throw std::runtime_error(path + ": fewer than n particles");
    s.id[i] = static_cast<long>(i);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2 && !(argc == 4 && std::string(argv[2]) == "--dump")) {
    std::fprintf(stderr, "usage: %s INPUT [--dump FILE]\n", argv[0]);
    return 2;
  }
  Params prm;
  Particles s;
  try {
    read_input(argv[1], prm, s);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  omp_set_num_threads(prm.threads);
  ReferenceLoop loop(prm, s);
  if (argc == 4) {
    loop.evaluate();
    const std::size_t n = s.x.size();
    std::vector<std::size_t> at(n);  // input line -> position in cell order
    for (std::size_t i = 0; i < n; ++i) at[s.id[i]] = i;
    FILE* out = std::fopen(argv[3], "w");
    if (!out) {
      std::fprintf(stderr, "error: cannot write %s\n", argv[3]);
      return 2;
    }
    for (std::size_t line = 0; line < n; ++line) {
      const std::size_t i = at[line];
      std::fprintf(out, "%.17g %.17g %.17g\n", s.rho[i], s.ax[i], s.ay[i]);
    }
    std::fclose(out);
    return 0;
  }
  for (long k = 0; k < prm.warmup; ++k) loop.step();
  const auto begin = std::chrono::steady_clock::now();
  for (long k = 0; k < prm.steps; ++k) loop.step();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
  for (double x : s.x) {
    if (!std::isfinite(x)) {
      std::fprintf(stderr, "error: non-finite position after %ld steps\n", prm.warmup + prm.steps);
      return 1;
    }
  }
  std::printf("steps_per_s %.6g seconds %.6g steps %ld particles %zu threads %d\n",
              prm.steps / wall, wall, prm.steps, s.x.size(), prm.threads);
  return 0;
}
