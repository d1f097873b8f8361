"""The particle set's field registry (cpp/core/particles.hpp), in a small
program: a field a method adds in one line follows its particle through a
permutation and through moves (in place, and through the permutation a
numpy view forces), and is resized, compacted and counted with the rest; a
derived field is left to be recomputed; a field that goes away leaves the
registry. (The moves cut into parts, one a thread, are checked through the
solver's sort in test_grid.py.)"""
from __future__ import annotations

from test_walls_native import build_and_run

DRIVER = r"""
#include <cstdio>
#include <memory>
#include <vector>
#include "core/particles.hpp"
using namespace sphfluid;

int main() {
  int bad = 0;
  ParticleSet ps;
  // what a method would add: one state field, one derived one
  auto warm = std::make_unique<Field<Real>>(ps, "warm start", FieldKind::kState);
  Field<Real> rate(ps, "rate", FieldKind::kDerived);
  bad += ps.fields().size() != 8;
  const Index n = 1000;
  ps.resize(n);
  bad += warm->size() != std::size_t(n) || rate.size() != std::size_t(n);
  for (Index i = 0; i < n; ++i) {
    ps.x[i] = Vec2(i, -i);
    ps.v[i] = Vec2(2 * i, 0);
    ps.id[i] = 10 * i;
    (*warm)[i] = 0.5 * i;
    rate[i] = -1;
  }
  auto follows = [&]() {  // each particle's state fields agree with its id
    int wrong = 0;
    for (Index i = 0; i < ps.size(); ++i) {
      const Real k = static_cast<Real>(ps.id[i] / 10);
      wrong += ps.x[i] != Vec2(k, -k) || ps.v[i] != Vec2(2 * k, 0) || (*warm)[i] != 0.5 * k;
    }
    return wrong;
  };
  // a permutation: reversed
  std::vector<Index> order(n);
  for (Index k = 0; k < n; ++k) order[k] = n - 1 - k;
  ps.permute_state(order, 2);
  bad += follows() + (ps.id[0] != 10 * (n - 1));
  bad += rate[0] != -1;  // derived: untouched
  // moves: entry 3 jumps to the end, the block 4..n-1 shifts down by one
  std::vector<Move> blocks{{4, 3, n - 4}}, jumps{{3, n - 1, 1}};
  const Id jumper = ps.id[3];
  MoveParts parts;
  parts.at = {0, n};
  parts.block = {0, 1};
  parts.jump = {0, 1};
  ps.apply_moves(blocks, jumps, parts, order, 1);
  bad += follows() + (ps.id[n - 1] != jumper);
  // the same through a permutation, as when a numpy view shares a buffer
  const auto view = ps.x.share();
  const Id jumper2 = ps.id[3];
  ps.apply_moves(blocks, jumps, parts, order, 1);
  bad += follows() + (ps.id[n - 1] != jumper2) + ((*view)[n - 1] != Vec2(jumper / 10, -(jumper / 10)));
  // compaction keeps every field in step
  std::vector<char> keep(n, 1);
  for (Index i = 0; i < n; i += 3) keep[i] = 0;
  ps.compact(keep);
  bad += warm->size() != ps.x.size() || rate.size() != ps.x.size() || follows() != 0;
  const std::size_t with = ps.bytes();
  warm.reset();  // the field goes away with its method
  bad += ps.fields().size() != 7 || !(ps.bytes() < with);
  std::printf("fields: %zu, wrong %d\n", ps.fields().size(), bad);
  return bad != 0;
}
"""


def test_a_registered_field_follows_its_particle(tmp_path):
    out = build_and_run(tmp_path, DRIVER, "-fopenmp", units=())
    assert out.returncode == 0, out.stdout + out.stderr
    assert "wrong 0" in out.stdout
