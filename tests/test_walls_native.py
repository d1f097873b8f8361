"""WallSet::may_hit, the integration's shortcut past the wall collision, checked
in a small program against collide itself: over random walls (a box, slanted
segments, segments along the lookup grid's lines) and random short paths,
every path may_hit lets through untested is one that collide leaves as it is.
The walls are built with a tiny support h, so that the lookup cells are small
and most paths are skipped."""
from __future__ import annotations

import os
import shutil
import subprocess

import pytest
from conftest import ROOT
from test_grid_filter import eigen_include

DRIVER = r"""
#include <cstdio>
#include <vector>
#include "boundary/walls.hpp"
using namespace sphfluid;

int main() {
  unsigned s = 2024;
  auto rnd = [&] { s = s * 1664525u + 1013904223u; return (s >> 8) / double(1u << 24); };
  std::vector<Segment> segs;
  const Vec2 box[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (int k = 0; k < 4; ++k) segs.push_back(make_segment(box[k], box[(k + 1) % 4]));
  for (int k = 0; k < 12; ++k)  // slanted segments inside the box
    segs.push_back(make_segment(Vec2(rnd(), rnd()), Vec2(rnd(), rnd())));
  for (int k = 1; k < 4; ++k)  // along grid lines of the lookup cells (h = 0.01)
    segs.push_back(make_segment(Vec2(0.25 * k, 0.1), Vec2(0.25 * k, 0.9)));
  const WallSet walls(segs, 0.01);
  long skipped = 0, wrong = 0;
  for (long k = 0; k < 2000000; ++k) {
    const Vec2 p0(1.2 * rnd() - 0.1, 1.2 * rnd() - 0.1);
    const Real len = k % 3 == 0 ? 0.02 * rnd() : 0.002 * rnd();
    const Real ang = 6.283185307179586 * rnd();
    const Vec2 p1 = p0 + len * Vec2(std::cos(ang), std::sin(ang));
    if (walls.may_hit(p0, p1)) continue;
    ++skipped;
    Vec2 x = p1, v(1.0, 2.0);
    walls.collide(p0, x, v, 0.5);
    if (x != p1 || v != Vec2(1.0, 2.0)) ++wrong;
  }
  std::printf("skipped %ld, changed by collide %ld\n", skipped, wrong);
  return wrong != 0 || skipped < 100000;
}
"""


def build_and_run(tmp_path, source, *flags, units=("boundary/walls.cpp",)):
    """Compile a driver with the given units of cpp/ (boundary/walls.cpp unless said) and run it
    (skips without a compiler or Eigen)."""
    cxx = os.environ.get("CXX") or shutil.which("c++") or shutil.which("g++")
    eigen = eigen_include()
    if cxx is None or eigen is None:
        pytest.skip("needs a C++ compiler and Eigen's headers (pip install cmeel-eigen)")
    (tmp_path / "driver.cpp").write_text(source)
    cpp = ROOT / "cpp"
    exe = tmp_path / "driver"
    subprocess.run([cxx, "-std=c++17", "-O2", *flags, f"-I{cpp}", f"-isystem{eigen}",
                    str(tmp_path / "driver.cpp"), *(str(cpp / u) for u in units), "-o", str(exe)],
                   check=True, capture_output=True, text=True)
    return subprocess.run([str(exe)], capture_output=True, text=True, check=False)


def test_may_hit_never_skips_a_collision(tmp_path):
    out = build_and_run(tmp_path, DRIVER)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "changed by collide 0" in out.stdout

DRIVER8 = r"""
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>
#include "boundary/walls.hpp"
using namespace sphfluid;

int main() {
#if defined(__AVX512F__) && defined(__AVX512VL__)
  unsigned s = 7;
  auto rnd = [&] { s = s * 1664525u + 1013904223u; return (s >> 8) / double(1u << 24); };
  std::vector<Segment> segs;
  const Vec2 box[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (int k = 0; k < 4; ++k) segs.push_back(make_segment(box[k], box[(k + 1) % 4]));
  for (int k = 0; k < 6; ++k) segs.push_back(make_segment(Vec2(rnd(), rnd()), Vec2(rnd(), rnd())));
  const WallSet walls(segs, 0.05);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  // Points of every kind: inside, off the lookup grid, on cell edges, not finite.
  auto point = [&](double& x, double& y) {
    const unsigned kind = s % 9;
    x = 1.4 * rnd() - 0.2;
    y = 1.4 * rnd() - 0.2;
    if (kind == 0) x = nan;
    if (kind == 1) y = -inf;
    if (kind == 2) x = 0.05 * std::floor(20 * x);  // on a cell line (cells of about h)
    if (kind == 3) x = -5;                           // far off the grid
  };
  long checked = 0, wrong = 0, wrong_near = 0, with_ghosts = 0, near_without = 0;
  for (long k = 0; k < 200000; ++k) {
    alignas(64) double x0[8], y0[8], x1[8], y1[8];
    for (int l = 0; l < 8; ++l) {
      point(x0[l], y0[l]);
      if (s % 4 == 0) {  // a short path, often within one cell
        x1[l] = x0[l] + 0.01 * (rnd() - 0.5);
        y1[l] = y0[l] + 0.01 * (rnd() - 0.5);
      } else {
        point(x1[l], y1[l]);
      }
    }
    const __mmask8 lanes = static_cast<__mmask8>(s >> 5);
    using simd::D8;
    const __mmask8 got = walls.may_hit8(lanes, D8::loadu(x0), D8::loadu(y0), D8::loadu(x1),
                                        D8::loadu(y1));
    const __mmask8 near = walls.near8(lanes, D8::loadu(x0), D8::loadu(y0));
    for (int l = 0; l < 8; ++l) {
      const Vec2 p0(x0[l], y0[l]);
      const bool want = (lanes >> l & 1) && walls.may_hit(p0, Vec2(x1[l], y1[l]));
      wrong += want != bool(got >> l & 1);
      ++checked;
      // near8: every point with a ghost is near; a near point lies in a
      // lookup cell with walls (where may_hit of a path that stays put is true)
      bool ghost = false;
      walls.for_each_ghost(p0, [&](const Vec2&, bool) { ghost = true; });
      const bool is_near = near >> l & 1;
      if (!(lanes >> l & 1)) {
        wrong_near += is_near;
      } else {
        wrong_near += (ghost && !is_near) || (is_near && !walls.may_hit(p0, p0));
        with_ghosts += ghost;
        near_without += is_near && !ghost;
      }
    }
  }
  // What the integration takes from the ghost search (Solver::find_ghosts,
  // Solver::integrate): a path shorter than the clearance (safe_path2 of the
  // distance for_each_ghost returns) meets no wall; from points with ghosts,
  // from points near walls without, from points no wall comes near, and from
  // points on a wall (the cell lines include the box's sides). Paths up to
  // three clearances long must meet walls, or this check could not fail.
  long short_paths = 0, hit = 0, long_paths = 0, long_hit = 0;
  for (long k = 0; k < 400000; ++k) {
    double x0, y0;
    point(x0, y0);
    if (!std::isfinite(x0) || !std::isfinite(y0)) continue;
    const Vec2 p0(x0, y0);
    // as the solver keeps it: in float
    const Real c2 = static_cast<float>(walls.safe_path2(walls.for_each_ghost(p0, [](const Vec2&, bool) {})));
    const bool too_long = k % 2 == 1;
    const Real len = (too_long ? 3 : 1) * std::sqrt(c2 * rnd()), ang = 6.283185307179586 * rnd();
    const Vec2 p1 = p0 + len * Vec2(std::cos(ang), std::sin(ang));
    Vec2 x = p1, v(1.0, 2.0);
    walls.collide(p0, x, v, 0.5);
    const bool changed = x != p1 || v != Vec2(1.0, 2.0);
    if (too_long) {
      ++long_paths;
      long_hit += changed;
    } else {
      ++short_paths;
      hit += changed;
    }
  }
  std::printf("checked %ld lanes, wrong %ld\n", checked, wrong);
  std::printf("near8: %ld lanes with ghosts, %ld near without, wrong %ld\n", with_ghosts,
              near_without, wrong_near);
  std::printf("paths shorter than the clearance: %ld, met a wall %ld\n", short_paths, hit);
  std::printf("paths up to three clearances: %ld, met a wall %ld\n", long_paths, long_hit);
  wrong += hit;
  if (short_paths < 100000 || long_hit < 100) ++wrong;
  wrong += wrong_near;
  if (with_ghosts < 1000 || near_without < 1000) ++wrong;  // both sides exercised
  return wrong != 0;
#else
  std::printf("no AVX-512\n");
  return 0;
#endif
}
"""


def test_may_hit8_agrees_with_may_hit_on_every_lane(tmp_path):
    """The integration's eight-lane wall check (AVX-512 builds) against the
    scalar one, lane by lane: random lane masks, points off the lookup grid,
    on its cell lines and not finite. And the ghost search's eight-lane test
    (near8): no point with a wall ghost is left out, no point is taken in
    whose lookup cell has no wall. And no path shorter than a point's clearance
    from the ghost search meets a wall (the integration skips the wall check
    there)."""
    out = build_and_run(tmp_path, DRIVER8, "-march=native")
    if "no AVX-512" in out.stdout:
        pytest.skip("this CPU has no AVX-512 (the eight-lane check is not built)")
    assert out.returncode == 0, out.stdout + out.stderr
    assert "wrong 0" in out.stdout
