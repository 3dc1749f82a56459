#include "support/planecell_fixtures.hpp"

#include <Eigen/Geometry>
#include <algorithm>

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

void tile(std::vector<Planecell>& out, const Eigen::Vector3f& origin, const Eigen::Vector3f& a,
          const Eigen::Vector3f& b, float a_len, float b_len, float tile_m, float shift_m, int bin) {
  for (float s = shift_m; s < a_len - 1e-3f; s += tile_m) {
    for (float t = shift_m; t < b_len - 1e-3f; t += tile_m) {
      const float ds = std::min(tile_m, a_len - s), dt = std::min(tile_m, b_len - t);
      Planecell c = rect_cell(static_cast<std::uint32_t>(out.size()), origin + s * a + t * b, ds * a,
                              dt * b, bin);
      c.inlier_ratio = 1.0f;
      out.push_back(c);
    }
  }
}

std::vector<Planecell> street_cells(float shift_m, bool ground_only) {
  const Eigen::Vector3f x(1, 0, 0), y(0, 1, 0), z(0, 0, 1);
  std::vector<Planecell> cells;
  tile(cells, {-5, 1.65f, 3}, z, x, 17, 10, 2, shift_m, 1);  // road: n = z × x = +y
  if (ground_only) return cells;
  tile(cells, {-5, -3, 3}, y, z, 4.65f, 17, 2, shift_m, 2);  // left wall x = −5
  tile(cells, {5, -3, 3}, z, y, 17, 4.65f, 2, shift_m, 3);   // right wall x = +5
  tile(cells, {-5, -3, 20}, x, y, 10, 4.65f, 2, shift_m, 4); // facade z = 20
  return cells;
}

}  // namespace planecell::test
