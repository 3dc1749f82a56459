/// Photometric plane refinement (mapping/planecell/photometric_planes) against the synthetic
/// renderer's exact disparity: it recovers a road plane from a start 1.2 px off, keeps the plane
/// of a textureless cell, refuses bad inputs, and inside extract_planecells removes the slant bias
/// SGM leaves in the road's bottom rows.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "io/synthetic/synthetic_world.hpp"
#include "mapping/planecell/extraction.hpp"
#include "mapping/planecell/photometric_planes.hpp"
#include "mapping/stereo/sgm.hpp"
#include "support/expect_error.hpp"

namespace planecell::extraction {
namespace {

/// A rendered street frame (KITTI size: at half size the road's bottom cells hold too few
/// textured samples, and the refinement keeps about half of them as fitted) with its road pixels.
struct StreetFrame {
  io::SyntheticWorld world;
  io::SyntheticView view;
  cv::Mat left_grey, right_grey;
  cv::Mat road;  ///< CV_8U, 255 on road pixels with a GT disparity
};

StreetFrame street_frame() {
  SynthConfig config;
  config.frames = 30;
  config.width = 1242;
  config.height = 375;
  StreetFrame f;
  f.world = io::make_street_world(config);
  f.view = io::render_view(f.world, f.world.trajectory.at(20), 20);
  cv::cvtColor(f.view.left, f.left_grey, cv::COLOR_BGR2GRAY);
  cv::cvtColor(f.view.right, f.right_grey, cv::COLOR_BGR2GRAY);
  std::vector<bool> is_road(f.world.surfaces.size() + 1, false);
  for (const auto& s : f.world.surfaces) is_road.at(s.id) = s.kind == io::SurfaceKind::kRoad;
  f.road = cv::Mat::zeros(f.view.left.size(), CV_8U);
  for (int v = 0; v < f.road.rows; ++v)
    for (int u = 0; u < f.road.cols; ++u)
      if (is_road.at(f.view.surface_id.at<std::uint16_t>(v, u)) &&
          std::isfinite(f.view.disparity.at<float>(v, u)))
        f.road.at<std::uint8_t>(v, u) = 255;
  return f;
}

/// The extraction defaults with the photometric refinement on (5 steps per cell).
ExtractionConfig photometric_on() {
  ExtractionConfig config;
  config.photometric_iterations = 5;
  return config;
}

/// Least-squares disparity plane through the GT disparity of the pixels with label 0.
DisparityPlane fit_truth(const cv::Mat& disparity, const std::vector<std::int32_t>& labels) {
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (int v = 0; v < disparity.rows; ++v)
    for (int u = 0; u < disparity.cols; ++u) {
      if (labels[static_cast<std::size_t>(v) * disparity.cols + u] != 0) continue;
      const Eigen::Vector3d x(u, v, 1.0);
      a += x * x.transpose();
      b += x * disparity.at<float>(v, u);
    }
  const Eigen::Vector3d p = a.ldlt().solve(b);
  return {p[0], p[1], p[2]};
}

TEST(PhotometricPlanes, RecoversTheRoadPlaneFromAStartOffByMoreThanAPixel) {
  const StreetFrame f = street_frame();
  // One cell: the road in a band of rows near the bottom, middle half of the columns.
  const int w = f.road.cols, h = f.road.rows;
  std::vector<std::int32_t> labels(static_cast<std::size_t>(w) * h, -1);
  int pixels = 0;
  for (int v = h - 40; v < h - 10; ++v)
    for (int u = w / 4; u < 3 * w / 4; ++u)
      if (f.road.at<std::uint8_t>(v, u)) labels[static_cast<std::size_t>(v) * w + u] = 0, ++pixels;
  ASSERT_GT(pixels, 2000);
  const DisparityPlane truth = fit_truth(f.view.disparity, labels);
  ASSERT_GT(truth.b, 0.1);  // the road is slanted: its disparity grows towards the bottom
  std::vector<DisparityPlane> planes{{truth.a, truth.b + 0.01, truth.c + 1.2 - 0.01 * (h - 25)}};
  const std::vector<std::uint8_t> has_plane{1};
  const auto stats = refine_planes_photometric(f.left_grey, f.right_grey, labels, planes, has_plane,
                                               photometric_on());
  EXPECT_EQ(stats.refined, 1);
  double worst = 0.0;
  for (int v = h - 40; v < h - 10; ++v)
    for (int u = w / 4; u < 3 * w / 4; ++u)
      if (labels[static_cast<std::size_t>(v) * w + u] == 0)
        worst = std::max(worst, std::abs(planes[0].at(u, v) - truth.at(u, v)));
  EXPECT_LT(worst, 0.15) << "the start was 1.2 px off in the band's middle";
}

TEST(PhotometricPlanes, KeepsThePlaneOfATexturelessCell) {
  const cv::Mat flat(60, 80, CV_8UC1, cv::Scalar(120));
  std::vector<std::int32_t> labels(60 * 80, 0);
  const DisparityPlane fitted{0.01, 0.2, 5.0};
  std::vector<DisparityPlane> planes{fitted};
  const std::vector<std::uint8_t> has_plane{1};
  const auto stats = refine_planes_photometric(flat, flat, labels, planes, has_plane, photometric_on());
  EXPECT_EQ(stats.refined, 0);
  EXPECT_EQ(stats.kept, 1);
  EXPECT_EQ(planes[0].a, fitted.a);
  EXPECT_EQ(planes[0].b, fitted.b);
  EXPECT_EQ(planes[0].c, fitted.c);
}

TEST(PhotometricPlanes, RefusesImagesOfDifferentSizesAndALabelImageThatDoesNotFit) {
  const cv::Mat a(60, 80, CV_8UC1, cv::Scalar(0)), b(60, 81, CV_8UC1, cv::Scalar(0));
  std::vector<DisparityPlane> planes(1);
  const std::vector<std::uint8_t> has_plane{1};
  std::vector<std::int32_t> labels(60 * 80, 0);
  EXPECT_CONTAINS(test::input_error_of([&] {
                    refine_planes_photometric(a, b, labels, planes, has_plane, photometric_on());
                  }),
                  "one size");
  labels.resize(10);
  EXPECT_CONTAINS(test::input_error_of([&] {
                    refine_planes_photometric(a, a, labels, planes, has_plane, photometric_on());
                  }),
                  "label image");
}

/// Median signed error (px) of the dense plane disparity on the road pixels of rows [v0, v1).
double road_median_error(const StreetFrame& f, const cv::Mat& dense, int v0, int v1) {
  std::vector<double> errors;
  for (int v = v0; v < v1; ++v)
    for (int u = 0; u < f.road.cols; ++u)
      if (f.road.at<std::uint8_t>(v, u) && std::isfinite(dense.at<float>(v, u)))
        errors.push_back(dense.at<float>(v, u) - f.view.disparity.at<float>(v, u));
  if (errors.empty()) return NAN;
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return errors[errors.size() / 2];
}

TEST(PhotometricPlanes, RemovesSgmsSlantBiasFromTheRoadsBottomRows) {
  const StreetFrame f = street_frame();
  SgmConfig sgm;
  sgm.max_disparity = 128;
  const cv::Mat disparity = stereo::compute_disparity(f.view.left, f.view.right, sgm);
  ExtractionConfig config;
  config.target_cells = 800;
  const int h = f.road.rows;
  const auto fitted = extract_planecells(f.view.left, f.view.right, disparity, f.world.camera, config);
  config.photometric_iterations = 5;
  const auto refined = extract_planecells(f.view.left, f.view.right, disparity, f.world.camera, config);
  const double before = road_median_error(f, fitted.dense_disparity, h - 12, h);
  const double after = road_median_error(f, refined.dense_disparity, h - 12, h);
  // SGM's top-down paths lag on the slanted road where the bottom-up paths have just started.
  EXPECT_LT(before, -0.25) << "the bias this refinement is for is not there";
  EXPECT_LT(std::abs(after), 0.3);
  EXPECT_LT(std::abs(after), 0.5 * std::abs(before));
}

}  // namespace
}  // namespace planecell::extraction
