#include "mapping/map/spatial_index.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "mapping/map/container_bytes.hpp"

namespace planecell::map {
namespace {

/// Packs three signed 21-bit bucket coordinates into one key.
std::uint64_t bucket_key(std::int64_t x, std::int64_t y, std::int64_t z) {
  constexpr std::int64_t kBias = 1 << 20;
  constexpr std::uint64_t kMask = (1u << 21) - 1;
  return (static_cast<std::uint64_t>(x + kBias) & kMask) |
         ((static_cast<std::uint64_t>(y + kBias) & kMask) << 21) |
         ((static_cast<std::uint64_t>(z + kBias) & kMask) << 42);
}

}  // namespace

SpatialIndex::SpatialIndex(double bucket_m) : bucket_m_(bucket_m) {
  if (!(bucket_m > 0.0) || !std::isfinite(bucket_m))
    throw ConfigError("map.index_cell_m: must be a positive finite length, got " +
                      std::to_string(bucket_m));
}

template <class F>
void SpatialIndex::for_each_bucket(const Aabb& box, F&& f) const {
  if (box.empty() || !box.min.allFinite() || !box.max.allFinite()) return;
  // Clamped to the key range so a query box of any size stays a finite, in-range loop.
  const double limit = static_cast<double>((1 << 20) - 1);
  const Eigen::Vector3d lo = (box.min / bucket_m_).array().floor().max(-limit).min(limit);
  const Eigen::Vector3d hi = (box.max / bucket_m_).array().floor().max(-limit).min(limit);
  for (auto x = static_cast<std::int64_t>(lo.x()); x <= static_cast<std::int64_t>(hi.x()); ++x)
    for (auto y = static_cast<std::int64_t>(lo.y()); y <= static_cast<std::int64_t>(hi.y()); ++y)
      for (auto z = static_cast<std::int64_t>(lo.z()); z <= static_cast<std::int64_t>(hi.z()); ++z)
        f(bucket_key(x, y, z));
}

void SpatialIndex::insert(std::uint32_t id, const Aabb& box) {
  if (box.empty() || !box.min.allFinite() || !box.max.allFinite()) return;
  const double limit = max_coordinate_m();
  if (box.min.minCoeff() < -limit || box.max.maxCoeff() > limit)
    throw InputError("spatial index: cell " + std::to_string(id) + " lies outside ±" +
                     std::to_string(limit) + " m, the indexable range");
  ++size_;
  for_each_bucket(box, [&](std::uint64_t key) { buckets_[key].push_back(id); });
}

void SpatialIndex::remove(std::uint32_t id, const Aabb& box) {
  bool found = false;
  for_each_bucket(box, [&](std::uint64_t key) {
    auto it = buckets_.find(key);
    if (it == buckets_.end()) return;
    found = std::erase(it->second, id) > 0 || found;
    if (it->second.empty())
      buckets_.erase(it);
    else
      shrink_if_sparse_vector(it->second);
  });
  if (found) --size_;
  shrink_if_sparse(buckets_);
}

std::vector<std::uint32_t> SpatialIndex::candidates(const Aabb& box) const {
  std::vector<std::uint32_t> out;
  candidates(box, out);
  return out;
}

void SpatialIndex::candidates(const Aabb& box, std::vector<std::uint32_t>& out) const {
  out.clear();
  for_each_bucket(box, [&](std::uint64_t key) {
    auto it = buckets_.find(key);
    if (it == buckets_.end()) return;
    out.insert(out.end(), it->second.begin(), it->second.end());
  });
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

void SpatialIndex::clear() {
  buckets_.clear();
  size_ = 0;
}

std::size_t SpatialIndex::bytes() const {
  std::size_t total = hash_map_bytes(buckets_);
  for (const auto& [key, ids] : buckets_) total += ids.capacity() * sizeof(std::uint32_t);
  return total;
}

}  // namespace planecell::map
