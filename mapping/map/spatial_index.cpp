#include "mapping/map/spatial_index.hpp"

#include <algorithm>
#include <cmath>

#include <boost/container/small_vector.hpp>

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

SpatialIndex::BucketRange SpatialIndex::bucket_range(const Aabb& box) const {
  BucketRange range;
  if (box.empty() || !box.min.allFinite() || !box.max.allFinite()) return range;
  // Clamped to the key range so a query box of any size stays a finite, in-range loop.
  const double limit = static_cast<double>((1 << 20) - 1);
  const Eigen::Vector3d lo = (box.min / bucket_m_).array().floor().max(-limit).min(limit);
  const Eigen::Vector3d hi = (box.max / bucket_m_).array().floor().max(-limit).min(limit);
  for (int a = 0; a < 3; ++a) {
    range.lo[a] = static_cast<std::int64_t>(lo[a]);
    range.hi[a] = static_cast<std::int64_t>(hi[a]);
  }
  range.empty = false;
  return range;
}

template <class F>
void SpatialIndex::for_each_bucket(const Aabb& box, F&& f) const {
  const BucketRange range = bucket_range(box);
  if (range.empty) return;
  for (auto x = range.lo[0]; x <= range.hi[0]; ++x)
    for (auto y = range.lo[1]; y <= range.hi[1]; ++y)
      for (auto z = range.lo[2]; z <= range.hi[2]; ++z) f(bucket_key(x, y, z));
}

void SpatialIndex::insert(std::uint32_t id, const Aabb& box) {
  if (box.empty() || !box.min.allFinite() || !box.max.allFinite()) return;
  const double limit = max_coordinate_m();
  if (box.min.minCoeff() < -limit || box.max.maxCoeff() > limit)
    throw InputError("spatial index: cell " + std::to_string(id) + " lies outside ±" +
                     std::to_string(limit) + " m, the indexable range");
  ++size_;
  // Each bucket keeps its ids sorted (new cells come with growing ids: an append), so that a
  // query merges its buckets instead of sorting their concatenation.
  for_each_bucket(box, [&](std::uint64_t key) {
    auto& ids = buckets_[key];
    if (ids.empty() || ids.back() < id)
      ids.push_back(id);
    else
      ids.insert(std::upper_bound(ids.begin(), ids.end(), id), id);
  });
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
  // The touched buckets' sorted ids, one run each (run r = out[starts[r], starts[r + 1])).
  boost::container::small_vector<std::size_t, 33> starts;
  for_each_bucket(box, [&](std::uint64_t key) {
    auto it = buckets_.find(key);
    if (it == buckets_.end()) return;
    starts.push_back(out.size());
    out.insert(out.end(), it->second.begin(), it->second.end());
  });
  const std::size_t n = out.size();
  starts.push_back(n);
  // Runs merged pairwise, back and forth between out[0, n) and out[n, 2n): ⌈log₂ runs⌉ passes of
  // n, against n log n for a sort; a cell in several buckets then sits in adjacent copies.
  if (starts.size() > 2) {
    out.resize(2 * n);
    std::uint32_t* from = out.data();
    std::uint32_t* to = out.data() + n;
    while (starts.size() > 2) {
      std::size_t kept = 0;
      for (std::size_t r = 0; r + 1 < starts.size(); r += 2, ++kept) {
        const std::size_t lo = starts[r], mid = starts[r + 1];
        const std::size_t hi = r + 2 < starts.size() ? starts[r + 2] : mid;
        std::merge(from + lo, from + mid, from + mid, from + hi, to + lo);
        starts[kept] = lo;
      }
      starts[kept] = n;
      starts.resize(kept + 1);
      std::swap(from, to);
    }
    if (from != out.data()) std::copy(from, from + n, out.data());
    out.resize(n);
  }
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
