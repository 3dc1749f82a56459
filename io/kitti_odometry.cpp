/// KITTI odometry readers: calib.txt, poses, times.txt and the sequence folder layout.
/// (The write_* functions live in kitti_odometry_writer.cpp.)
#include "io/kitti_odometry.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <future>
#include <sstream>
#include <string_view>

#include "core/error.hpp"
#include "io/image_io.hpp"
#include "io/paths.hpp"

namespace planecell::io {
namespace {

namespace fs = std::filesystem;

/// Splits a line into numbers; nullopt when a token is not a complete number.
std::optional<std::vector<double>> parse_numbers(std::string_view text) {
  std::vector<double> values;
  std::istringstream in{std::string(text)};
  std::string token;
  while (in >> token) {
    char* end = nullptr;
    const double value = std::strtod(token.c_str(), &end);
    if (end != token.c_str() + token.size()) return std::nullopt;
    values.push_back(value);
  }
  return values;
}

bool is_blank(std::string_view line) {
  return line.find_first_not_of(" \t\r\n") == std::string_view::npos;
}

/// All lines of a text file; throws InputError naming `what` and the path when unreadable.
std::vector<std::string> read_lines(const fs::path& path, const std::string& what) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))
    throw InputError(what + " '" + path.string() + "': file not found");
  std::ifstream in(path);
  if (!in) throw InputError(what + " '" + path.string() + "': cannot be opened");
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  // Trailing blank lines are harmless; blank lines inside would shift frame indices.
  while (!lines.empty() && is_blank(lines.back())) lines.pop_back();
  return lines;
}

/// Image files (png/jpg/ppm/pgm) of a folder, sorted by name.
std::vector<fs::path> list_images(const fs::path& dir) {
  std::vector<fs::path> images;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    if (!entry.is_regular_file()) continue;
    const std::string ext = lower_extension(entry.path());
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".ppm" || ext == ".pgm")
      images.push_back(entry.path());
  }
  if (ec) throw InputError("folder '" + dir.string() + "': cannot be listed: " + ec.message());
  std::sort(images.begin(), images.end());
  return images;
}

/// Name of a sequence folder, robust to a trailing slash ("seq/" → "seq").
std::string sequence_name(const fs::path& sequence_dir) {
  fs::path p = sequence_dir.lexically_normal();
  if (p.filename().empty()) p = p.parent_path();
  return p.filename().string();
}

/// Translation t of P = K [I | t] (camera i relative to cam0, rectified frame):
///   P[11] = t_z,  P[7] = fy·t_y + cy·t_z,  P[3] = fx·t_x + cx·t_z.
Eigen::Vector3d projection_translation(const std::array<double, 12>& p) {
  const double tz = p[11];
  return {(p[3] - p[2] * tz) / p[0], (p[7] - p[6] * tz) / p[5], tz};
}

}  // namespace

KittiCalibration read_kitti_calibration(const fs::path& path) {
  const auto lines = read_lines(path, "KITTI calibration");
  KittiCalibration calib;
  std::array<int, 4> line_of{0, 0, 0, 0};
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& line = lines[i];
    const std::string where =
        "KITTI calibration '" + path.string() + "' line " + std::to_string(i + 1);
    const auto colon = line.find(':');
    if (colon == std::string::npos) {
      if (is_blank(line)) continue;
      throw InputError(where + ": expected 'NAME: numbers', got '" + line.substr(0, 40) + "'");
    }
    std::string key = line.substr(0, colon);
    key.erase(0, key.find_first_not_of(" \t"));
    key.erase(key.find_last_not_of(" \t") + 1);
    // KITTI raw / stereo 2015 calib_cam_to_cam.txt names the rectified projections P_rect_0N.
    if (key.size() == 9 && key.compare(0, 8, "P_rect_0") == 0) key = std::string("P") + key[8];
    if (key.size() != 2 || key[0] != 'P' || key[1] < '0' || key[1] > '3') continue;  // Tr, ...
    const int index = key[1] - '0';
    if (line_of[index] != 0)
      throw InputError(where + ": " + key + " appears twice (first on line " +
                       std::to_string(line_of[index]) + ")");
    const auto numbers = parse_numbers(std::string_view(line).substr(colon + 1));
    if (!numbers) throw InputError(where + ": " + key + " holds a value that is not a number");
    if (numbers->size() != 12)
      throw InputError(where + ": " + key + " must hold 12 numbers (3×4 matrix), got " +
                       std::to_string(numbers->size()));
    for (int k = 0; k < 12; ++k) {
      if (!std::isfinite((*numbers)[k]))
        throw InputError(where + ": " + key + " holds a non-finite value");
      calib.projection[index][k] = (*numbers)[k];
    }
    line_of[index] = static_cast<int>(i + 1);
  }
  for (int k = 0; k < 4; ++k)
    if (line_of[k] == 0)
      throw InputError("KITTI calibration '" + path.string() + "': missing line P" +
                       std::to_string(k) + ":");
  return calib;
}

StereoCamera stereo_camera_from_kitti(const KittiCalibration& calib, int left_index, int width,
                                      int height) {
  if (left_index != 0 && left_index != 2)
    throw InputError("KITTI calibration: left camera must be 0 (gray pair) or 2 (colour pair), got " +
                     std::to_string(left_index));
  const auto& left = calib.projection[left_index];
  const auto& right = calib.projection[left_index + 1];
  const std::string pair =
      "KITTI calibration P" + std::to_string(left_index) + "/P" + std::to_string(left_index + 1);
  for (const auto* p : {&left, &right}) {
    const auto& m = *p;
    if (!(m[0] > 0.0) || !(m[5] > 0.0))
      throw InputError(pair + ": focal lengths P[0], P[5] must be > 0");
    if (m[1] != 0.0 || m[4] != 0.0 || m[8] != 0.0 || m[9] != 0.0 || m[10] != 1.0)
      throw InputError(pair + ": not a rectified projection matrix [fx 0 cx tx; 0 fy cy ty; 0 0 1 tz]");
  }
  auto differs = [](double a, double b) { return std::abs(a - b) > 1e-6 * std::max(1.0, std::abs(a)); };
  if (differs(left[0], right[0]) || differs(left[5], right[5]) || differs(left[2], right[2]) ||
      differs(left[6], right[6]))
    throw InputError(pair + ": left and right intrinsics (fx, fy, cx, cy) differ: not a rectified pair");
  if (width < 0 || height < 0) throw InputError(pair + ": image size must be >= 0");
  StereoCamera camera;
  camera.fx = left[0];
  camera.fy = left[5];
  camera.cx = left[2];
  camera.cy = left[6];
  /// Baseline B = (P_left[3] − P_right[3]) / fx  (P[3] = −fx·t_x of each camera).
  camera.baseline_m = (left[3] - right[3]) / left[0];
  if (!(camera.baseline_m > 0.0))
    throw InputError(pair + ": baseline (P_left[3] - P_right[3]) / fx = " +
                     std::to_string(camera.baseline_m) +
                     " m must be > 0 (right camera to the right of the left one; rows swapped?)");
  camera.width = width;
  camera.height = height;
  return camera;
}

std::vector<Pose> read_kitti_poses(const fs::path& path) {
  const auto lines = read_lines(path, "KITTI poses");
  std::vector<Pose> poses;
  poses.reserve(lines.size());
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string where = "KITTI poses '" + path.string() + "' line " + std::to_string(i + 1);
    const auto numbers = parse_numbers(lines[i]);
    if (!numbers) throw InputError(where + ": holds a value that is not a number");
    if (numbers->size() != 12)
      throw InputError(where + ": expected 12 numbers (row-major 3×4 [R|t]), got " +
                       std::to_string(numbers->size()));
    poses.push_back(pose_from_3x4(numbers->data(), where));
  }
  return poses;
}

std::vector<double> read_kitti_times(const fs::path& path) {
  const auto lines = read_lines(path, "KITTI times");
  std::vector<double> times;
  times.reserve(lines.size());
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string where = "KITTI times '" + path.string() + "' line " + std::to_string(i + 1);
    const auto numbers = parse_numbers(lines[i]);
    if (!numbers || numbers->size() != 1)
      throw InputError(where + ": expected one time in seconds, got '" + lines[i].substr(0, 40) + "'");
    const double t = numbers->front();
    if (!std::isfinite(t)) throw InputError(where + ": time is not finite");
    if (!times.empty() && t < times.back())
      throw InputError(where + ": time " + std::to_string(t) + " s goes backwards (previous " +
                       std::to_string(times.back()) + " s)");
    times.push_back(t);
  }
  return times;
}

std::optional<fs::path> find_kitti_poses_file(const fs::path& sequence_dir) {
  std::error_code ec;
  const std::string name = sequence_name(sequence_dir);
  const fs::path local = sequence_dir / "poses";
  if (fs::is_regular_file(local / (name + ".txt"), ec)) return local / (name + ".txt");
  if (fs::is_directory(local, ec)) {
    if (fs::is_regular_file(local / "00.txt", ec)) return local / "00.txt";
    std::vector<fs::path> candidates;
    for (const auto& entry : fs::directory_iterator(local, ec))
      if (entry.is_regular_file() && entry.path().extension() == ".txt")
        candidates.push_back(entry.path());
    if (candidates.size() == 1) return candidates.front();
    if (candidates.size() > 1)
      throw InputError("KITTI sequence '" + sequence_dir.string() + "': " +
                       std::to_string(candidates.size()) + " pose files in '" + local.string() +
                       "' and none named " + name + ".txt or 00.txt; pass the poses file explicitly");
  }
  // Official layout: dataset/sequences/NN with dataset/poses/NN.txt.
  const fs::path official =
      sequence_dir.lexically_normal() / ".." / ".." / "poses" / (name + ".txt");
  if (fs::is_regular_file(official, ec)) return official.lexically_normal();
  return std::nullopt;
}

KittiOdometrySequence open_kitti_odometry(const fs::path& sequence_dir,
                                          const std::optional<fs::path>& poses_file) {
  std::error_code ec;
  const std::string where = "KITTI sequence '" + sequence_dir.string() + "'";
  if (!fs::is_directory(sequence_dir, ec)) throw InputError(where + ": folder not found");

  KittiOdometrySequence seq;
  seq.root = sequence_dir;
  int left_index = -1;
  if (fs::is_directory(sequence_dir / "image_2", ec) && fs::is_directory(sequence_dir / "image_3", ec))
    left_index = 2;
  else if (fs::is_directory(sequence_dir / "image_0", ec) &&
           fs::is_directory(sequence_dir / "image_1", ec))
    left_index = 0;
  else
    throw InputError(where + ": no stereo pair found (expected image_2/ + image_3/ or "
                     "image_0/ + image_1/)");
  seq.left_dir = sequence_dir / ("image_" + std::to_string(left_index));
  seq.right_dir = sequence_dir / ("image_" + std::to_string(left_index + 1));
  seq.left_images = list_images(seq.left_dir);
  if (seq.left_images.empty())
    throw InputError(where + ": no images in '" + seq.left_dir.string() + "'");
  const auto right_listed = list_images(seq.right_dir);
  for (const auto& left : seq.left_images) {
    const fs::path right = seq.right_dir / left.filename();
    if (!fs::is_regular_file(right, ec))
      throw InputError(where + ": right image '" + right.string() + "' missing (left '" +
                       left.string() + "' exists)");
    seq.right_images.push_back(right);
  }
  if (right_listed.size() != seq.left_images.size())
    throw InputError(where + ": " + std::to_string(seq.left_images.size()) + " left but " +
                     std::to_string(right_listed.size()) + " right images");

  const cv::Mat first = read_image(seq.left_images.front(), false);
  const KittiCalibration calib = read_kitti_calibration(sequence_dir / "calib.txt");
  seq.camera = stereo_camera_from_kitti(calib, left_index, first.cols, first.rows);
  /// The used left camera i relative to cam0: P_i = K [I | t_i] maps cam0 points X_0 to
  /// X_i = X_0 + t_i, so T_cam0_cami = [I | −t_i] (cam2 sits ≈ 6 cm left of cam0 in KITTI).
  seq.T_cam0_left = Pose::Identity();
  seq.T_cam0_left.translation() = -projection_translation(calib.projection[left_index]);

  const fs::path times_path = sequence_dir / "times.txt";
  if (fs::is_regular_file(times_path, ec)) {
    seq.times_s = read_kitti_times(times_path);
    if (seq.times_s.size() != seq.size())
      throw InputError(where + ": times.txt has " + std::to_string(seq.times_s.size()) +
                       " rows but there are " + std::to_string(seq.size()) + " frames");
  }

  std::optional<fs::path> pose_path = poses_file;
  if (pose_path) {
    if (!fs::is_regular_file(*pose_path, ec))
      throw InputError(where + ": poses file '" + pose_path->string() + "' not found");
  } else {
    pose_path = find_kitti_poses_file(sequence_dir);
  }
  if (pose_path) {
    const auto cam0_poses = read_kitti_poses(*pose_path);
    if (cam0_poses.size() != seq.size())
      throw InputError(where + ": poses file '" + pose_path->string() + "' has " +
                       std::to_string(cam0_poses.size()) + " poses but there are " +
                       std::to_string(seq.size()) + " frames");
    seq.poses.reserve(cam0_poses.size());
    /// T_world_left = T_world_cam0 · T_cam0_left.
    for (const auto& pose : cam0_poses) seq.poses.push_back(pose * seq.T_cam0_left);
  }
  return seq;
}

void check_frame_size(const KittiOdometrySequence& sequence, const std::filesystem::path& image, int width,
                      int height) {
  if (sequence.camera.width > 0 && (width != sequence.camera.width || height != sequence.camera.height))
    throw InputError("KITTI frame '" + image.string() + "': size " + std::to_string(width) + "x" +
                     std::to_string(height) + " differs from the sequence's " +
                     std::to_string(sequence.camera.width) + "x" + std::to_string(sequence.camera.height));
}

StereoFrame load_kitti_frame(const KittiOdometrySequence& sequence, std::size_t index) {
  if (index >= sequence.size())
    throw InputError("KITTI sequence '" + sequence.root.string() + "': frame " +
                     std::to_string(index) + " out of range (" + std::to_string(sequence.size()) +
                     " frames)");
  StereoFrame frame;
  frame.frame_id = index;
  // The two decodes are independent: the right image decodes on a second thread meanwhile, which
  // halves the load latency when a core is free (PNG decoding is ~11 ms per 1242×375 image).
  auto right = std::async(std::launch::async,
                          [&path = sequence.right_images[index]] { return read_image(path, true); });
  frame.left = read_image(sequence.left_images[index], true);
  frame.right = right.get();
  if (frame.left.size() != frame.right.size())
    throw InputError("KITTI frame '" + sequence.right_images[index].string() + "': size " +
                     std::to_string(frame.right.cols) + "x" + std::to_string(frame.right.rows) +
                     " differs from the left image " + std::to_string(frame.left.cols) + "x" +
                     std::to_string(frame.left.rows));
  check_frame_size(sequence, sequence.left_images[index], frame.left.cols, frame.left.rows);
  frame.camera = sequence.camera;
  if (!sequence.times_s.empty()) frame.timestamp_s = sequence.times_s[index];
  if (!sequence.poses.empty()) frame.pose = sequence.poses[index];
  return frame;
}

}  // namespace planecell::io
