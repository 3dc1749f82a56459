#pragma once
/// An optional value kept on the heap: one pointer in its owner, deep-copied with it. For records
/// that are many and whose large part most of them drop (a dormant surface's detail):
/// std::optional<T> keeps sizeof(T) in every record, std::unique_ptr<T> does not copy.
#include <memory>
#include <utility>

namespace planecell::map {

template <class T>
class HeapOptional {
 public:
  HeapOptional() = default;
  HeapOptional(const HeapOptional& o) : value_(o.value_ ? std::make_unique<T>(*o.value_) : nullptr) {}
  HeapOptional(HeapOptional&&) noexcept = default;
  HeapOptional& operator=(const HeapOptional& o) {
    if (this != &o) value_ = o.value_ ? std::make_unique<T>(*o.value_) : nullptr;
    return *this;
  }
  HeapOptional& operator=(HeapOptional&&) noexcept = default;
  ~HeapOptional() = default;

  /// Holds `value` from now on (replacing what it held).
  T& emplace(T value) {
    value_ = std::make_unique<T>(std::move(value));
    return *value_;
  }
  void reset() { value_.reset(); }
  bool has_value() const { return value_ != nullptr; }
  explicit operator bool() const { return has_value(); }
  T& operator*() { return *value_; }
  const T& operator*() const { return *value_; }
  T* operator->() { return value_.get(); }
  const T* operator->() const { return value_.get(); }

  /// Equal when both are empty or both hold equal values.
  bool operator==(const HeapOptional& o) const {
    return value_ ? (o.value_ && *value_ == *o.value_) : !o.value_;
  }

 private:
  std::unique_ptr<T> value_;
};

}  // namespace planecell::map
