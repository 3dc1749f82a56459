#include "mapping/map/stored_polygon.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace planecell::map {
namespace {

/// The grid coordinate k mm of `x` when x is exactly float(k / 1000) (bit for bit, so −0 is
/// not) with |k| < 2³¹; false otherwise.
bool grid_mm(float x, std::int64_t& k) {
  if (!std::isfinite(x) || std::abs(x) >= 2.0e6f) return false;
  k = std::llround(static_cast<double>(x) * 1000.0);
  return std::bit_cast<std::uint32_t>(from_mm(k)) == std::bit_cast<std::uint32_t>(x);
}

}  // namespace

StoredPolygon::StoredPolygon(std::span<const Eigen::Vector3f> vertices) {
  if (vertices.size() > kSizeMask)
    throw std::length_error("stored polygon: more than 2^31 - 1 vertices");
  if (vertices.empty()) return;
  const std::size_t n = vertices.size();
  boost::container::small_vector<std::int64_t, 48> mm(3 * n);  // millimetres, 16 vertices on the stack
  bool compact = true;
  for (std::size_t i = 0; i < n && compact; ++i)
    for (int k = 0; k < 3 && compact; ++k) {
      compact = grid_mm(vertices[i][k], mm[3 * i + k]);
      if (compact && i > 0) {
        const std::int64_t offset = mm[3 * i + k] - mm[k];
        compact = offset >= std::numeric_limits<std::int16_t>::min() &&
                  offset <= std::numeric_limits<std::int16_t>::max();
      }
    }
  data_ = std::make_unique<std::byte[]>(heap_bytes(n, compact));
  const std::uint32_t header = static_cast<std::uint32_t>(n) | (compact ? kCompactBit : 0u);
  std::memcpy(data_.get(), &header, sizeof header);
  std::byte* out = data_.get() + sizeof header;
  if (!compact) {
    std::memcpy(out, vertices.data()->data(), 3 * n * sizeof(float));
    return;
  }
  for (int k = 0; k < 3; ++k, out += sizeof(std::int32_t)) {
    const auto anchor = static_cast<std::int32_t>(mm[k]);
    std::memcpy(out, &anchor, sizeof anchor);
  }
  for (std::size_t i = 1; i < n; ++i)
    for (int k = 0; k < 3; ++k, out += sizeof(std::int16_t)) {
      const auto offset = static_cast<std::int16_t>(mm[3 * i + k] - mm[k]);
      std::memcpy(out, &offset, sizeof offset);
    }
}

StoredPolygon::StoredPolygon(const StoredPolygon& o) {
  if (o.empty()) return;
  const std::size_t n = o.bytes();
  data_ = std::make_unique<std::byte[]>(n);
  std::memcpy(data_.get(), o.data_.get(), n);
}

StoredPolygon& StoredPolygon::operator=(const StoredPolygon& o) {
  if (this != &o) *this = StoredPolygon(o);
  return *this;
}

const Eigen::Vector3f StoredPolygon::operator[](std::size_t i) const {
  Eigen::Vector3f v;
  if (!compact()) {
    std::memcpy(v.data(), payload() + 3 * i * sizeof(float), 3 * sizeof(float));
    return v;
  }
  std::int32_t anchor[3];
  std::memcpy(anchor, payload(), sizeof anchor);
  std::int16_t d[3] = {0, 0, 0};
  if (i > 0) std::memcpy(d, payload() + sizeof anchor + 3 * (i - 1) * sizeof(std::int16_t), sizeof d);
  for (int k = 0; k < 3; ++k) v[k] = from_mm(std::int64_t{anchor[k]} + d[k]);
  return v;
}

std::vector<Eigen::Vector3f> StoredPolygon::vertices() const {
  std::vector<Eigen::Vector3f> out;
  vertices_into(out);
  return out;
}

void StoredPolygon::decode(Eigen::Vector3f* out) const {
  const std::size_t n = size();
  if (n == 0) return;
  if (!compact()) {
    std::memcpy(out->data(), payload(), 3 * n * sizeof(float));
    return;
  }
  std::int32_t anchor[3];
  std::memcpy(anchor, payload(), sizeof anchor);
  out[0] = {from_mm(anchor[0]), from_mm(anchor[1]), from_mm(anchor[2])};
  const std::byte* offsets = payload() + sizeof anchor;
  for (std::size_t i = 1; i < n; ++i, offsets += 3 * sizeof(std::int16_t)) {
    std::int16_t d[3];
    std::memcpy(d, offsets, sizeof d);
    out[i] = {from_mm(std::int64_t{anchor[0]} + d[0]), from_mm(std::int64_t{anchor[1]} + d[1]),
              from_mm(std::int64_t{anchor[2]} + d[2])};
  }
}

Aabb StoredPolygon::bounds() const {
  Aabb box;
  const std::size_t n = size();
  if (n == 0) return box;
  if (!compact()) {
    for (std::size_t i = 0; i < n; ++i) box.extend((*this)[i].cast<double>().eval());
    return box;
  }
  // from_mm is monotonic in k, so the box of the decoded vertices is the decoded box of the
  // millimetres: six conversions instead of three per vertex.
  std::int32_t anchor[3];
  std::memcpy(anchor, payload(), sizeof anchor);
  std::int32_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  const std::byte* offsets = payload() + sizeof anchor;
  for (std::size_t i = 1; i < n; ++i, offsets += 3 * sizeof(std::int16_t)) {
    std::int16_t d[3];
    std::memcpy(d, offsets, sizeof d);
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min<std::int32_t>(lo[k], d[k]);
      hi[k] = std::max<std::int32_t>(hi[k], d[k]);
    }
  }
  for (int k = 0; k < 3; ++k) {
    box.min[k] = from_mm(std::int64_t{anchor[k]} + lo[k]);
    box.max[k] = from_mm(std::int64_t{anchor[k]} + hi[k]);
  }
  return box;
}

bool StoredPolygon::operator==(const StoredPolygon& o) const {
  const std::size_t n = bytes();
  return n == o.bytes() && (n == 0 || std::memcmp(data_.get(), o.data_.get(), n) == 0);
}

}  // namespace planecell::map
