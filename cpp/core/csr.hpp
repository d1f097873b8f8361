// The chunked CSR (compressed rows) that holds per-particle lists (neighbours,
// wall ghosts): each thread fills a contiguous block of rows into its own
// buffer, so the rows do not depend on the thread count.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "core/parallel.hpp"
#include "core/types.hpp"
#include "simd/ints.hpp"

namespace sphfluid {

// A growable array that never zero-fills: the per-thread output of Csr::build.
template <class T>
class Chunk {
 public:
  std::size_t size() const { return size_; }
  const T* begin() const { return data_.data(); }
  const T* end() const { return data_.data() + size_; }
  void clear() { size_ = 0; }
  void push_back(const T& v) { *extend(1) = v; }
  // k writable slots at the end; keep only what is then committed with resize().
  T* extend(std::size_t k) {
    // Grows by an eighth: the chunks are the largest arrays, and a step's size
    // is close to the last one's, so doubling would mostly hold empty slots.
    if (size_ + k > data_.size()) {
      const std::size_t grown = std::max(data_.size() + data_.size() / 8, size_ + k + 64);
      data_.reserve(grown);  // exactly: resize() alone would double the capacity
      data_.resize(grown);
    }
    T* out = data_.data() + size_;
    size_ += k;
    return out;
  }
  void resize(std::size_t n) { size_ = n; }  // n <= size()
  std::size_t bytes() const { return data_.capacity() * sizeof(T); }

 private:
  std::vector<T> data_;  // capacity; only [0, size_) holds entries
  std::size_t size_ = 0;
};

// The entries of one row of a Csr.
template <class T>
struct Row {
  const T* first;
  const T* last;
  const T* begin() const { return first; }
  const T* end() const { return last; }
};

// Compressed rows, built in blocks: thread t fills the rows of particles
// [lo[t], lo[t + 1]) into its own chunk, and the chunks are kept as they are
// (no concatenated copy: that would double the memory of the largest array).
template <class T>
class Csr {
 public:
  Row<T> row(Index i) const {
    int t = 0;
    while (i >= lo_[t + 1]) ++t;  // a handful of blocks: one per thread
    const T* base = chunks_[t].begin();
    const Index last = i + 1 == lo_[t + 1] ? static_cast<Index>(chunks_[t].size()) : start_[i + 1];
    return {base + start_[i], base + last};
  }
  // f(i, row(i)) for each row that holds entries, each block of rows on one
  // thread (the blocks of the last build).
  template <class F>
  void for_each_nonempty_row(int threads, F f) const {
    const int blocks = static_cast<int>(lo_.size()) - 1;
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int t = 0; t < blocks; ++t) for_each_nonempty_row_in(lo_[t], lo_[t + 1], f);
  }
  // The same for the rows [i0, i1) of the last build, on the calling thread.
  // Where AVX-512 runs, sixteen rows' offsets are compared at a time (most
  // rows are empty: the wall ghosts of particles away from the walls).
  template <class F>
  void for_each_nonempty_row_in(Index i0, Index i1, F f) const {
    for (std::size_t t = 0; t + 1 < lo_.size(); ++t) {
      const Index lo = std::max(i0, lo_[t]), hi = std::min(i1, lo_[t + 1]);
      const T* base = chunks_[t].begin();
      Index i = lo;
#if SPHFLUID_AVX512
      if constexpr (sizeof(Index) == 4) {
        // Rows i .. i + 15 end at start_[i + 1 ..] while none is the block's last.
        for (; i + 16 < lo_[t + 1] && i + 16 <= hi; i += 16) {
          for (unsigned m = simd::differ16(start_.data() + i, start_.data() + i + 1); m != 0;
               m &= m - 1) {
            const Index r = i + static_cast<Index>(__builtin_ctz(m));
            f(r, Row<T>{base + start_[r], base + start_[r + 1]});
          }
        }
      }
#endif
      for (; i < hi; ++i) {
        const Index b = start_[i];
        const Index e = i + 1 == lo_[t + 1] ? static_cast<Index>(chunks_[t].size()) : start_[i + 1];
        if (b != e) f(i, Row<T>{base + b, base + e});
      }
    }
  }
  // Heap bytes held, capacity included.
  std::size_t bytes() const {
    std::size_t sum = (start_.capacity() + lo_.capacity()) * sizeof(Index);
    for (const Chunk<T>& c : chunks_) sum += c.bytes();
    return sum;
  }
  // Rows of the last build.
  Index rows() const { return start_.empty() ? 0 : static_cast<Index>(start_.size() - 1); }
  // Entries in all rows.
  std::int64_t total() const {
    std::int64_t sum = 0;
    for (const Chunk<T>& c : chunks_) sum += static_cast<std::int64_t>(c.size());
    return sum;
  }

  // emit(i, out) appends particle i's entries to out (a Chunk<T>).
  template <class Emit>
  void build(Index n, int threads, Emit emit) {
    build_rows(n, threads, 1, [&](Index lo, Index hi, Chunk<T>& local) {
      for (Index i = lo; i < hi; ++i) {
        start_[i] = static_cast<Index>(local.size());
        emit(i, local);
      }
    });
  }

  // The same where fill(lo, hi, start, out) fills the rows [lo, hi) of one
  // thread itself: start[i] = out.size() before row i's entries are appended.
  template <class Fill>
  void build_ranges(Index n, int threads, Fill fill) {
    build_rows(n, threads, 1,
               [&](Index lo, Index hi, Chunk<T>& local) { fill(lo, hi, start_.data(), local); });
  }
  // The same with the threads' rows cut by `balance` (begun for n rows and
  // this many threads), each thread's time recorded in it.
  template <class Fill>
  void build_ranges(Index n, int threads, Balance& balance, Fill fill) {
    build_rows(n, threads, 1,
               [&](Index lo, Index hi, Chunk<T>& local) { fill(lo, hi, start_.data(), local); },
               &balance);
  }

  // The same over blocks of `block` rows, each built whole by one thread, in
  // order: emit(i, out, lo, hi) with [lo, hi) the block of row i.
  template <class Emit>
  void build_blocks(Index n, int threads, Index block, Emit emit) {
    build_rows(n, threads, block, [&](Index lo, Index hi, Chunk<T>& local) {
      for (Index b0 = lo; b0 < hi; b0 += block) {
        const Index b1 = std::min(hi, b0 + block);
        for (Index i = b0; i < b1; ++i) {
          start_[i] = static_cast<Index>(local.size());
          emit(i, local, b0, b1);
        }
      }
    });
  }

 private:
  // rows(lo, hi, out) fills the rows [lo, hi) of one thread, whose first row is
  // a multiple of align.
  template <class Rows>
  void build_rows(Index n, int threads, Index align, Rows rows, Balance* balance = nullptr) {
    const int nt_max = resolve_threads(threads);
    start_.resize(static_cast<std::size_t>(n) + 1);
    if (static_cast<int>(chunks_.size()) < nt_max) chunks_.resize(nt_max);
    lo_.assign(nt_max + 1, n);
    lo_[0] = 0;
    bool overflow = false;
#pragma omp parallel num_threads(nt_max) reduction(|| : overflow)
    {
      const int t = thread_rank(), nt = thread_team_size();
      const std::int64_t blocks = (std::int64_t(n) + align - 1) / align;
      Index lo = static_cast<Index>(std::min<std::int64_t>(n, blocks * t / nt * align));
      Index hi = static_cast<Index>(std::min<std::int64_t>(n, blocks * (t + 1) / nt * align));
      if (balance && nt == nt_max) {
        lo = balance->cut(t);
        hi = balance->cut(t + 1);
      }
      lo_[t] = lo;
      // Work on a buffer whose header lives on this thread's stack: the headers
      // in chunks_ share cache lines, and appending writes them constantly.
      Chunk<T> local = std::move(chunks_[t]);
      local.clear();
      const auto began = std::chrono::steady_clock::now();
      rows(lo, hi, local);
      if (balance && nt == nt_max)
        balance->record(t, std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                                         began).count());
      overflow = local.size() > static_cast<std::size_t>(INT32_MAX);
      chunks_[t] = std::move(local);  // keeps its capacity for the next build
    }
    // A smaller team than asked for leaves blocks that hold no rows.
    for (int t = 0; t < nt_max; ++t)
      if (lo_[t] == lo_[t + 1]) chunks_[t].clear();
    if (overflow) throw std::length_error("over 2^31 neighbour entries in one thread's block");
  }

  std::vector<Index> start_;  // offset of row i in its block's chunk
  std::vector<Index> lo_;     // first row of each block, and n
  std::vector<Chunk<T>> chunks_;
};

}  // namespace sphfluid
