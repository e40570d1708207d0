// RecordArray<T>: a keyframe's array of fixed-size records (keypoints,
// descriptors, map point ids) that either owns its elements (a std::vector)
// or views them where they already lie: the mapped bytes of the map file they
// were read from, kept alive by a shared handle.
//
// Reading a map file is then one pass over its bytes (the checksum) and no
// copy of its three largest sections (about 70% of a file: docs/mapstore.md),
// which on a virtual machine, where each fresh page costs a host fault, is
// most of a big map's load. Reading an array is the same either way; the
// first change to a view copies it into owned memory (copy on write), so code
// that edits records (map_join, map_compose, tests) needs no care. A view's
// elements are never written: they are in a read-only mapping.
//
// Copies of a view share the mapping (they are views too); the mapping goes
// when the last array viewing it goes.
#pragma once

#include <algorithm>
#include <cstddef>
#include <initializer_list>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

namespace rrslam {

template <typename T>
class RecordArray {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  using value_type = T;
  using size_type = size_t;
  using iterator = T*;
  using const_iterator = const T*;

  RecordArray() = default;
  RecordArray(std::vector<T> elements) : owned_(std::move(elements)) {}  // NOLINT: implicit.
  RecordArray(std::initializer_list<T> elements) : owned_(elements) {}

  // A view of `count` elements at `data`, which stay valid and unchanged while
  // `keep_alive` (the mapping holding them) lives. `data` is aligned for T.
  // Without a `keep_alive` the elements are copied.
  static RecordArray View(const T* data, size_t count, std::shared_ptr<const void> keep_alive) {
    RecordArray a;
    if (keep_alive == nullptr) {
      a.owned_.assign(data, data + count);
      return a;
    }
    a.view_ = data;
    a.view_size_ = count;
    a.keep_alive_ = std::move(keep_alive);
    return a;
  }

  bool is_view() const { return keep_alive_ != nullptr; }
  size_t size() const { return is_view() ? view_size_ : owned_.size(); }
  bool empty() const { return size() == 0; }

  // Reading: no copy.
  const T* data() const { return is_view() ? view_ : owned_.data(); }
  const T* begin() const { return data(); }
  const T* end() const { return data() + size(); }
  const T& operator[](size_t i) const { return data()[i]; }
  const T& back() const { return data()[size() - 1]; }

  // Writing: a view becomes owned first.
  T* data() { return Own().data(); }
  T* begin() { return data(); }
  T* end() { return data() + size(); }
  T& operator[](size_t i) { return Own()[i]; }
  T& back() { return Own().back(); }
  void resize(size_t n) { Own().resize(n); }
  void resize(size_t n, const T& value) { Own().resize(n, value); }
  void assign(size_t n, const T& value) { Own().assign(n, value); }
  void reserve(size_t n) { Own().reserve(n); }
  void clear() { *this = RecordArray(); }
  void push_back(const T& value) { Own().push_back(value); }
  void pop_back() { Own().pop_back(); }
  template <typename... Args>
  T& emplace_back(Args&&... args) {
    return Own().emplace_back(std::forward<Args>(args)...);
  }

  // The elements as a std::vector: moved out when owned, copied from a view.
  std::vector<T> TakeVector() && {
    if (!is_view()) return std::move(owned_);
    return std::vector<T>(begin(), end());
  }

  friend bool operator==(const RecordArray& a, const RecordArray& b) {
    return std::equal(a.begin(), a.end(), b.begin(), b.end());
  }

 private:
  std::vector<T>& Own() {
    if (is_view()) {
      owned_.assign(view_, view_ + view_size_);
      view_ = nullptr;
      view_size_ = 0;
      keep_alive_.reset();
    }
    return owned_;
  }

  std::vector<T> owned_;
  const T* view_ = nullptr;
  size_t view_size_ = 0;
  std::shared_ptr<const void> keep_alive_;  // Non-null exactly for a view.
};

}  // namespace rrslam
