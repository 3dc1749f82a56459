/// Vertex extraction on hand-made label images (exact corners, in order), plane fitting on
/// exact and contaminated samples, and the exact 2D→3D conversion of a known plane.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "core/error.hpp"
#include "mapping/planecell/conversion_3d.hpp"
#include "mapping/planecell/plane_fit.hpp"
#include "mapping/planecell/vertex_extraction.hpp"

namespace planecell::extraction {
namespace {

using Polygon = std::vector<Eigen::Vector2f>;

void expect_polygon(const Polygon& actual, const Polygon& expected) {
  ASSERT_EQ(actual.size(), expected.size());
  for (std::size_t k = 0; k < expected.size(); ++k) {
    EXPECT_FLOAT_EQ(actual[k].x(), expected[k].x()) << "vertex " << k;
    EXPECT_FLOAT_EQ(actual[k].y(), expected[k].y()) << "vertex " << k;
  }
}

double shoelace_area(const Polygon& p) {
  double twice = 0.0;
  for (std::size_t k = 0; k < p.size(); ++k) {
    const auto& a = p[k];
    const auto& b = p[(k + 1) % p.size()];
    twice += static_cast<double>(a.x()) * b.y() - static_cast<double>(b.x()) * a.y();
  }
  return 0.5 * twice;
}

TEST(VertexExtraction, RectangleGivesItsFourCornersClockwise) {
  cv::Mat labels(10, 12, CV_32S, cv::Scalar(0));
  labels(cv::Rect(3, 2, 5, 4)).setTo(1);  // pixels u ∈ [3, 7], v ∈ [2, 5]
  const auto polygons = extract_polygons(labels, 2);
  ASSERT_EQ(polygons.size(), 2u);
  expect_polygon(polygons[1], {{2.5f, 1.5f}, {7.5f, 1.5f}, {7.5f, 5.5f}, {2.5f, 5.5f}});
  // The background's outer boundary is the image border.
  expect_polygon(polygons[0], {{-0.5f, -0.5f}, {11.5f, -0.5f}, {11.5f, 9.5f}, {-0.5f, 9.5f}});
  EXPECT_DOUBLE_EQ(shoelace_area(polygons[1]), 20.0);
}

TEST(VertexExtraction, LShapeGivesSixCornersInOrder) {
  // 1 1 0 0
  // 1 1 0 0
  // 1 1 1 1
  // 1 1 1 1
  cv::Mat labels(4, 4, CV_32S, cv::Scalar(1));
  labels(cv::Rect(2, 0, 2, 2)).setTo(0);
  const auto polygons = extract_polygons(labels, 2);
  expect_polygon(polygons[1], {{-0.5f, -0.5f},
                               {1.5f, -0.5f},
                               {1.5f, 1.5f},
                               {3.5f, 1.5f},
                               {3.5f, 3.5f},
                               {-0.5f, 3.5f}});
  EXPECT_DOUBLE_EQ(shoelace_area(polygons[1]), 12.0);
  expect_polygon(polygons[0], {{1.5f, -0.5f}, {3.5f, -0.5f}, {3.5f, 1.5f}, {1.5f, 1.5f}});
}

TEST(VertexExtraction, JunctionsOnStraightEdgesAreVertices) {
  // Three vertical strips under one horizontal strip: the T-junctions on the strip's bottom
  // edge are vertices of the top cell although its boundary is straight there.
  cv::Mat labels(6, 9, CV_32S, cv::Scalar(0));
  labels(cv::Rect(0, 3, 3, 3)).setTo(1);
  labels(cv::Rect(3, 3, 3, 3)).setTo(2);
  labels(cv::Rect(6, 3, 3, 3)).setTo(3);
  const auto polygons = extract_polygons(labels, 4, 1.0);
  expect_polygon(polygons[0], {{-0.5f, -0.5f},
                               {8.5f, -0.5f},
                               {8.5f, 2.5f},
                               {5.5f, 2.5f},
                               {2.5f, 2.5f},
                               {-0.5f, 2.5f}});
  expect_polygon(polygons[2], {{2.5f, 2.5f}, {5.5f, 2.5f}, {5.5f, 5.5f}, {2.5f, 5.5f}});
}

TEST(VertexExtraction, StaircaseIsSimplifiedWithinTolerance) {
  // Label 1 below a 45° staircase; without simplification every step is two vertices.
  constexpr int kN = 12;
  cv::Mat labels(kN, kN, CV_32S, cv::Scalar(0));
  for (int v = 0; v < kN; ++v)
    for (int u = 0; u <= v; ++u) labels.at<int>(v, u) = 1;
  const auto exact = extract_polygons(labels, 2, 0.0);
  const auto simplified = extract_polygons(labels, 2, 1.0);
  EXPECT_EQ(exact[1].size(), 2u * kN + 2);  // 2 per step + the two far corners
  EXPECT_DOUBLE_EQ(shoelace_area(exact[1]), kN * (kN + 1) / 2.0);
  // The junctions (1,0), (12,11) and the image corners stay; the 0.7 px steps go.
  expect_polygon(simplified[1],
                 {{-0.5f, -0.5f}, {0.5f, -0.5f}, {11.5f, 10.5f}, {11.5f, 11.5f}, {-0.5f, 11.5f}});
  EXPECT_NEAR(shoelace_area(simplified[1]), kN * (kN + 1) / 2.0, kN);
}

TEST(VertexExtraction, JunctionsOnlyKeepsJunctionsAndImageCorners) {
  constexpr int kN = 12;
  cv::Mat labels(kN, kN, CV_32S, cv::Scalar(0));
  for (int v = 0; v < kN; ++v)
    for (int u = 0; u <= v; ++u) labels.at<int>(v, u) = 1;
  const auto polygons = extract_polygons(labels, 2, 0.0, true);
  // Junctions where the staircase meets the border, (1,0) and (12,11), plus image corners.
  expect_polygon(polygons[1],
                 {{-0.5f, -0.5f}, {0.5f, -0.5f}, {11.5f, 10.5f}, {11.5f, 11.5f}, {-0.5f, 11.5f}});
  expect_polygon(polygons[0], {{0.5f, -0.5f}, {11.5f, -0.5f}, {11.5f, 10.5f}});
}

TEST(VertexExtraction, RejectsBadLabels) {
  EXPECT_THROW(extract_polygons(cv::Mat(), 1), InputError);
  EXPECT_THROW(extract_polygons(cv::Mat(3, 3, CV_8U, cv::Scalar(0)), 1), InputError);
  EXPECT_THROW(extract_polygons(cv::Mat(3, 3, CV_32S, cv::Scalar(5)), 2), InputError);
}

TEST(PlaneFit, RecoversAnExactPlaneDespiteOutliers) {
  const DisparityPlane truth{0.03, -0.02, 17.0};
  std::vector<Eigen::Vector3f> samples;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> wild(3.0f, 40.0f);
  for (int v = 0; v < 20; ++v)
    for (int u = 100; u < 130; ++u) {
      const bool outlier = (u * 7 + v * 3) % 5 == 0;  // 20 % gross outliers (≥ 3 px off)
      const float d = static_cast<float>(truth.at(u, v));
      samples.emplace_back(u, v, outlier ? d + wild(rng) : d);
    }
  ExtractionConfig config;
  const PlaneFitResult fit = fit_disparity_plane(samples, config, 3);
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.plane.a, truth.a, 1e-5);
  EXPECT_NEAR(fit.plane.b, truth.b, 1e-5);
  EXPECT_NEAR(fit.plane.c, truth.c, 1e-3);
  EXPECT_EQ(fit.valid, 600);
  EXPECT_EQ(fit.inliers, 480);  // exactly the true samples
}

TEST(PlaneFit, FailsOnTooFewOrIncoherentSamples) {
  ExtractionConfig config;
  std::vector<Eigen::Vector3f> few = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
  EXPECT_FALSE(fit_disparity_plane(few, config, 1).ok);
  std::vector<Eigen::Vector3f> noise;
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> wild(0.0f, 100.0f);
  for (int k = 0; k < 400; ++k) noise.emplace_back(k % 20, k / 20, wild(rng));
  EXPECT_FALSE(fit_disparity_plane(noise, config, 1).ok);
}

TEST(Conversion3d, VerticesBackProjectExactlyOntoThePlane) {
  StereoCamera camera;  // KITTI defaults
  // A ground plane 1.65 m below the camera: Y = 1.65 → n = (0, 1, 0), e = −1.65.
  Plane3 ground;
  ground.normal = Eigen::Vector3d::UnitY();
  ground.offset = -1.65;
  Planecell cell;
  cell.has_plane = true;
  cell.disparity_plane = disparity_from_plane(ground, camera);
  cell.vertices_px = {{400.0f, 300.0f}, {700.0f, 300.0f}, {700.0f, 370.0f}, {400.0f, 370.0f}};
  convert_to_3d(cell, camera);
  EXPECT_NEAR(cell.plane.normal.dot(ground.normal), 1.0, 1e-9);
  EXPECT_NEAR(cell.plane.offset, ground.offset, 1e-9);
  ASSERT_EQ(cell.vertices_m.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) {
    const Eigen::Vector3d x = cell.vertices_m[k].cast<double>();
    EXPECT_NEAR(x.y(), 1.65, 1e-5);  // on the ground
    const double d = cell.disparity_plane.at(cell.vertices_px[k].x(), cell.vertices_px[k].y());
    EXPECT_NEAR(x.z(), camera.fx * camera.baseline_m / d, 1e-4);
    const Eigen::Vector3d uvd = camera.project(x);
    EXPECT_NEAR(uvd.x(), cell.vertices_px[k].x(), 1e-3);
    EXPECT_NEAR(uvd.y(), cell.vertices_px[k].y(), 1e-3);
  }
  cell.has_plane = false;
  convert_to_3d(cell, camera);
  EXPECT_TRUE(cell.vertices_m.empty());
}

TEST(DenseDisparity, PlanelessCellTakesTheFartherNeighbourPlane) {
  // Three strips: near plane (d = 40), planeless middle, far plane (d = 10).
  cv::Mat labels(4, 9, CV_32S);
  for (int u = 0; u < 9; ++u) labels.col(u).setTo(u / 3);
  std::vector<Planecell> cells(3);
  cells[0].has_plane = true;
  cells[0].disparity_plane = {0.0, 0.0, 40.0};
  cells[2].has_plane = true;
  cells[2].disparity_plane = {0.0, 0.0, 10.0};
  const cv::Mat filled = render_dense_disparity(labels, cells, true);
  EXPECT_FLOAT_EQ(filled.at<float>(1, 4), 10.0f);
  EXPECT_FLOAT_EQ(filled.at<float>(1, 0), 40.0f);
  const cv::Mat unfilled = render_dense_disparity(labels, cells, false);
  EXPECT_TRUE(std::isnan(unfilled.at<float>(1, 4)));
  EXPECT_FLOAT_EQ(unfilled.at<float>(1, 8), 10.0f);
}

TEST(DenseDisparity, PlanelessCellsAreFilledAcrossEveryEdgeAndInRings) {
  // Cell 0 has the plane d = 7, cell 1 none. Returns the filled dense map.
  auto fill = [](int w, int h, const std::vector<std::int32_t>& values, int n) {
    cv::Mat labels(h, w, CV_32S);
    std::copy(values.begin(), values.end(), labels.ptr<std::int32_t>(0));
    std::vector<Planecell> cells(n);
    cells[0].has_plane = true;
    cells[0].disparity_plane = {0.0, 0.0, 7.0};
    return render_dense_disparity(labels, cells, true);
  };
  // Cell 1 touches cell 0 only across its top edge, then only across its left edge.
  const cv::Mat below = fill(3, 2, {0, 0, 0, 1, 1, 1}, 2);
  EXPECT_FLOAT_EQ(below.at<float>(1, 1), 7.0f);
  const cv::Mat right = fill(2, 3, {0, 1, 0, 1, 0, 1}, 2);
  EXPECT_FLOAT_EQ(right.at<float>(2, 1), 7.0f);
  // Cell 2 is enclosed by the planeless ring of cell 1: filled in the second round.
  const cv::Mat ring = fill(5, 5, {0, 0, 0, 0, 0,  //
                                   0, 1, 1, 1, 0,  //
                                   0, 1, 2, 1, 0,  //
                                   0, 1, 1, 1, 0,  //
                                   0, 0, 0, 0, 0},
                            3);
  for (int v = 0; v < 5; ++v)
    for (int u = 0; u < 5; ++u) EXPECT_FLOAT_EQ(ring.at<float>(v, u), 7.0f) << u << ", " << v;
}

TEST(DenseDisparity, RejectsLabelsOutsideTheCells) {
  std::vector<Planecell> cells(2);
  cells[0].has_plane = cells[1].has_plane = true;
  cv::Mat labels(3, 4, CV_32S, cv::Scalar(1));
  EXPECT_NO_THROW(render_dense_disparity(labels, cells, true));
  labels.at<std::int32_t>(2, 3) = 2;
  EXPECT_THROW(render_dense_disparity(labels, cells, true), InputError);
  labels.at<std::int32_t>(2, 3) = -1;
  EXPECT_THROW(render_dense_disparity(labels, cells, false), InputError);
}

}  // namespace
}  // namespace planecell::extraction
