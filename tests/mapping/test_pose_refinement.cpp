/// Pose refinement against hand-built maps: big rectangular surfaces (road, two side walls, a
/// facade facing the camera) tiled into cells; the frame sees the same planes (tiles offset by half
/// a tile) from a known pose and is handed a perturbed one.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/error.hpp"
#include "mapping/map/global_map.hpp"
#include "mapping/map/pose_transform.hpp"
#include "mapping/refine/pose_refinement.hpp"
#include "mapping/refine/surface_planes.hpp"
#include "support/planecell_fixtures.hpp"

namespace planecell::refine {
namespace {

using Vector6 = Eigen::Matrix<double, 6, 1>;
constexpr double kDeg = std::numbers::pi / 180.0;

/// The map built from the street seen at the identity pose.
map::GlobalMap make_map(bool ground_only) {
  MapConfig config;
  config.max_range_m = 40.0;  // the facade at z = 20 m is part of the fixture
  map::GlobalMap map(config);
  const auto cells = test::street_cells(0.0f, ground_only);
  map.integrate(0, Pose::Identity(), cells);
  return map;
}

/// The frame's camera-frame cells, seen from the true pose.
std::vector<Planecell> frame_cells(const Pose& T_world_cam_true, bool ground_only) {
  const auto world = test::street_cells(1.0f, ground_only);
  return map::to_world(world, T_world_cam_true.inverse());
}

Pose make_pose(const Eigen::Vector3d& rotation_vector, const Eigen::Vector3d& t) {
  Pose p = Pose::Identity();
  if (rotation_vector.norm() > 0)
    p.linear() = Eigen::AngleAxisd(rotation_vector.norm(), rotation_vector.normalized()).toRotationMatrix();
  p.translation() = t;
  return p;
}

double rotation_error_deg(const Pose& a, const Pose& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() / kDeg;
}

RefineConfig enabled_config() {
  RefineConfig c;
  c.enabled = true;
  return c;
}

// The camera 6 m down the road, slightly yawed; the odometry is off by ~0.2 m and 0.3° (inside the
// association gates: RMS plane distance ≤ 0.3 m).
const StereoCamera kCamera;  // KITTI-like: fx 721.5 px, baseline 0.54 m

const Pose kTrue = make_pose(Eigen::Vector3d(0, 2 * kDeg, 0), Eigen::Vector3d(0.3, 0.0, 6.0));
const Pose kPerturbed =
    make_pose(Eigen::Vector3d(0.2, -0.3, 0.25).normalized() * 0.3 * kDeg, Eigen::Vector3d(0.1, -0.08, 0.15)) *
    kTrue;

TEST(ApplyCorrection, RotatesAboutTheCameraCentreThenTranslates) {
  const Pose input = make_pose(Eigen::Vector3d::Zero(), Eigen::Vector3d(10, 0, 0));
  Vector6 delta;
  delta << 0, 0, std::numbers::pi / 2, 1, 2, 3;  // 90° about world z, then (1, 2, 3)
  const Pose out = apply_correction(input, delta);
  // Camera centre moves by τ only: (11, 2, 3); camera x axis (1, 0, 0) turns to (0, 1, 0).
  EXPECT_TRUE(out.translation().isApprox(Eigen::Vector3d(11, 2, 3), 1e-12));
  EXPECT_TRUE((out.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
  // A camera point 1 m ahead along x: world (11, 0, 0) before → c + R(ω)(1, 0, 0) + τ = (11, 3, 3).
  EXPECT_TRUE((out * Eigen::Vector3d(1, 0, 0)).isApprox(Eigen::Vector3d(11, 3, 3), 1e-12));
}

TEST(PoseRefinement, RecoversTheTruePoseFromAPerturbedOne) {
  const map::GlobalMap map = make_map(false);
  const auto cells = frame_cells(kTrue, false);
  ASSERT_GT((kPerturbed.translation() - kTrue.translation()).norm(), 0.15);
  const PoseRefinement r = refine_pose(cells, kPerturbed, map, kCamera, enabled_config());
  ASSERT_EQ(r.status, RefineStatus::kRefined);
  EXPECT_EQ(r.observable_directions, 6);
  EXPECT_GT(r.associations, cells.size() / 2);
  EXPECT_LT((r.refined.translation() - kTrue.translation()).norm(), 0.005);
  EXPECT_LT(rotation_error_deg(r.refined, kTrue), 0.01);
  EXPECT_LT(r.final_cost, 1e-3 * r.initial_cost);
  // The reported correction is what takes the input to the refined pose.
  EXPECT_TRUE(apply_correction(kPerturbed, r.correction).isApprox(r.refined, 1e-9));
}

TEST(SurfacePlanes, FusedReObservationsCountAsInformationOfTheSurfacePlane) {
  // The same road seen twice from the same pose: the second view is fused into the surfaces, not
  // stored, so the stored cells are the same but every surface holds two observations. The plane's
  // information W doubles and M⁻¹ halves, so σ_S(X)² = 1/W + aᵀM⁻¹a halves at every X.
  MapConfig map_config;
  map_config.max_range_m = 40.0;
  map::GlobalMap once(map_config), twice(map_config);
  const auto cells = test::street_cells(0.0f, true);
  once.integrate(0, Pose::Identity(), cells);
  twice.integrate(0, Pose::Identity(), cells);
  twice.integrate(1, Pose::Identity(), cells);
  ASSERT_EQ(twice.cells().size(), once.cells().size());
  map::Aabb region;
  region.extend(Eigen::Vector3d(-6, 0, 2));
  region.extend(Eigen::Vector3d(6, 3, 21));
  const RefineConfig config = enabled_config();
  const SurfacePlanes a = surface_planes_near(once, region, config);
  const SurfacePlanes b = surface_planes_near(twice, region, config);
  ASSERT_FALSE(a.planes.empty());
  ASSERT_EQ(a.planes.size(), b.planes.size());
  for (const auto& [id, plane] : a.planes) {
    ASSERT_TRUE(b.planes.contains(id));
    const map::Surface* s = twice.surface(id);
    ASSERT_NE(s, nullptr);
    const double factor = static_cast<double>(s->observations) / static_cast<double>(s->cells.size());
    ASSERT_NEAR(factor, 2.0, 1e-12);
    for (const Eigen::Vector3d& x : {plane.mean, Eigen::Vector3d(plane.mean + 3.0 * plane.u + 1.0 * plane.v)}) {
      const double single = plane.sigma_at(x), fused = b.planes.at(id).sigma_at(x);
      EXPECT_NEAR(fused * fused, single * single / 2.0, 1e-9 * single * single) << "surface " << id;
    }
  }
}

TEST(PoseRefinement, ExactPoseIsNotMadeWorse) {
  const map::GlobalMap map = make_map(false);
  const PoseRefinement r = refine_pose(frame_cells(kTrue, false), kTrue, map, kCamera, enabled_config());
  ASSERT_EQ(r.status, RefineStatus::kRefined);
  EXPECT_LT((r.refined.translation() - kTrue.translation()).norm(), 1e-4);
  EXPECT_LT(rotation_error_deg(r.refined, kTrue), 1e-4);
}

TEST(PoseRefinement, OutlierCellsAreDownWeightedByTheRobustLoss) {
  const map::GlobalMap map = make_map(false);
  auto cells = frame_cells(kTrue, false);
  // Ten cells 0.3 m off their plane (e.g. a moved object): still within the association gate.
  for (std::size_t i = 0; i < 10; ++i) {
    Planecell& c = cells[i * 7 % cells.size()];
    const Eigen::Vector3f shift = (0.3 * c.plane.normal).cast<float>();
    for (auto& v : c.vertices_m) v += shift;
    c.plane.offset -= 0.3;
  }
  // The σ gate would leave these cells out altogether; opened here so the loss has to cope.
  RefineConfig robust = enabled_config();
  robust.gate_sigmas = 1e3;
  const PoseRefinement r = refine_pose(cells, kPerturbed, map, kCamera, robust);
  ASSERT_EQ(r.status, RefineStatus::kRefined);
  EXPECT_LT((r.refined.translation() - kTrue.translation()).norm(), 0.02);
  EXPECT_LT(rotation_error_deg(r.refined, kTrue), 0.1);
  // Without the robust loss the outliers pull the pose further off.
  RefineConfig plain = robust;
  plain.loss = "none";
  const PoseRefinement q = refine_pose(cells, kPerturbed, map, kCamera, plain);
  ASSERT_EQ(q.status, RefineStatus::kRefined);
  EXPECT_LT(rotation_error_deg(r.refined, kTrue), 0.5 * rotation_error_deg(q.refined, kTrue));
}

TEST(PoseRefinement, GroundOnlyKeepsUnobservableDirectionsAtTheInput) {
  const map::GlobalMap map = make_map(true);
  const auto cells = frame_cells(kTrue, true);
  // Odometry off in every direction: along the road (z), sideways (x), height (y), yaw, pitch, roll.
  const Pose input = make_pose(Eigen::Vector3d(0.3, 0.5, -0.2) * kDeg, Eigen::Vector3d(0.2, 0.08, 0.4)) * kTrue;
  const PoseRefinement r = refine_pose(cells, input, map, kCamera, enabled_config());
  ASSERT_EQ(r.status, RefineStatus::kRefined);
  // Only the road plane: height, pitch and roll are observable; x, z translation and yaw are not.
  // (The map's road normal is fitted to float vertices, so the null space is axis-aligned only to
  // ~1e-8: the kept components are zero to 1e-6, not to round-off.)
  EXPECT_EQ(r.observable_directions, 3);
  EXPECT_NEAR(r.correction[1], 0.0, 1e-6);  // yaw (about the world y axis)
  EXPECT_NEAR(r.correction[3], 0.0, 1e-6);  // along x
  EXPECT_NEAR(r.correction[5], 0.0, 1e-6);  // along the road
  EXPECT_NEAR(r.refined.translation().x(), input.translation().x(), 1e-6);
  EXPECT_NEAR(r.refined.translation().z(), input.translation().z(), 1e-6);
  // The observable part is recovered: camera height and the road normal seen from the camera.
  EXPECT_NEAR(r.refined.translation().y(), kTrue.translation().y(), 0.002);
  const Eigen::Vector3d up_cam_refined = r.refined.linear().transpose() * Eigen::Vector3d::UnitY();
  const Eigen::Vector3d up_cam_true = kTrue.linear().transpose() * Eigen::Vector3d::UnitY();
  EXPECT_LT(std::acos(std::min(1.0, up_cam_refined.dot(up_cam_true))) / kDeg, 0.01);
}

TEST(PoseRefinement, EmptyMapOrDisabledKeepsTheInputPose) {
  const map::GlobalMap empty;
  const auto cells = frame_cells(kTrue, false);
  const PoseRefinement none = refine_pose(cells, kPerturbed, empty, kCamera, enabled_config());
  EXPECT_EQ(none.status, RefineStatus::kTooFewAssociations);
  EXPECT_EQ(none.associations, 0u);
  EXPECT_TRUE(none.refined.isApprox(kPerturbed, 0.0));

  const map::GlobalMap map = make_map(false);
  const PoseRefinement off = refine_pose(cells, kPerturbed, map, kCamera, RefineConfig{});
  EXPECT_EQ(off.status, RefineStatus::kDisabled);
  EXPECT_TRUE(off.refined.isApprox(kPerturbed, 0.0));
}

TEST(PoseRefinement, CorrectionBeyondTheLimitIsRejected) {
  const map::GlobalMap map = make_map(false);
  RefineConfig config = enabled_config();
  config.max_correction_m = 0.05;  // the true correction is ~0.2 m
  const PoseRefinement r = refine_pose(frame_cells(kTrue, false), kPerturbed, map, kCamera, config);
  EXPECT_EQ(r.status, RefineStatus::kRejected);
  EXPECT_TRUE(r.refined.isApprox(kPerturbed, 0.0));
}

TEST(PoseRefinement, BadConfigAndPoseAreClearErrors) {
  const map::GlobalMap map;
  RefineConfig config = enabled_config();
  config.loss = "tukey";
  try {
    refine_pose({}, Pose::Identity(), map, kCamera, config);
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("refine.loss"), std::string::npos) << e.what();
  }
  config = enabled_config();
  config.degeneracy_ratio = 0.0;
  EXPECT_THROW(refine_pose({}, Pose::Identity(), map, kCamera, config), ConfigError);
  config = enabled_config();
  config.drift_gain = 1.5;
  try {
    refine_pose({}, Pose::Identity(), map, kCamera, config);
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("refine.drift_gain"), std::string::npos) << e.what();
  }
  Pose bad = Pose::Identity();
  bad.translation().x() = std::nan("");
  EXPECT_THROW(refine_pose({}, bad, map, kCamera, enabled_config()), InputError);
}

}  // namespace
}  // namespace planecell::refine
