/// The map's spatial index (map::SpatialIndex) against brute force: which boxes overlap a query
/// box, before and after most boxes leave (the index trims its buckets then), and its errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <vector>

#include "core/error.hpp"
#include "mapping/map/spatial_index.hpp"

namespace planecell::map {
namespace {

Aabb box_at(const Eigen::Vector3d& lo, const Eigen::Vector3d& size) {
  Aabb b;
  b.extend(lo);
  b.extend(lo + size);
  return b;
}

/// Ids of `boxes` overlapping `query`, sorted: the answer the index must give.
std::vector<std::uint32_t> brute_force(const std::map<std::uint32_t, Aabb>& boxes,
                                       const Aabb& query) {
  std::vector<std::uint32_t> ids;
  for (const auto& [id, b] : boxes)
    if (b.overlaps(query)) ids.push_back(id);
  return ids;
}

class SpatialIndexTest : public ::testing::Test {
 protected:
  /// 2 000 seeded boxes of 0.1–6 m along a 200 m street, 2 m buckets.
  void SetUp() override {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> x(-100.0, 100.0), y(-8.0, 8.0), z(-2.0, 6.0),
        size(0.1, 6.0);
    for (std::uint32_t id = 0; id < 2000; ++id) {
      boxes_[id] = box_at({x(rng), y(rng), z(rng)}, {size(rng), size(rng), size(rng)});
      index_.insert(id, boxes_[id]);
    }
  }

  void expect_matches_brute_force(int queries) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> x(-110.0, 110.0), y(-10.0, 10.0), z(-3.0, 7.0),
        size(0.0, 12.0);
    for (int q = 0; q < queries; ++q) {
      const Aabb query = box_at({x(rng), y(rng), z(rng)}, {size(rng), size(rng), size(rng)});
      const auto found = index_.query(query, [&](std::uint32_t id) { return boxes_.at(id); });
      ASSERT_EQ(found, brute_force(boxes_, query)) << "query " << q;
      const auto candidates = index_.candidates(query);
      EXPECT_TRUE(std::is_sorted(candidates.begin(), candidates.end()));
      EXPECT_EQ(std::adjacent_find(candidates.begin(), candidates.end()), candidates.end()) << "query " << q;
      EXPECT_TRUE(std::includes(candidates.begin(), candidates.end(), found.begin(), found.end()));
    }
  }

  SpatialIndex index_{2.0};
  std::map<std::uint32_t, Aabb> boxes_;
};

TEST_F(SpatialIndexTest, AnswersBoxQueriesLikeBruteForce) {
  EXPECT_EQ(index_.size(), 2000u);
  expect_matches_brute_force(300);
}

/// After 95 % of the boxes leave (as replaced, pruned and consolidated cells do), the index,
/// whose buckets and bucket table shrink on the way, still answers exactly, and takes new boxes.
TEST_F(SpatialIndexTest, AnswersExactlyAfterMostBoxesLeave) {
  for (std::uint32_t id = 0; id < 2000; ++id)
    if (id % 20 != 0) {
      index_.remove(id, boxes_.at(id));
      boxes_.erase(id);
    }
  EXPECT_EQ(index_.size(), 100u);
  expect_matches_brute_force(300);
  for (std::uint32_t id = 5000; id < 5200; ++id) {
    boxes_[id] = box_at({0.1 * (id - 5000) - 10.0, 0.5, 1.0}, {1.0, 1.0, 1.0});
    index_.insert(id, boxes_[id]);
  }
  expect_matches_brute_force(300);
  for (const auto& [id, b] : boxes_) index_.remove(id, b);
  EXPECT_EQ(index_.size(), 0u);
  EXPECT_TRUE(index_.candidates(box_at({-200, -20, -10}, {400, 40, 20})).empty());
}

/// Ids registered in any order (a map restored from its store, cells re-registered after a move)
/// are answered as when registered in id order: the same sorted, unique candidates.
TEST_F(SpatialIndexTest, AnswersLikeBruteForceWhateverTheInsertionOrder) {
  std::vector<std::uint32_t> ids;
  for (const auto& [id, b] : boxes_) ids.push_back(id);
  std::shuffle(ids.begin(), ids.end(), std::mt19937(3));
  SpatialIndex shuffled(2.0);
  for (std::uint32_t id : ids) shuffled.insert(id, boxes_.at(id));
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> x(-110.0, 110.0), y(-10.0, 10.0), z(-3.0, 7.0), size(0.0, 12.0);
  for (int q = 0; q < 300; ++q) {
    const Aabb query = box_at({x(rng), y(rng), z(rng)}, {size(rng), size(rng), size(rng)});
    ASSERT_EQ(shuffled.candidates(query), index_.candidates(query)) << "query " << q;
    ASSERT_EQ(shuffled.query(query, [&](std::uint32_t id) { return boxes_.at(id); }), brute_force(boxes_, query));
  }
}

TEST_F(SpatialIndexTest, CandidatesAreTheIdsWhoseBucketRangeMeetsTheQuerys) {
  // The bridges filter one frame-wide query by bucket ranges instead of querying per surface:
  // an id is among candidates(box) exactly when the bucket range of the box it was registered
  // with overlaps the query's (by hand: the 2 m buckets floor(x / 2) … floor(max / 2) per axis).
  const SpatialIndex::BucketRange unit = index_.bucket_range(box_at({-1.0, 0.5, 3.9}, {2.5, 1.0, 0.2}));
  ASSERT_FALSE(unit.empty);
  EXPECT_EQ(unit.lo, (std::array<std::int64_t, 3>{-1, 0, 1}));
  EXPECT_EQ(unit.hi, (std::array<std::int64_t, 3>{0, 0, 2}));
  EXPECT_TRUE(index_.bucket_range(Aabb{}).empty);
  EXPECT_FALSE(unit.overlaps(index_.bucket_range(Aabb{})));
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> x(-110.0, 110.0), y(-10.0, 10.0), z(-3.0, 7.0), size(0.0, 12.0);
  for (int q = 0; q < 200; ++q) {
    const Aabb query = box_at({x(rng), y(rng), z(rng)}, {size(rng), size(rng), size(rng)});
    const SpatialIndex::BucketRange range = index_.bucket_range(query);
    std::vector<std::uint32_t> by_range;
    for (const auto& [id, b] : boxes_)
      if (index_.bucket_range(b).overlaps(range)) by_range.push_back(id);
    std::sort(by_range.begin(), by_range.end());
    ASSERT_EQ(index_.candidates(query), by_range) << "query " << q;
  }
}

TEST(SpatialIndex, RefusesBadBucketsAndBoxesBeyondItsRange) {
  EXPECT_THROW(SpatialIndex(0.0), ConfigError);
  EXPECT_THROW(SpatialIndex(-1.0), ConfigError);
  SpatialIndex index(2.0);
  const double edge = index.max_coordinate_m();
  EXPECT_THROW(index.insert(1, box_at({edge + 10.0, 0, 0}, {1, 1, 1})), InputError);
  EXPECT_EQ(index.size(), 0u);
}

}  // namespace
}  // namespace planecell::map
