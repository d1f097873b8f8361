// ParticleSet: one contiguous array per particle field (structure of arrays),
// re-ordered together by one permutation. Buffers are shared with the numpy
// views handed to Python, and are copied before any write that would move or
// resize memory a view still points at (copy-on-write), so a view never dangles.
#pragma once

#include <algorithm>
#include <cstring>
#include <memory>
#include <utility>
#include <vector>

#include "moves.hpp"
#include "parallel.hpp"
#include "types.hpp"

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
           moved_at_.capacity() * sizeof(Index);
  }

  void resize(Index n) {
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

  // The same by block moves (CellGrid::moves), in place where no numpy view
  // shares the arrays (a step moves few particles to another cell, so the
  // blocks hold a few percent of them), else through a permutation in
  // `order`. The entries moved pass through each field's spare buffer (the
  // one begin_write() fills). On several threads each takes a share of the
  // moves, in order of their destinations (the blocks mostly shift by a
  // place or two, so each thread moves what it holds and reads next); all
  // read their sources before any writes.
  void apply_moves(const std::vector<Move>& moves, std::vector<Index>& order, int threads) {
    if (!(x.exclusive() && v.exclusive() && id.exclusive())) {
      moves_to_order(moves, size(), order);
      permute_state(order, threads);
      return;
    }
    const std::size_t count = moves.size(), n = static_cast<std::size_t>(size());
    if (moved_at_.capacity() < moves.capacity() + 1) moved_at_.reserve(moves.capacity() + 1);
    moved_at_.resize(count + 1);
    moved_at_[0] = 0;
    for (std::size_t k = 0; k < count; ++k) moved_at_[k + 1] = moved_at_[k] + moves[k].len;
    const std::size_t total = static_cast<std::size_t>(moved_at_[count]);
    if (2 * total > n) {  // more than the spare buffers hold (CellGrid::resort moves fewer)
      moves_to_order(moves, size(), order);
      permute_state(order, threads);
      return;
    }
    Vec2* const xs = x.data();
    Vec2* const vs = v.data();
    Id* const is = id.data();
    // The spare buffers of x and v: x's holds the moved positions, then the
    // moved ids (as bytes: 24 of its 16 n bytes per entry moved, at most n / 2).
    Vec2* const tx = x.begin_write(n);
    Vec2* const tv = v.begin_write(n);
    unsigned char* const ti = reinterpret_cast<unsigned char*>(tx + total);
    auto gather = [&](std::size_t k0, std::size_t k1) {
      for (std::size_t k = k0; k < k1; ++k) {
        const Move& m = moves[k];
        const std::size_t t = static_cast<std::size_t>(moved_at_[k]);
        std::copy(xs + m.src, xs + m.src + m.len, tx + t);
        std::copy(vs + m.src, vs + m.src + m.len, tv + t);
        std::memcpy(ti + t * sizeof(Id), is + m.src, m.len * sizeof(Id));
      }
    };
    auto place = [&](std::size_t k0, std::size_t k1) {
      for (std::size_t k = k0; k < k1; ++k) {
        const Move& m = moves[k];
        const std::size_t t = static_cast<std::size_t>(moved_at_[k]);
        std::copy(tx + t, tx + t + m.len, xs + m.dst);
        std::copy(tv + t, tv + t + m.len, vs + m.dst);
        std::memcpy(is + m.dst, ti + t * sizeof(Id), m.len * sizeof(Id));
      }
    };
    if (threads > 1 && total >= kParallelMoves) {
#pragma omp parallel num_threads(threads)
      {
        // Thread t's moves: those whose entries start in its share of them.
        const int t = thread_rank(), nt = thread_team_size();
        auto first = [&](int u) {
          const Index goal = static_cast<Index>(std::int64_t(total) * u / nt);
          return static_cast<std::size_t>(
              std::lower_bound(moved_at_.begin(), moved_at_.end() - 1, goal) -
              moved_at_.begin());
        };
        const std::size_t k0 = first(t), k1 = t + 1 == nt ? count : first(t + 1);
        gather(k0, k1);
#pragma omp barrier
        place(k0, k1);
      }
    } else {
      gather(0, count);
      place(0, count);
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
  // apply_moves: from this many entries moved on the threads; where each
  // move's entries start in the scratch
  static constexpr Index kParallelMoves = 4096;
  std::vector<Index> moved_at_;
};

}  // namespace sphfluid
