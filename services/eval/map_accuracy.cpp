#include "services/eval/map_accuracy.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <unordered_map>
#include <unordered_set>

#include "core/error.hpp"
#include "mapping/map/coverage.hpp"
#include "mapping/map/geometry.hpp"

namespace planecell::services::eval {

std::vector<GtPolygon> gt_polygons(std::span<const io::SyntheticSurface> surfaces) {
  std::vector<GtPolygon> out;
  out.reserve(surfaces.size());
  for (const auto& s : surfaces) {
    if (s.polygon.size() < 3) continue;
    GtPolygon g{s.plane, s.origin, s.u_axis, s.v_axis, s.polygon, {}, {}};
    g.box_min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    g.box_max = -g.box_min;
    for (const Eigen::Vector3d& c : s.corners_world()) {
      g.box_min = g.box_min.cwiseMin(c);
      g.box_max = g.box_max.cwiseMax(c);
    }
    out.push_back(std::move(g));
  }
  return out;
}

double distance_to_gt_polygon(const Eigen::Vector3d& point, const GtPolygon& gt) {
  const Eigen::Vector3d d = point - gt.origin;
  const Eigen::Vector2d st(d.dot(gt.u), d.dot(gt.v));
  const double h = gt.plane.signed_distance(point);
  if (map::point_in_ring(gt.polygon, st)) return std::abs(h);
  double best2 = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0, n = gt.polygon.size(); i < n; ++i) {
    const Eigen::Vector2d& a = gt.polygon[i];
    const Eigen::Vector2d& b = gt.polygon[(i + 1) % n];
    const Eigen::Vector2d ab = b - a;
    const double len2 = ab.squaredNorm();
    const double t = len2 > 0.0 ? std::clamp((st - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    best2 = std::min(best2, (a + t * ab - st).squaredNorm());
  }
  return std::sqrt(h * h + best2);
}

MapAccuracy map_accuracy(const map::GlobalMap& map, std::span<const GtPolygon> gt) {
  MapAccuracy acc;
  const double reach = kCompletenessDistancesM.back();
  std::array<double, kCompletenessDistancesM.size()> area_within{};
  std::vector<Eigen::Vector3f> vertices;
  std::vector<const GtPolygon*> near;
  for (const auto& [id, cell] : map.cells()) {
    cell.vertices_m.vertices_into(vertices);
    const double area = map::polygon_area_m2(vertices);
    const Plane3 plane = cell.plane;
    const map::CoverageGrid grid = map::coverage_grid(plane, vertices);
    if (!(area > 0.0) || grid.points.empty()) continue;
    ++acc.cells;
    acc.area_m2 += area;
    // The GT polygons whose bounds come within the largest distance of the cell's.
    const map::Aabb box = map::bounds_of(vertices);
    near.clear();
    for (const GtPolygon& g : gt)
      if ((g.box_min.array() <= box.max.array() + reach).all() && (g.box_max.array() >= box.min.array() - reach).all())
        near.push_back(&g);
    std::array<std::size_t, kCompletenessDistancesM.size()> hits{};
    for (const Eigen::Vector2d& st : grid.points) {
      const Eigen::Vector3d p = grid.basis.to_3d(st);
      double nearest = std::numeric_limits<double>::infinity();
      for (const GtPolygon* g : near) nearest = std::min(nearest, distance_to_gt_polygon(p, *g));
      for (std::size_t i = 0; i < hits.size(); ++i)
        if (nearest <= kCompletenessDistancesM[i]) ++hits[i];
    }
    for (std::size_t i = 0; i < hits.size(); ++i)
      area_within[i] += area * static_cast<double>(hits[i]) / static_cast<double>(grid.points.size());
  }
  if (acc.area_m2 > 0.0)
    for (std::size_t i = 0; i < area_within.size(); ++i) acc.within[i] = area_within[i] / acc.area_m2;
  return acc;
}

namespace {

/// A point's integer cell of edge `edge_m` per axis, packed into 64 bits (21 bits an axis: cells
/// of ±2²⁰, far beyond any map's coordinates at the edges used here).
std::int64_t cell_key(const Eigen::Vector3d& p, double edge_m) {
  const auto axis = [&](double x) {
    return static_cast<std::int64_t>(std::floor(x / edge_m)) + (std::int64_t{1} << 20);
  };
  return (axis(p.x()) << 42) | (axis(p.y()) << 21) | axis(p.z());
}

/// The GT polygons by the cubes of edge kBucketM their bounds, widened by the largest scored
/// distance, overlap: a point's bucket lists every polygon that can come within that distance.
class GtBuckets {
 public:
  static constexpr double kBucketM = 2.0;
  explicit GtBuckets(std::span<const GtPolygon> gt) : gt_(gt) {
    const double reach = kCompletenessDistancesM.back();
    for (std::uint32_t i = 0; i < gt.size(); ++i) {
      const Eigen::Vector3d lo = gt[i].box_min.array() - reach, hi = gt[i].box_max.array() + reach;
      for (double x = std::floor(lo.x() / kBucketM); x <= std::floor(hi.x() / kBucketM); ++x)
        for (double y = std::floor(lo.y() / kBucketM); y <= std::floor(hi.y() / kBucketM); ++y)
          for (double z = std::floor(lo.z() / kBucketM); z <= std::floor(hi.z() / kBucketM); ++z)
            buckets_[cell_key(kBucketM * Eigen::Vector3d(x + 0.5, y + 0.5, z + 0.5), kBucketM)].push_back(i);
    }
  }
  /// Distance from `p` to the nearest GT polygon, +∞ when none lies within the largest scored distance.
  double nearest(const Eigen::Vector3d& p) const {
    double best = std::numeric_limits<double>::infinity();
    if (const auto it = buckets_.find(cell_key(p, kBucketM)); it != buckets_.end())
      for (std::uint32_t i : it->second) best = std::min(best, distance_to_gt_polygon(p, gt_[i]));
    return best;
  }

 private:
  std::span<const GtPolygon> gt_;
  std::unordered_map<std::int64_t, std::vector<std::uint32_t>> buckets_;
};

}  // namespace

VoxelAccuracy voxel_accuracy(std::span<const Eigen::Vector3d> centres, std::span<const GtPolygon> gt) {
  VoxelAccuracy acc;
  acc.voxels = centres.size();
  if (centres.empty()) return acc;
  const GtBuckets buckets(gt);
  std::array<std::size_t, kCompletenessDistancesM.size()> hits{};
  for (const Eigen::Vector3d& c : centres) {
    const double d = buckets.nearest(c);
    for (std::size_t i = 0; i < hits.size(); ++i)
      if (d <= kCompletenessDistancesM[i]) ++hits[i];
  }
  for (std::size_t i = 0; i < hits.size(); ++i)
    acc.within[i] = static_cast<double>(hits[i]) / static_cast<double>(centres.size());
  return acc;
}

MapCompleteness voxel_completeness(std::span<const Eigen::Vector3d> centres, double resolution_m,
                                   std::span<const Eigen::Vector3d> points) {
  if (!(resolution_m > 0.0))
    throw InputError("voxel completeness: resolution must be > 0 m, got " + std::to_string(resolution_m));
  MapCompleteness c;
  c.points = points.size();
  if (points.empty()) return c;
  std::unordered_set<std::int64_t> occupied;
  occupied.reserve(centres.size());
  for (const Eigen::Vector3d& centre : centres) occupied.insert(cell_key(centre, resolution_m));
  const double reach = kCompletenessDistancesM.back();
  const int shells = static_cast<int>(std::ceil(reach / resolution_m)) + 1;
  std::array<std::size_t, kCompletenessDistancesM.size()> hits{};
  for (const Eigen::Vector3d& p : points) {
    if (!p.allFinite()) continue;  // scored, held by nothing
    const Eigen::Vector3i home = (p / resolution_m).array().floor().cast<int>();
    // Shell r (Chebyshev distance r in voxels) lies at least (r − 1)·resolution from p, which is
    // inside voxel `home`: stop once that exceeds the best distance found or the reach.
    double best = std::numeric_limits<double>::infinity();
    for (int r = 0; r <= shells && (r - 1) * resolution_m <= std::min(best, reach); ++r)
      for (int i = -r; i <= r; ++i)
        for (int j = -r; j <= r; ++j)
          for (int k = -r; k <= r; ++k) {
            if (std::max({std::abs(i), std::abs(j), std::abs(k)}) != r) continue;
            const Eigen::Vector3i q = home + Eigen::Vector3i(i, j, k);
            const Eigen::Vector3d lo = q.cast<double>() * resolution_m;
            if (!occupied.contains(cell_key(lo + Eigen::Vector3d::Constant(0.5 * resolution_m), resolution_m)))
              continue;
            const Eigen::Vector3d gap = (lo - p).cwiseMax(p - (lo.array() + resolution_m).matrix()).cwiseMax(0.0);
            best = std::min(best, gap.norm());
          }
    for (std::size_t i = 0; i < hits.size(); ++i)
      if (best <= kCompletenessDistancesM[i]) ++hits[i];
  }
  for (std::size_t i = 0; i < hits.size(); ++i)
    c.within[i] = static_cast<double>(hits[i]) / static_cast<double>(points.size());
  return c;
}

}  // namespace planecell::services::eval
