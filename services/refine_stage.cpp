#include "services/refine_stage.hpp"

#include <sstream>

#include "io/kitti_odometry.hpp"
#include "mapping/refine/pose_refinement.hpp"

namespace planecell::services {
namespace {

nlohmann::json pose_json(const Pose& pose) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) rows.push_back(pose.matrix()(r, c));
  return rows;  // row-major 3×4 [R | t], as in KITTI pose files
}

nlohmann::json ate_json(const eval::AteResult& a) {
  return {{"rmse_m", a.rmse_m}, {"mean_m", a.mean_m}, {"max_m", a.max_m}, {"poses", a.poses}};
}

nlohmann::json rpe_json(const eval::RpeResult& r) {
  return {{"pairs", r.pairs},
          {"translation_rmse_m", r.translation_rmse_m},
          {"translation_percent", r.translation_percent},
          {"rotation_deg_per_m", r.rotation_deg_per_m},
          {"rotation_rmse_deg", r.rotation_rmse_deg}};
}

}  // namespace

RefineStage::RefineStage(const RefineConfig& config, bool keep_records)
    : config_(config), keep_records_(keep_records) {
  refine::validate(config_);
}

Pose RefineStage::refine(std::uint64_t frame_id, std::span<const Planecell> cells_cam,
                         const Pose& input, const map::GlobalMap& map, const StereoCamera& camera) {
  FrameRefinement record;
  record.frame_id = frame_id;
  record.input = input;
  // Odometry increment since the previous frame, with the estimated drift removed (Δ·exp(b·s)).
  const Pose increment = frames_.empty() ? Pose::Identity() : Pose(frames_.back().input.inverse() * input);
  const double step_m = increment.translation().norm();
  const Pose drift_removed = refine::apply_correction(Pose::Identity(), drift_ * step_m);
  record.predicted = frames_.empty() ? input : Pose(frames_.back().refined * increment * drift_removed);
  // Re-orthonormalise: the product of three poses carries round-off.
  record.predicted.linear() =
      Eigen::Quaterniond(record.predicted.linear()).normalized().toRotationMatrix();
  const refine::PoseRefinement result =
      refine::refine_pose(cells_cam, record.predicted, map, camera, config_, step_m);
  record.refined = result.refined;
  record.status = refine::to_string(result.status);
  record.correction = result.status == refine::RefineStatus::kRefined
                          ? result.correction
                          : Eigen::Matrix<double, 6, 1>::Zero();
  record.associations = result.associations;
  record.observable_directions = result.observable_directions;
  record.iterations = result.iterations;
  record.information_eigenvalues = result.information_eigenvalues;
  if (result.status == refine::RefineStatus::kRefined && config_.drift_gain > 0.0 &&
      step_m >= config_.min_drift_step_m) {
    // ε = (R_predᵀ ω, R_predᵀ τ): the correction in the predicted camera frame; b += gain·ε/s.
    const Eigen::Matrix3d to_camera = record.predicted.linear().transpose();
    const Eigen::Vector3d omega = to_camera * result.correction.head<3>().eval();
    const Eigen::Vector3d tau = to_camera * result.correction.tail<3>().eval();
    drift_.head<3>() += (config_.drift_gain / step_m) * omega;
    drift_.tail<3>() += (config_.drift_gain / step_m) * tau;
    const auto clamp_norm = [](auto&& v, double max_norm) {
      if (v.norm() > max_norm) v *= max_norm / v.norm();
    };
    clamp_norm(drift_.head<3>(), config_.max_drift_deg_per_m * kDegToRad);
    clamp_norm(drift_.tail<3>(), config_.max_drift_per_m);
  }
  record.drift = drift_;
  if (!keep_records_) frames_.clear();
  frames_.push_back(record);
  return record.refined;
}

RefineSummary RefineStage::summary(const std::vector<Pose>& ground_truth,
                                   std::optional<std::filesystem::path> ground_truth_file) const {
  RefineSummary out;
  out.frames = frames_;
  for (const auto& f : frames_) out.refined_frames += f.status == "refined" ? 1 : 0;
  bool covered = !frames_.empty();
  for (const auto& f : frames_) covered = covered && f.frame_id < ground_truth.size();
  if (!covered) return out;
  std::vector<Pose> gt, input, refined;
  for (const auto& f : frames_) {
    gt.push_back(ground_truth[f.frame_id]);
    input.push_back(f.input);
    refined.push_back(f.refined);
  }
  TrajectoryComparison cmp;
  cmp.input_ate = eval::absolute_trajectory_error(input, gt);
  cmp.refined_ate = eval::absolute_trajectory_error(refined, gt);
  const auto anchored = [&gt](std::vector<Pose> poses) {
    const Pose anchor = gt.front() * poses.front().inverse();
    for (Pose& pose : poses) pose = anchor * pose;
    return eval::absolute_trajectory_error(poses, gt, false);
  };
  cmp.input_ate_anchored = anchored(input);
  cmp.refined_ate_anchored = anchored(refined);
  cmp.input_rpe = eval::relative_pose_error(input, gt);
  cmp.refined_rpe = eval::relative_pose_error(refined, gt);
  out.trajectory = cmp;
  out.ground_truth_file = std::move(ground_truth_file);
  return out;
}

std::optional<std::pair<std::filesystem::path, std::vector<Pose>>> sequence_ground_truth(
    const std::filesystem::path& sequence_dir) {
  const auto file = io::find_kitti_poses_file(sequence_dir);
  if (!file) return std::nullopt;
  const io::KittiOdometrySequence own = io::open_kitti_odometry(sequence_dir, *file);
  return std::make_pair(*file, own.poses);
}

nlohmann::json to_json(const RefineSummary& s) {
  nlohmann::json frames = nlohmann::json::array();
  for (const auto& f : s.frames) {
    frames.push_back({{"frame", f.frame_id},
                      {"status", f.status},
                      {"rotation_deg", f.correction.head<3>().norm() * kRadToDeg},
                      {"translation_m", f.correction.tail<3>().norm()},
                      {"correction", std::vector<double>(f.correction.data(), f.correction.data() + 6)},
                      {"associations", f.associations},
                      {"observable_directions", f.observable_directions},
                      {"iterations", f.iterations},
                      {"information_eigenvalues",
                       std::vector<double>(f.information_eigenvalues.data(), f.information_eigenvalues.data() + 6)},
                      {"drift", std::vector<double>(f.drift.data(), f.drift.data() + 6)},
                      {"input_pose", pose_json(f.input)},
                      {"refined_pose", pose_json(f.refined)}});
  }
  nlohmann::json out = {{"frames", frames.size()}, {"refined_frames", s.refined_frames}, {"per_frame", frames}};
  if (s.trajectory) {
    out["ground_truth"] = s.ground_truth_file ? s.ground_truth_file->string() : std::string();
    out["input"] = {{"ate", ate_json(s.trajectory->input_ate)},
                    {"ate_anchored", ate_json(s.trajectory->input_ate_anchored)},
                    {"rpe", rpe_json(s.trajectory->input_rpe)}};
    out["refined"] = {{"ate", ate_json(s.trajectory->refined_ate)},
                      {"ate_anchored", ate_json(s.trajectory->refined_ate_anchored)},
                      {"rpe", rpe_json(s.trajectory->refined_rpe)}};
  }
  return out;
}

std::string summary_text(const RefineSummary& s) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(3);
  double max_t = 0.0, max_r = 0.0;
  for (const auto& f : s.frames) {
    max_t = std::max(max_t, f.correction.tail<3>().norm());
    max_r = std::max(max_r, f.correction.head<3>().norm() * kRadToDeg);
  }
  out << "  pose refinement: " << s.refined_frames << "/" << s.frames.size()
      << " frames refined, max correction " << max_t << " m / " << max_r << " deg\n";
  if (s.trajectory) {
    const auto& t = *s.trajectory;
    out << "  trajectory vs ground truth: ATE input " << t.input_ate.rmse_m << " m, refined "
        << t.refined_ate.rmse_m << " m; RPE input " << t.input_rpe.translation_percent << " % / "
        << t.input_rpe.rotation_deg_per_m << " deg/m, refined " << t.refined_rpe.translation_percent
        << " % / " << t.refined_rpe.rotation_deg_per_m << " deg/m; per frame input "
        << t.input_rpe.translation_rmse_m << " m / " << t.input_rpe.rotation_rmse_deg << " deg, refined "
        << t.refined_rpe.translation_rmse_m << " m / " << t.refined_rpe.rotation_rmse_deg << " deg\n"
        << "  anchored at the first pose (no best-fit alignment): ATE input " << t.input_ate_anchored.rmse_m
        << " m, refined " << t.refined_ate_anchored.rmse_m << " m\n";
  }
  return out.str();
}

}  // namespace planecell::services
