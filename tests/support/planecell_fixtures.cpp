#include "support/planecell_fixtures.hpp"

#include <Eigen/Geometry>

namespace planecell::test {

Planecell rect_cell(std::uint32_t id, const Eigen::Vector3f& corner, const Eigen::Vector3f& e1,
                    const Eigen::Vector3f& e2, int colour_bin) {
  Planecell c;
  c.id = id;
  c.has_plane = true;
  c.vertices_m = {corner, corner + e1, corner + e1 + e2, corner + e2};
  const Eigen::Vector3d n = e1.cross(e2).cast<double>().normalized();
  c.plane.normal = n;
  c.plane.offset = -n.dot(corner.cast<double>());
  c.histogram.fill(0.0f);
  c.histogram[colour_bin] = 1.0f;
  c.mean_rgb = Eigen::Vector3f(4.0f * colour_bin, 100.0f, 50.0f);
  c.area_px = 400;
  c.vertices_px = {{0, 0}, {20, 0}, {20, 20}, {0, 20}};
  return c;
}

}  // namespace planecell::test
