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
#include "walls.hpp"
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


def test_may_hit_never_skips_a_collision(tmp_path):
    cxx = os.environ.get("CXX") or shutil.which("c++") or shutil.which("g++")
    eigen = eigen_include()
    if cxx is None or eigen is None:
        pytest.skip("needs a C++ compiler and Eigen's headers (pip install cmeel-eigen)")
    (tmp_path / "driver.cpp").write_text(DRIVER)
    cpp = ROOT / "cpp"
    exe = tmp_path / "driver"
    subprocess.run([cxx, "-std=c++17", "-O2", f"-I{cpp}", f"-isystem{eigen}",
                    str(tmp_path / "driver.cpp"), str(cpp / "walls.cpp"), "-o", str(exe)],
                   check=True, capture_output=True, text=True)
    out = subprocess.run([str(exe)], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "changed by collide 0" in out.stdout
