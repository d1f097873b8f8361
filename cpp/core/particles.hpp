// ParticleSet: one contiguous array per particle field (structure of arrays),
// each listed once in a field registry that resizing, reordering (by a
// permutation or by moves), compaction and memory accounting iterate over. A
// field of a method's own (a warm start, a rate) registers itself the same
// way, in one line. Buffers are shared with the numpy views handed to Python,
// and are copied before any write that would move or resize memory a view
// still points at (copy-on-write), so a view never dangles.
#pragma once

#include <cstring>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "core/parallel.hpp"
#include "core/types.hpp"
#include "core/moves.hpp"

namespace sphfluid {

class ParticleSet;

// What a reordering does to a field: a state field moves with its particle
// (positions, velocities, ids; a method's warm start); a derived one is
// recomputed after every sort (density, pressure, acceleration; a method's
// scratch), so a sort leaves it as it is and only resizing and compaction
// keep it in step.
enum class FieldKind { kState, kDerived };

// A field as the registry sees it.
class FieldBase {
 public:
  FieldBase(ParticleSet& set, const char* name, FieldKind kind);
  virtual ~FieldBase();
  FieldBase(const FieldBase&) = delete;
  FieldBase& operator=(const FieldBase&) = delete;

  const char* name() const { return name_; }
  FieldKind kind() const { return kind_; }
  // A method whose step carries this field from one step to the next (wcsph's
  // continuity density) makes it state.
  void set_kind(FieldKind kind) { kind_ = kind; }
  virtual std::size_t size() const = 0;
  virtual void resize(std::size_t n) = 0;
  // The values as numbers, for a checkpoint: each value is components()
  // numbers of scalar_bytes() bytes, integers or floating point; raw() the
  // first, assign() replaces all with n values from src.
  virtual int components() const = 0;
  virtual std::size_t scalar_bytes() const = 0;
  virtual bool integral() const = 0;
  virtual const void* raw() const = 0;
  virtual void assign(const void* src, std::size_t n) = 0;
  virtual void compact(const std::vector<char>& keep) = 0;
  virtual std::size_t bytes() const = 0;
  virtual bool exclusive() const = 0;
  virtual void own() = 0;
  // out[k] = in[order[k]], into a fresh buffer that then becomes current.
  virtual void permute(const std::vector<Index>& order, int threads) = 0;
  // The moves in place (exclusive() only); the jumps' entries wait in the
  // spare buffer (begin_write's). prepare_moves before any part is applied.
  virtual void prepare_moves(std::size_t n) = 0;
  virtual void apply_moves(const std::vector<Move>& blocks, const std::vector<Move>& jumps) = 0;
  virtual void apply_part(const MoveParts& parts, int t, const std::vector<Move>& blocks,
                          const std::vector<Move>& jumps) = 0;

 protected:
  // The set's particles when this field registered (its first field's size).
  std::size_t initial_size() const { return initial_size_; }

 private:
  std::size_t initial_size_ = 0;
  ParticleSet* set_;
  const char* name_;
  FieldKind kind_;
};

// A value's numbers: a scalar, or an Eigen vector's.
template <class T, class = void>
struct ValueLayout {
  using Scalar = T;
  static constexpr int kComponents = 1;
};
template <class T>
struct ValueLayout<T, std::void_t<typename T::Scalar>> {
  using Scalar = typename T::Scalar;
  static constexpr int kComponents = static_cast<int>(sizeof(T) / sizeof(Scalar));
};

template <class T>
class Field final : public FieldBase {
 public:
  using Buffer = std::vector<T>;
  using Layout = ValueLayout<T>;

  // Sized to the set's particles (a field registered after they exist).
  Field(ParticleSet& set, const char* name, FieldKind kind);

  T* data() { return buf_->data(); }
  const T* data() const { return buf_->data(); }
  T& operator[](std::size_t i) { return (*buf_)[i]; }
  const T& operator[](std::size_t i) const { return (*buf_)[i]; }
  std::size_t size() const override { return buf_->size(); }
  // Heap bytes held by this field (its buffer and its scratch), capacity included.
  std::size_t bytes() const override {
    return (buf_->capacity() + (tmp_ ? tmp_->capacity() : 0)) * sizeof(T);
  }

  // The buffer as Python sees it: a view holds this pointer, keeping it alive.
  std::shared_ptr<Buffer> share() const { return buf_; }

  void resize(std::size_t n) override {
    detach();
    buf_->resize(n);
  }

  int components() const override { return Layout::kComponents; }
  std::size_t scalar_bytes() const override { return sizeof(typename Layout::Scalar); }
  bool integral() const override { return std::is_integral_v<typename Layout::Scalar>; }
  const void* raw() const override { return data(); }
  void assign(const void* src, std::size_t n) override {
    resize(n);
    if (n > 0) std::memcpy(static_cast<void*>(data()), src, n * sizeof(T));
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
  bool exclusive() const override { return buf_.use_count() == 1; }
  // Before writing in place: a buffer a numpy view shares is left to the view
  // (it keeps the values it showed) and the field goes on in a copy.
  void own() override { detach(); }

  // Keep the entries whose keep[i] is true, in order.
  void compact(const std::vector<char>& keep) override {
    detach();
    Buffer& b = *buf_;
    std::size_t w = 0;
    for (std::size_t i = 0; i < b.size(); ++i)
      if (keep[i]) b[w++] = b[i];
    b.resize(w);
  }

  void permute(const std::vector<Index>& order, int threads) override {
    const Index n = static_cast<Index>(order.size());
    const Index* o = order.data();
    const T* in = data();
    T* out = begin_write(order.size());
#pragma omp parallel for schedule(static) num_threads(threads)
    for (Index k = 0; k < n; ++k) out[k] = in[o[k]];
    commit_write();
  }
  void prepare_moves(std::size_t n) override { spare_ = begin_write(n); }
  void apply_moves(const std::vector<Move>& blocks, const std::vector<Move>& jumps) override {
    sphfluid::apply_moves(blocks, jumps, data(), spare_);
  }
  void apply_part(const MoveParts& parts, int t, const std::vector<Move>& blocks,
                  const std::vector<Move>& jumps) override {
    parts.apply(t, blocks, jumps, data(), spare_);
  }

 private:
  // Before resizing in place, stop sharing memory with a numpy view.
  void detach() {
    if (buf_.use_count() > 1) buf_ = std::make_shared<Buffer>(*buf_);
  }

  std::shared_ptr<Buffer> buf_;
  std::shared_ptr<Buffer> tmp_;  // scratch for begin_write(), reused every step
  T* spare_ = nullptr;           // the moves' jumps wait here (prepare_moves)
};

class ParticleSet {
  friend class FieldBase;
  // Every field, in the order of registration (declared first: the fields
  // below register themselves as they are built).
  std::vector<FieldBase*> fields_;

 public:
  ParticleSet() = default;
  ParticleSet(const ParticleSet&) = delete;
  ParticleSet& operator=(const ParticleSet&) = delete;

  // The fields every method has; a method registers its own beside them.
  Field<Vec2> x{*this, "position", FieldKind::kState};      // m
  Field<Vec2> v{*this, "velocity", FieldKind::kState};      // m/s
  Field<Id> id{*this, "id", FieldKind::kState};             // stable identity
  Field<Vec2> a{*this, "acceleration", FieldKind::kDerived};  // of the last evaluation, m/s^2
  Field<Real> rho{*this, "density", FieldKind::kDerived};   // of the last evaluation, kg/m^3
  Field<Real> p{*this, "pressure", FieldKind::kDerived};    // of the last evaluation, Pa

  Index size() const { return static_cast<Index>(x.size()); }
  const std::vector<FieldBase*>& fields() const { return fields_; }
  std::size_t bytes() const {
    std::size_t sum = 0;
    for (const FieldBase* f : fields_) sum += f->bytes();
    return sum;
  }
  void resize(Index n) {
    for (FieldBase* f : fields_) f->resize(static_cast<std::size_t>(n));
  }
  void compact(const std::vector<char>& keep) {
    for (FieldBase* f : fields_) f->compact(keep);
  }

  // Before a step or an evaluation writes fields in place (the derived ones,
  // and a method's state such as the continuity density): none of them
  // shares its buffer with a numpy view any more (Field::own). Costs a copy
  // only of a field a view holds.
  void own_fields() {
    for (FieldBase* f : fields_) f->own();
  }

  // Reorder the state fields by the permutation (order[k] = the particle
  // that goes to k); derived fields are recomputed after a sort.
  void permute_state(const std::vector<Index>& order, int threads) {
    for (FieldBase* f : fields_)
      if (f->kind() == FieldKind::kState) f->permute(order, threads);
  }

  // The same by moves (CellGrid::moves and jumps), in place where no numpy
  // view shares a state field (a step moves few particles to another cell,
  // so the moves touch a few percent of them), else through a permutation in
  // `order`. The jumping entries wait in each field's spare buffer. In place,
  // each of the moves' parts (disjoint ranges) is applied by a thread of its
  // own: the one that takes that range in the loops that follow.
  void apply_moves(const std::vector<Move>& blocks, const std::vector<Move>& jumps,
                   const MoveParts& parts, std::vector<Index>& order, int threads) {
    const std::size_t n = static_cast<std::size_t>(size());
    bool exclusive = jumps.size() <= n / 64 + 1;
    for (const FieldBase* f : fields_)
      exclusive = exclusive && (f->kind() != FieldKind::kState || f->exclusive());
    if (!exclusive) {
      moves_to_order(blocks, jumps, size(), order);
      permute_state(order, threads);
      return;
    }
    for (FieldBase* f : fields_)
      if (f->kind() == FieldKind::kState) f->prepare_moves(n);
    const int count = threads > 1 ? parts.count() : 1;
    if (count > 1) {
#pragma omp parallel for schedule(static) num_threads(count)
      for (int t = 0; t < count; ++t)
        for (FieldBase* f : fields_)
          if (f->kind() == FieldKind::kState) f->apply_part(parts, t, blocks, jumps);
    } else {
      for (FieldBase* f : fields_)
        if (f->kind() == FieldKind::kState) f->apply_moves(blocks, jumps);
    }
  }
};

template <class T>
Field<T>::Field(ParticleSet& set, const char* name, FieldKind kind)
    : FieldBase(set, name, kind),
      buf_(std::make_shared<Buffer>(initial_size())) {}

inline FieldBase::FieldBase(ParticleSet& set, const char* name, FieldKind kind)
    : set_(&set), name_(name), kind_(kind) {
  if (!set.fields_.empty()) initial_size_ = set.fields_.front()->size();
  set.fields_.push_back(this);
}
inline FieldBase::~FieldBase() {
  auto& f = set_->fields_;
  for (std::size_t k = 0; k < f.size(); ++k)
    if (f[k] == this) {
      f.erase(f.begin() + static_cast<std::ptrdiff_t>(k));
      break;
    }
}

}  // namespace sphfluid
