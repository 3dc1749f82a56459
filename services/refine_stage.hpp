#pragma once
/// The pose-refinement stage of replay (issue 9): predicts each frame's pose from the odometry
/// increment and the previous refined pose, refines it against the global map
/// (refine::refine_pose), records input and refined poses, and summarises corrections and the
/// trajectory error of input vs refined poses against ground truth.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/config/refine_config.hpp"
#include "core/planecell.hpp"
#include "core/pose.hpp"
#include "core/stereo_camera.hpp"
#include "mapping/map/global_map.hpp"
#include "services/eval/trajectory_metrics.hpp"

namespace planecell::services {

/// One frame's refinement.
struct FrameRefinement {
  std::uint64_t frame_id = 0;
  std::string status;  ///< refine::to_string(RefineStatus)
  Pose input = Pose::Identity();      ///< the pose file's pose (odometry)
  Pose predicted = Pose::Identity();  ///< refined_prev · (input_prev⁻¹ · input) · exp(b·s) (what was refined)
  Pose refined = Pose::Identity();    ///< what the map and store recorded
  Eigen::Matrix<double, 6, 1> correction = Eigen::Matrix<double, 6, 1>::Zero();  ///< (ω rad, τ m) on predicted
  std::size_t associations = 0;
  int observable_directions = 0;
  int iterations = 0;
  Eigen::Matrix<double, 6, 1> information_eigenvalues = Eigen::Matrix<double, 6, 1>::Zero();
  /// The odometry drift estimate after this frame (rad/m ×3, m/m ×3, camera frame; see
  /// RefineConfig::drift_gain), used for the next prediction.
  Eigen::Matrix<double, 6, 1> drift = Eigen::Matrix<double, 6, 1>::Zero();
};

/// Input vs refined trajectory against ground truth (frames processed in this run).
struct TrajectoryComparison {
  eval::AteResult input_ate, refined_ate;
  /// The same without a best-fit alignment: each trajectory is anchored at its first pose
  /// (A = G_first · P_first⁻¹, as odometry benchmarks do), so a steady climb or a scale error,
  /// which the rigid alignment partly rotates away, counts in full.
  eval::AteResult input_ate_anchored, refined_ate_anchored;
  eval::RpeResult input_rpe, refined_rpe;  ///< frame delta 1
};

struct RefineSummary {
  std::vector<FrameRefinement> frames;
  std::size_t refined_frames = 0;  ///< status "refined"
  std::optional<std::filesystem::path> ground_truth_file;
  std::optional<TrajectoryComparison> trajectory;  ///< when ground truth exists
};

class RefineStage {
 public:
  /// Validates the config (ConfigError). With `keep_records` every frame's record is kept for
  /// summary() (replay's report); without (the daemon, which runs indefinitely), only the last
  /// one, which the next prediction needs.
  explicit RefineStage(const RefineConfig& config, bool keep_records = true);

  /// Refines frame `frame_id` seen with odometry pose `input` (cells in the camera frame) and
  /// returns the pose to transform, merge and store the frame with. Prediction: with the previous
  /// processed frame's input P and refined Q, the pose refined is Q·Δ·exp(b·s), Δ = P⁻¹·input
  /// the odometry increment (length s) applied to the corrected pose and exp(b·s) = [R(ω_b s) |
  /// τ_b s] the estimated drift removed (b = 0 unless RefineConfig::drift_gain > 0; b is updated
  /// from each refined frame's correction); the first frame uses `input`.
  Pose refine(std::uint64_t frame_id, std::span<const Planecell> cells_cam, const Pose& input,
              const map::GlobalMap& map, const StereoCamera& camera);

  /// Corrections per frame and, when `ground_truth` (indexed by frame id) covers the frames,
  /// ATE/RPE of input and refined poses.
  RefineSummary summary(const std::vector<Pose>& ground_truth,
                        std::optional<std::filesystem::path> ground_truth_file) const;

 private:
  RefineConfig config_;
  bool keep_records_ = true;
  std::vector<FrameRefinement> frames_;  ///< every record (keep_records), else at most the last
  Eigen::Matrix<double, 6, 1> drift_ = Eigen::Matrix<double, 6, 1>::Zero();  ///< b, see RefineConfig
};

/// Ground truth for replay's trajectory metrics: the sequence's own pose file (found as
/// io::find_kitti_poses_file does, times the camera offset) when one exists. nullopt when the
/// sequence has none.
std::optional<std::pair<std::filesystem::path, std::vector<Pose>>> sequence_ground_truth(
    const std::filesystem::path& sequence_dir);

nlohmann::json to_json(const RefineSummary& summary);

/// One or two human-readable lines.
std::string summary_text(const RefineSummary& summary);

}  // namespace planecell::services
