#pragma once
/// Raw little-endian byte writing and bounds-checked reading for the map store's blobs
/// (x86-64 / AArch64 hosts). Internal to io/.
#include <Eigen/Core>
#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/error.hpp"

namespace planecell::io::blob {

/// Appends trivially copyable values as raw little-endian bytes (x86-64 / AArch64 hosts).
class Writer {
 public:
  template <class T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
    bytes.insert(bytes.end(), p, p + sizeof(T));
  }
  template <class Derived>
  void put_matrix(const Eigen::MatrixBase<Derived>& m) {
    for (Eigen::Index i = 0; i < m.size(); ++i) put(m(i));
  }
  /// Unsigned LEB128: 7 bits per byte, low groups first, high bit set on all but the last.
  void put_varint(std::uint64_t v) {
    for (; v >= 0x80; v >>= 7) bytes.push_back(static_cast<std::uint8_t>(v | 0x80));
    bytes.push_back(static_cast<std::uint8_t>(v));
  }
  std::vector<std::uint8_t> bytes;
};

/// Reads what Writer wrote; throws StorageError on a short blob.
class Reader {
 public:
  Reader(const void* data, std::size_t size, std::string what)
      : data_(static_cast<const std::uint8_t*>(data)), size_(size), what_(std::move(what)) {}
  template <class T>
  T get() {
    if (pos_ + sizeof(T) > size_)
      throw StorageError(what_ + ": blob truncated at byte " + std::to_string(pos_));
    T v;
    std::memcpy(&v, data_ + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  template <class Derived>
  void get_matrix(Eigen::MatrixBase<Derived>& m) {
    for (Eigen::Index i = 0; i < m.size(); ++i) m(i) = get<typename Derived::Scalar>();
  }
  std::uint32_t count(std::size_t element_bytes) {
    const auto n = get<std::uint32_t>();
    if (static_cast<std::size_t>(n) * element_bytes > size_ - pos_)
      throw StorageError(what_ + ": count " + std::to_string(n) + " exceeds the blob");
    return n;
  }
  std::uint64_t get_varint() {
    std::uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      const auto b = get<std::uint8_t>();
      v |= static_cast<std::uint64_t>(b & 0x7f) << shift;
      if (!(b & 0x80)) return v;
    }
    throw StorageError(what_ + ": varint longer than 10 bytes before byte " + std::to_string(pos_));
  }
  bool at_end() const { return pos_ == size_; }
  const std::string& what() const { return what_; }
  void expect_end() const {
    if (pos_ != size_)
      throw StorageError(what_ + ": " + std::to_string(size_ - pos_) + " trailing bytes");
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  std::string what_;
};

}  // namespace planecell::io::blob
