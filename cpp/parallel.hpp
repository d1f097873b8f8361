// OpenMP helpers that also compile without OpenMP, and the chunked CSR builder:
// each thread fills a contiguous block of particles into its own buffer, then
// the blocks are concatenated, so the result does not depend on thread count.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "types.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace sphfluid {

inline int resolve_threads(int requested) {
#ifdef _OPENMP
  return requested > 0 ? requested : omp_get_max_threads();
#else
  (void)requested;
  return 1;
#endif
}

inline int thread_rank() {
#ifdef _OPENMP
  return omp_get_thread_num();
#else
  return 0;
#endif
}

inline int thread_team_size() {
#ifdef _OPENMP
  return omp_get_num_threads();
#else
  return 1;
#endif
}

using Offset = std::int64_t;

// A growable array that never zero-fills: the per-thread output of build_csr.
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
    if (size_ + k > data_.size()) data_.resize(std::max(2 * data_.size(), size_ + k + 64));
    T* out = data_.data() + size_;
    size_ += k;
    return out;
  }
  void resize(std::size_t n) { size_ = n; }  // n <= size()

 private:
  std::vector<T> data_;  // capacity; only [0, size_) holds entries
  std::size_t size_ = 0;
};

// Compressed rows: the entries of particle i are items[start[i] .. start[i+1]).
template <class T>
struct Csr {
  std::vector<Offset> start;
  std::vector<T> items;
  std::vector<Chunk<T>> per_thread;  // scratch kept between steps

  Offset begin(Index i) const { return start[i]; }
  Offset end(Index i) const { return start[i + 1]; }
};

// emit(i, out) appends particle i's entries to out (a Chunk<T>).
template <class T, class Emit>
void build_csr(Index n, int threads, Csr<T>& csr, Emit emit) {
  const int nt_max = resolve_threads(threads);
  csr.start.resize(static_cast<std::size_t>(n) + 1);
  if (static_cast<int>(csr.per_thread.size()) < nt_max) csr.per_thread.resize(nt_max);
  std::vector<Offset> base(nt_max + 1, 0);
#pragma omp parallel num_threads(nt_max)
  {
    const int t = thread_rank(), nt = thread_team_size();
    const Index lo = static_cast<Index>(std::int64_t(n) * t / nt);
    const Index hi = static_cast<Index>(std::int64_t(n) * (t + 1) / nt);
    // Work on a buffer whose header lives on this thread's stack: the headers
    // in per_thread share cache lines, and appending writes them constantly.
    Chunk<T> local = std::move(csr.per_thread[t]);
    local.clear();
    for (Index i = lo; i < hi; ++i) {
      csr.start[i] = static_cast<Offset>(local.size());
      emit(i, local);
    }
    base[t + 1] = static_cast<Offset>(local.size());
#pragma omp barrier
#pragma omp single
    {
      for (int s = 0; s < nt_max; ++s) base[s + 1] += base[s];
      csr.items.resize(base[nt_max]);
    }
    const Offset off = base[t];
    for (Index i = lo; i < hi; ++i) csr.start[i] += off;
    std::copy(local.begin(), local.end(), csr.items.begin() + off);
    csr.per_thread[t] = std::move(local);  // keep the capacity for the next step
  }
  csr.start[n] = static_cast<Offset>(csr.items.size());
}

}  // namespace sphfluid
