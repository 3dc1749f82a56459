/// JSON export of surface outlines: a map of a floor cell and a wall cell written and read back
/// (format, planes, rings against the cells' corners), and the errors of a bad path or tolerance.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.hpp"
#include "io/outline_export.hpp"
#include "support/expect_error.hpp"
#include "support/planecell_fixtures.hpp"
#include "support/test_data.hpp"

namespace planecell::io {
namespace {

/// A map of two surfaces: a 1 m floor square (y = 1.5, x 0…1, z 5…6) and a 1 m wall square
/// (x = −3, y 0…1, z 5…6), integrated from the identity pose.
map::GlobalMap floor_and_wall() {
  map::GlobalMap map;
  const std::vector<Planecell> cells = {test::rect_cell(0, {0, 1.5f, 5}, {1, 0, 0}, {0, 0, 1}, 3),
                                        test::rect_cell(1, {-3, 0, 5}, {0, 1, 0}, {0, 0, 1}, 20)};
  map.integrate(0, Pose::Identity(), cells);
  return map;
}

TEST(OutlineExport, WritesEachSurfaceWithItsPlaneAndRing) {
  test::ScratchDir dir;
  const map::GlobalMap map = floor_and_wall();
  ASSERT_EQ(map.surfaces().size(), 2u);
  const auto path = dir / "out" / "outlines.json";  // the folder is created
  const OutlineExport written = write_outlines_json(path, map, 0.0);
  EXPECT_EQ(written.surfaces, 2u);
  EXPECT_EQ(written.rings, 2u);
  EXPECT_EQ(written.vertices, 8u);  // two squares, four corners each

  std::ifstream in(path);
  const nlohmann::json json = nlohmann::json::parse(in);
  EXPECT_EQ(json["format"], "planecell-outlines");
  EXPECT_EQ(json["version"], 1);
  EXPECT_DOUBLE_EQ(json["footprint_resolution_m"].get<double>(),
                   map.config().footprint_resolution_m);
  ASSERT_EQ(json["surfaces"].size(), 2u);
  for (const auto& surface : json["surfaces"]) {
    const map::Surface* s = map.surface(surface["id"].get<std::uint32_t>());
    ASSERT_NE(s, nullptr);
    EXPECT_NEAR(surface["plane"][3].get<double>(), s->plane.offset(), 1e-12);
    EXPECT_NEAR(surface["area_m2"].get<double>(), 1.0, 1e-9);  // 10 × 10 bits of 10 cm
    ASSERT_EQ(surface["rings"].size(), 1u);
    const auto& ring = surface["rings"][0];
    EXPECT_FALSE(ring["hole"].get<bool>());
    ASSERT_EQ(ring["vertices"].size(), 4u);
    // Each corner lies on the surface's plane and on the cell's square (the bits' centres fall
    // inside it, so the bits cover it exactly; 0.1 mm rounding).
    for (const auto& v : ring["vertices"]) {
      const Eigen::Vector3d x(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
      EXPECT_NEAR(s->plane.signed_distance(x), 0.0, 1e-4);
      EXPECT_NEAR(x.z() - 5.0, std::round(x.z() - 5.0), 1e-4);  // z is 5 or 6
    }
  }
}

TEST(OutlineExport, BadPathAndToleranceAreNamedErrors) {
  test::ScratchDir dir;
  const map::GlobalMap map = floor_and_wall();
  std::ofstream(dir / "file") << "x";
  const auto blocked = dir / "file" / "outlines.json";  // parent is a file
  try {
    write_outlines_json(blocked, map, 0.1);
    ADD_FAILURE() << "no StorageError";
  } catch (const StorageError& e) {
    EXPECT_CONTAINS(e.what(), blocked.string());
  }
  EXPECT_CONTAINS(test::input_error_of([&] { write_outlines_json(dir / "o.json", map, -1.0); }),
                  "tolerance");
}

}  // namespace
}  // namespace planecell::io
