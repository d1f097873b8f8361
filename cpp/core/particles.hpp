// ParticleSet: one contiguous array per particle field (structure of arrays),
// re-ordered together by one permutation. Buffers are shared with the numpy
// views handed to Python, and are copied before any write that would move or
// resize memory a view still points at (copy-on-write), so a view never dangles.
#pragma once

#include <memory>
#include <vector>

#include "neighbours/moves.hpp"
#include "core/parallel.hpp"
#include "core/types.hpp"

namespace sphfluid {

template <class T>
class Field {
 public:
  using Buffer = std::vector<T>;

  Field() : buf_(std::make_shared<Buffer>()) {}

  T* data() { return buf_->data(); }
  const T* data() const { return buf_->data(); }
  T& operator[](std::size_t i) { return (*buf_)[i]; }
  const T& operator[](std::size_t i) const { return (*buf_)[i]; }
  std::size_t size() const { return buf_->size(); }
  // Heap bytes held by this field (its buffer and its scratch), capacity included.
  std::size_t bytes() const {
    return (buf_->capacity() + (tmp_ ? tmp_->capacity() : 0)) * sizeof(T);
  }

  // The buffer as Python sees it: a view holds this pointer, keeping it alive.
  std::shared_ptr<Buffer> share() const { return buf_; }

  void resize(std::size_t n) {
    detach();
    buf_->resize(n);
  }

  // A buffer of n entries to write a new version of the field into, without
  // touching the current one; commit_write() makes it current.
  T* begin_write(std::size_t n) {
    if (!tmp_ || tmp_.use_count() > 1) tmp_ = std::make_shared<Buffer>();
    tmp_->resize(n);
    return tmp_->data();
  }
  void commit_write() { buf_.swap(tmp_); }
  // No numpy view shares the buffer: it may be changed in place.
  bool exclusive() const { return buf_.use_count() == 1; }

  // Keep the entries whose keep[i] is true, in order; returns how many remain.
  std::size_t compact(const std::vector<char>& keep) {
    detach();
    Buffer& b = *buf_;
    std::size_t w = 0;
    for (std::size_t i = 0; i < b.size(); ++i)
      if (keep[i]) b[w++] = b[i];
    b.resize(w);
    return w;
  }

 private:
  // Before resizing in place, stop sharing memory with a numpy view.
  void detach() {
    if (buf_.use_count() > 1) buf_ = std::make_shared<Buffer>(*buf_);
  }

  std::shared_ptr<Buffer> buf_;
  std::shared_ptr<Buffer> tmp_;  // scratch for begin_write(), reused every step
};

struct ParticleSet {
  Field<Vec2> x;    // position, m
  Field<Vec2> v;    // velocity, m/s
  Field<Vec2> a;    // acceleration of the last force evaluation, m/s^2
  Field<Real> rho;  // density of the last evaluation, kg/m^3
  Field<Real> p;    // pressure of the last evaluation, Pa
  Field<Id> id;     // stable identity; storage order changes every step

  Index size() const { return static_cast<Index>(x.size()); }
  std::size_t bytes() const {
    return x.bytes() + v.bytes() + a.bytes() + rho.bytes() + p.bytes() + id.bytes() +
           jumped_ids_.capacity() * sizeof(Id);
  }

  void resize(Index n) {
    jumped_ids_.reserve(static_cast<std::size_t>(n) / 64 + 1);  // apply_moves, sized here
    x.resize(n);
    v.resize(n);
    a.resize(n);
    rho.resize(n);
    p.resize(n);
    id.resize(n);
  }

  // Reorder the state (x, v, id) in one pass over the permutation; derived
  // fields are recomputed after a sort.
  void permute_state(const std::vector<Index>& order, int threads) {
    const Index n = static_cast<Index>(order.size());
    const Index* o = order.data();
    const Vec2* xi = x.data();
    const Vec2* vi = v.data();
    const Id* ii = id.data();
    Vec2* xo = x.begin_write(order.size());
    Vec2* vo = v.begin_write(order.size());
    Id* io = id.begin_write(order.size());
#pragma omp parallel for schedule(static) num_threads(threads)
    for (Index k = 0; k < n; ++k) {
      xo[k] = xi[o[k]];
      vo[k] = vi[o[k]];
      io[k] = ii[o[k]];
    }
    x.commit_write();
    v.commit_write();
    id.commit_write();
  }

  // The same by moves (CellGrid::moves and jumps), in place where no numpy
  // view shares the arrays (a step moves few particles to another cell, so
  // the moves touch a few percent of them), else through a permutation in
  // `order`. The jumping entries wait in the spare buffers of x and v (the
  // ones begin_write() fills) and in jumped_ids_ (kept at n / 64 + 1
  // entries, the most jumps a sort makes). In place, each of the moves'
  // parts (disjoint ranges) is applied by a thread of its own: the one that
  // takes that range in the loops that follow.
  void apply_moves(const std::vector<Move>& blocks, const std::vector<Move>& jumps,
                   const MoveParts& parts, std::vector<Index>& order, int threads) {
    const std::size_t n = static_cast<std::size_t>(size());
    if (!(x.exclusive() && v.exclusive() && id.exclusive()) || jumps.size() > n / 64 + 1) {
      moves_to_order(blocks, jumps, size(), order);
      permute_state(order, threads);
      return;
    }
    jumped_ids_.resize(n / 64 + 1);
    Vec2* const xs = x.data();
    Vec2* const vs = v.data();
    Id* const is = id.data();
    Vec2* const xt = x.begin_write(n);
    Vec2* const vt = v.begin_write(n);
    Id* const it = jumped_ids_.data();
    const int count = threads > 1 ? parts.count() : 1;
    if (count > 1) {
#pragma omp parallel for schedule(static) num_threads(count)
      for (int t = 0; t < count; ++t) {
        parts.apply(t, blocks, jumps, xs, xt);
        parts.apply(t, blocks, jumps, vs, vt);
        parts.apply(t, blocks, jumps, is, it);
      }
    } else {
      sphfluid::apply_moves(blocks, jumps, xs, xt);
      sphfluid::apply_moves(blocks, jumps, vs, vt);
      sphfluid::apply_moves(blocks, jumps, is, it);
    }
  }

  void compact(const std::vector<char>& keep) {
    x.compact(keep);
    v.compact(keep);
    a.compact(keep);
    rho.compact(keep);
    p.compact(keep);
    id.compact(keep);
  }

 private:
  std::vector<Id> jumped_ids_;  // apply_moves' scratch
};

}  // namespace sphfluid
