/// The top-down map views: hand-made cells land where the view's axes say, in the colour of their
/// surface or height, higher cells over lower ones.
#include <gtest/gtest.h>

#include "core/error.hpp"
#include "services/bench/map_views.hpp"
#include "services/render/cell_colours.hpp"
#include "support/planecell_fixtures.hpp"

namespace planecell::services::bench {
namespace {

/// A horizontal square [x0, x0 + size] × [z0, z0 + size] at height h (world y = −h: y is down).
map::MapCell flat_square(std::uint32_t id, float x0, float z0, float size, float h,
                         std::uint32_t surface) {
  const Planecell cell = test::rect_cell(id, Eigen::Vector3f(x0, -h, z0), Eigen::Vector3f(size, 0, 0),
                                         Eigen::Vector3f(0, 0, size), 3);
  return map::map_cell_of(cell, id, 0, surface);
}

cv::Vec3b at(const cv::Mat& image, const PlotArea& area, double x, double z) {
  return image.at<cv::Vec3b>(area.to_point(x, z));
}

TEST(TopView, CellsLandWhereTheAxesSayInTheirSurfaceColour) {
  // A road square (surface 4) and a raised square (surface 9) partly over it.
  const std::vector<map::MapCell> cells = {flat_square(1, 0, 0, 4, 0.0f, 4),
                                        flat_square(2, 3, 3, 2, 1.5f, 9)};
  TopViewOptions options;
  options.colour = TopViewColour::kSurface;
  const cv::Mat image = render_top_view(cells, options);
  const PlotArea area = top_view_area(cells, options);
  EXPECT_EQ(at(image, area, 1.0, 1.0), render::surface_colour_bgr(4));
  EXPECT_EQ(at(image, area, 4.5, 4.5), render::surface_colour_bgr(9));
  EXPECT_EQ(at(image, area, 3.5, 3.5),
            render::surface_colour_bgr(9));  // the higher cell covers the road
  EXPECT_EQ(at(image, area, 1.0, 4.6), cv::Vec3b(255, 255, 255));  // no cell there
  // Equal scale: a metre is as many pixels along x as along z.
  EXPECT_NEAR(area.to_pixel(1, 0).x - area.to_pixel(0, 0).x,
              area.to_pixel(0, 0).y - area.to_pixel(0, 1).y, 1e-9);
}

TEST(TopView, HeightColoursSeparateLowAndHighCells) {
  const std::vector<map::MapCell> cells = {flat_square(1, 0, 0, 4, 0.0f, 1),
                                        flat_square(2, 6, 0, 4, 2.0f, 1)};
  TopViewOptions options;  // height
  const cv::Mat image = render_top_view(cells, options);
  const PlotArea area = top_view_area(cells, options);
  const cv::Vec3b low = at(image, area, 2, 2), high = at(image, area, 8, 2);
  EXPECT_NE(low, high);
  EXPECT_NE(low, cv::Vec3b(255, 255, 255));
  EXPECT_NE(high, cv::Vec3b(255, 255, 255));
  EXPECT_GT(image.cols, area.rect().x + area.rect().width + 100);  // room for the colour bar
}

TEST(TopView, RejectsAMapWithoutVerticesAndAZeroUp) {
  std::vector<map::MapCell> cells(2);
  EXPECT_THROW(render_top_view(cells, {}), InputError);
  cells = {flat_square(1, 0, 0, 1, 0.0f, 1)};
  TopViewOptions options;
  options.up = Eigen::Vector3d::Zero();
  EXPECT_THROW(render_top_view(cells, options), ConfigError);
}

}  // namespace
}  // namespace planecell::services::bench
