/// EuRoC MAV reader: calibration, ground truth, stereo rectification.
#include "io/paths.hpp"
#include "io/euroc.hpp"

#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/error.hpp"
#include "io/image_io.hpp"

namespace planecell::io {
namespace {

namespace fs = std::filesystem;


std::string read_text(const fs::path& path, const std::string& what) {
  if (!is_file(path)) throw InputError(what + " '" + path.string() + "': file not found");
  std::ifstream in(path);
  if (!in) throw InputError(what + " '" + path.string() + "': cannot be opened");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// A list of `count` numbers under `key` of `node`; throws naming the file and key.
std::vector<double> numbers_of(const YAML::Node& node, const std::string& key, std::size_t count,
                               const std::string& where) {
  const YAML::Node value = node[key];
  if (!value) throw InputError(where + ": missing '" + key + "'");
  if (!value.IsSequence() || value.size() != count)
    throw InputError(where + ": '" + key + "' must be a list of " + std::to_string(count) +
                     " numbers");
  std::vector<double> out;
  try {
    for (const auto& v : value) out.push_back(v.as<double>());
  } catch (const YAML::Exception&) {
    throw InputError(where + ": '" + key + "' holds a value that is not a number");
  }
  for (double v : out)
    if (!std::isfinite(v)) throw InputError(where + ": '" + key + "' holds a non-finite value");
  return out;
}

/// Splits a line at commas and/or whitespace into numbers; nullopt on a non-number.
std::optional<std::vector<double>> parse_numbers(std::string line) {
  std::replace(line.begin(), line.end(), ',', ' ');
  std::istringstream in(line);
  std::vector<double> values;
  std::string token;
  while (in >> token) {
    char* end = nullptr;
    const double v = std::strtod(token.c_str(), &end);
    if (end != token.c_str() + token.size()) return std::nullopt;
    values.push_back(v);
  }
  return values;
}

/// Largest whole-second count whose nanoseconds (plus a fraction < 1 s) fit an int64:
/// ⌊(2⁶³ − 1) / 10⁹⌋ − 1 = 9 223 372 035 s (year 2262).
constexpr std::int64_t kMaxWholeSeconds = std::numeric_limits<std::int64_t>::max() / 1'000'000'000LL - 1;

/// Leading decimal seconds of `text` ("1403715273.26214 ...") as exact nanoseconds: a double
/// holds only ~16 digits, so the integer and fractional parts are read separately. Times beyond
/// ±kMaxWholeSeconds (no int64 nanosecond count) and unparsable tokens are InputErrors.
std::int64_t seconds_text_to_ns(const std::string& text, const std::string& where) {
  const std::string token = text.substr(0, text.find_first_of(" \t,"));
  const auto out_of_range = [&] {
    return InputError(where + ": time '" + token + "' s is outside ±" +
                      std::to_string(kMaxWholeSeconds) + " s");
  };
  const auto dot = token.find('.');
  const std::string whole = token.substr(0, dot);
  std::string fraction = dot == std::string::npos ? "" : token.substr(dot + 1);
  const bool plain = !whole.empty() && whole.size() <= 10 &&
                     std::all_of(whole.begin(), whole.end(), ::isdigit) &&
                     std::all_of(fraction.begin(), fraction.end(), ::isdigit);
  if (!plain) {  // exponent or sign: fall back to double precision
    char* end = nullptr;
    const double seconds = std::strtod(token.c_str(), &end);
    if (token.empty() || end != token.c_str() + token.size())
      throw InputError(where + ": bad time '" + token + "'");
    if (!(std::abs(seconds) <= static_cast<double>(kMaxWholeSeconds))) throw out_of_range();
    return static_cast<std::int64_t>(std::llround(seconds * 1e9));
  }
  if (fraction.size() > 9) fraction.resize(9);
  fraction.append(9 - fraction.size(), '0');
  const std::int64_t whole_seconds = std::stoll(whole);  // ≤ 10 digits: cannot overflow
  if (whole_seconds > kMaxWholeSeconds) throw out_of_range();
  return whole_seconds * 1'000'000'000LL + std::stoll(fraction);
}

/// Leading integer nanoseconds of a EuRoC csv row (image lists, ground truth:
/// "1403715273262142976,4,5,...") read exactly (a double would round it to a multiple of 256 ns);
/// a non-integer or out-of-int64 stamp is an InputError.
std::int64_t nanoseconds_text_to_ns(const std::string& text, const std::string& where) {
  const std::string token = text.substr(0, text.find_first_of(" \t,"));
  std::int64_t ns = 0;
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), ns);
  if (error == std::errc::result_out_of_range)
    throw InputError(where + ": timestamp '" + token + "' ns does not fit 64 bits");
  if (error != std::errc() || end != token.data() + token.size())
    throw InputError(where + ": timestamp '" + token + "' is not an integer nanosecond count");
  return ns;
}

struct CameraList {
  std::vector<std::int64_t> timestamps_ns;
  std::vector<fs::path> images;
  std::size_t missing = 0;  ///< rows whose image file does not exist (skipped)
};

/// data.csv: "#timestamp [ns],filename" then "t,name.png" per line; images in data/.
CameraList read_camera_list(const fs::path& cam_dir) {
  const fs::path csv = cam_dir / "data.csv";
  std::istringstream in(read_text(csv, "EuRoC image list"));
  CameraList out;
  int line_number = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    const auto comma = line.find(',');
    const std::string where =
        "EuRoC image list '" + csv.string() + "' line " + std::to_string(line_number);
    if (comma == std::string::npos) throw InputError(where + ": expected 'timestamp_ns,filename'");
    const std::int64_t t = nanoseconds_text_to_ns(line.substr(0, comma), where);
    std::string name = line.substr(comma + 1);
    name.erase(0, name.find_first_not_of(" \t"));
    name.erase(name.find_last_not_of(" \t") + 1);
    const fs::path image = cam_dir / "data" / name;
    if (!is_file(image)) {  // truncated copies (e.g. EuRoC "micro" subsets) list absent images
      ++out.missing;
      continue;
    }
    out.timestamps_ns.push_back(t);
    out.images.push_back(image);
  }
  return out;
}

cv::Mat to_cv(const Eigen::Matrix3d& m) {
  cv::Mat out(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out.at<double>(r, c) = m(r, c);
  return out;
}

std::optional<fs::path> find_groundtruth(const fs::path& mav0) {
  const fs::path csv = mav0 / "state_groundtruth_estimate0" / "data.csv";
  if (is_file(csv)) return csv;
  const fs::path dir = mav0.parent_path() / "groundtruth";
  if (!is_dir(dir)) return std::nullopt;
  std::vector<fs::path> candidates;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec))
    if (entry.is_regular_file() && entry.path().extension() == ".txt")
      candidates.push_back(entry.path());
  if (candidates.size() == 1) return candidates.front();
  if (candidates.size() > 1)
    throw InputError("EuRoC ground truth folder '" + dir.string() +
                     "': several *.txt files; pass the ground-truth file explicitly");
  return std::nullopt;
}

}  // namespace

EurocCameraCalibration read_euroc_camera(const fs::path& sensor_yaml) {
  const std::string where = "EuRoC sensor '" + sensor_yaml.string() + "'";
  std::string text = read_text(sensor_yaml, "EuRoC sensor");
  // OpenCV-style "%YAML:1.0" directive: yaml-cpp only accepts "%YAML 1.x"; drop the line.
  if (text.rfind("%YAML", 0) == 0) text.erase(0, text.find('\n') == std::string::npos
                                                      ? text.size()
                                                      : text.find('\n') + 1);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(where + ": not valid YAML (" + e.what() + ")");
  }
  if (!root.IsMap()) throw InputError(where + ": expected a mapping of key: value");
  // A text value, or "" when absent; InputError when it is a list or mapping.
  const auto text_of = [&](const char* key) -> std::string {
    const YAML::Node value = root[key];
    if (!value) return "";
    if (!value.IsScalar()) throw InputError(where + ": '" + key + "' must be a name");
    return value.Scalar();
  };
  if (root["camera_model"] && text_of("camera_model") != "pinhole")
    throw InputError(where + ": camera_model '" + text_of("camera_model") +
                     "' unsupported (pinhole only)");
  const std::string model = text_of("distortion_model");
  if (model != "radial-tangential" && model != "radtan")
    throw InputError(where + ": distortion_model '" + model +
                     "' unsupported (radial-tangential only)");
  EurocCameraCalibration calib;
  const auto intrinsics = numbers_of(root, "intrinsics", 4, where);
  if (!(intrinsics[0] > 0.0) || !(intrinsics[1] > 0.0))
    throw InputError(where + ": intrinsics fu, fv must be > 0");
  calib.K = (cv::Mat_<double>(3, 3) << intrinsics[0], 0, intrinsics[2], 0, intrinsics[1],
             intrinsics[3], 0, 0, 1);
  calib.distortion = cv::Mat(numbers_of(root, "distortion_coefficients", 4, where), true).reshape(1, 1);
  const auto resolution = numbers_of(root, "resolution", 2, where);
  // Checked as doubles first: casting an out-of-range double to int is undefined behaviour.
  if (!(resolution[0] >= 1.0 && resolution[1] >= 1.0 && resolution[0] <= 65535.0 &&
        resolution[1] <= 65535.0 && resolution[0] * resolution[1] <= kDefaultMaxImagePixels))
    throw InputError(where + ": resolution must be within [1, 65535] x [1, 65535] and at most " +
                     std::to_string(kDefaultMaxImagePixels) + " pixels");
  calib.width = static_cast<int>(resolution[0]);
  calib.height = static_cast<int>(resolution[1]);
  if (!root["T_BS"] || !root["T_BS"].IsMap()) throw InputError(where + ": missing 'T_BS' matrix");
  const auto t = numbers_of(root["T_BS"], "data", 16, where + " T_BS");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = t[r * 4 + c];
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9)
    throw InputError(where + ": T_BS last row must be [0 0 0 1]");
  calib.T_body_sensor.matrix() = m;
  validate_pose(calib.T_body_sensor, where + " T_BS", 1e-3);
  return calib;
}

std::vector<StampedPose> read_euroc_groundtruth(const fs::path& path) {
  std::istringstream in(read_text(path, "EuRoC ground truth"));
  const bool euroc_csv = path.extension() == ".csv";
  std::vector<StampedPose> out;
  int line_number = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_number;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const std::string where =
        "EuRoC ground truth '" + path.string() + "' line " + std::to_string(line_number);
    const auto v = parse_numbers(line);
    if (!v) throw InputError(where + ": holds a value that is not a number");
    if (v->size() < 8)
      throw InputError(where + ": expected at least 8 numbers (time, position, quaternion), got " +
                       std::to_string(v->size()));
    if (!euroc_csv && v->size() != 8)
      throw InputError(where + ": TUM format needs 8 numbers 't tx ty tz qx qy qz qw', got " +
                       std::to_string(v->size()));
    const auto& x = *v;
    StampedPose sample;
    Eigen::Quaterniond q;
    if (euroc_csv) {  // t[ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z, ...
      sample.timestamp_ns = nanoseconds_text_to_ns(line.substr(first), where);
      q = Eigen::Quaterniond(x[4], x[5], x[6], x[7]);
    } else {  // t[s], tx, ty, tz, qx, qy, qz, qw
      sample.timestamp_ns = seconds_text_to_ns(line.substr(first), where);
      q = Eigen::Quaterniond(x[7], x[4], x[5], x[6]);
    }
    for (int k = 0; k < 8; ++k)
      if (!std::isfinite(x[k])) throw InputError(where + ": non-finite value");
    if (q.norm() < 0.5 || q.norm() > 1.5)
      throw InputError(where + ": quaternion norm " + std::to_string(q.norm()) + " is not ≈ 1");
    sample.pose = Pose::Identity();
    sample.pose.linear() = q.normalized().toRotationMatrix();
    sample.pose.translation() = Eigen::Vector3d(x[1], x[2], x[3]);
    validate_pose(sample.pose, where);
    out.push_back(sample);
  }
  std::stable_sort(out.begin(), out.end(), [](const StampedPose& a, const StampedPose& b) {
    return a.timestamp_ns < b.timestamp_ns;
  });
  return out;
}

std::optional<Pose> nearest_pose(const std::vector<StampedPose>& trajectory,
                                 std::int64_t timestamp_ns, std::int64_t max_gap_ns) {
  if (trajectory.empty()) return std::nullopt;
  auto it = std::lower_bound(
      trajectory.begin(), trajectory.end(), timestamp_ns,
      [](const StampedPose& s, std::int64_t t) { return s.timestamp_ns < t; });
  const StampedPose* best = nullptr;
  std::int64_t best_gap = 0;
  for (auto candidate : {it, it == trajectory.begin() ? trajectory.end() : std::prev(it)}) {
    if (candidate == trajectory.end()) continue;
    const std::int64_t gap = std::abs(candidate->timestamp_ns - timestamp_ns);
    if (best == nullptr || gap < best_gap) {
      best = &*candidate;
      best_gap = gap;
    }
  }
  if (best == nullptr || best_gap > max_gap_ns) return std::nullopt;
  return best->pose;
}

EurocSequence open_euroc(const fs::path& mav0_or_root, const std::optional<fs::path>& gt_file) {
  if (!is_dir(mav0_or_root))
    throw InputError("EuRoC sequence '" + mav0_or_root.string() + "': folder not found");
  EurocSequence seq;
  seq.mav0 = is_dir(mav0_or_root / "mav0") ? mav0_or_root / "mav0" : mav0_or_root;
  if (!is_dir(seq.mav0 / "cam0") || !is_dir(seq.mav0 / "cam1"))
    throw InputError("EuRoC sequence '" + mav0_or_root.string() +
                     "': expected mav0/cam0/ and mav0/cam1/ (or cam0/, cam1/ in the folder)");
  seq.raw_left = read_euroc_camera(seq.mav0 / "cam0" / "sensor.yaml");
  seq.raw_right = read_euroc_camera(seq.mav0 / "cam1" / "sensor.yaml");
  if (seq.raw_left.width != seq.raw_right.width || seq.raw_left.height != seq.raw_right.height)
    throw InputError("EuRoC sequence '" + seq.mav0.string() + "': cam0 and cam1 resolutions differ");

  /// Stereo extrinsics: X_cam1 = R·X_cam0 + T with T_cam1_cam0 = T_BS1⁻¹ · T_BS0.
  const Pose T_cam1_cam0 = seq.raw_right.T_body_sensor.inverse() * seq.raw_left.T_body_sensor;
  const cv::Mat R = to_cv(T_cam1_cam0.linear());
  const cv::Mat T = (cv::Mat_<double>(3, 1) << T_cam1_cam0.translation().x(),
                     T_cam1_cam0.translation().y(), T_cam1_cam0.translation().z());
  const cv::Size size(seq.raw_left.width, seq.raw_left.height);
  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(seq.raw_left.K, seq.raw_left.distortion, seq.raw_right.K,
                    seq.raw_right.distortion, size, R, T, R1, R2, P1, P2, Q,
                    cv::CALIB_ZERO_DISPARITY, 0.0, size);
  /// Rectified right camera: P2 = [f 0 cx −f·B; 0 f cy 0; 0 0 1 0], so B = −P2(0,3)/f.
  const double f = P1.at<double>(0, 0);
  seq.camera.fx = f;
  seq.camera.fy = P1.at<double>(1, 1);
  seq.camera.cx = P1.at<double>(0, 2);
  seq.camera.cy = P1.at<double>(1, 2);
  seq.camera.baseline_m = -P2.at<double>(0, 3) / f;
  seq.camera.width = size.width;
  seq.camera.height = size.height;
  if (!(seq.camera.baseline_m > 0.0))
    throw InputError("EuRoC sequence '" + seq.mav0.string() +
                     "': cam1 is not to the right of cam0 after rectification (baseline " +
                     std::to_string(seq.camera.baseline_m) + " m)");
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) seq.R_rect_left(r, c) = R1.at<double>(r, c);
  cv::initUndistortRectifyMap(seq.raw_left.K, seq.raw_left.distortion, R1, P1, size, CV_16SC2,
                              seq.left_map1, seq.left_map2);
  cv::initUndistortRectifyMap(seq.raw_right.K, seq.raw_right.distortion, R2, P2, size, CV_16SC2,
                              seq.right_map1, seq.right_map2);

  // Pair cam0/cam1 images by equal timestamps (the EuRoC cameras are hardware-synchronised).
  const CameraList left = read_camera_list(seq.mav0 / "cam0");
  const CameraList right = read_camera_list(seq.mav0 / "cam1");
  for (const auto* list : {&left, &right})
    if (list->missing > 0)
      spdlog::warn("EuRoC '{}': {} rows of {}/data.csv name absent images; skipped",
                   seq.mav0.string(), list->missing, list == &left ? "cam0" : "cam1");
  std::map<std::int64_t, fs::path> right_by_time;
  for (std::size_t i = 0; i < right.images.size(); ++i)
    right_by_time.emplace(right.timestamps_ns[i], right.images[i]);
  std::size_t unpaired = 0;
  for (std::size_t i = 0; i < left.images.size(); ++i) {
    const auto it = right_by_time.find(left.timestamps_ns[i]);
    if (it == right_by_time.end()) {
      ++unpaired;
      continue;
    }
    seq.timestamps_ns.push_back(left.timestamps_ns[i]);
    seq.left_images.push_back(left.images[i]);
    seq.right_images.push_back(it->second);
  }
  if (seq.timestamps_ns.empty())
    throw InputError("EuRoC sequence '" + seq.mav0.string() +
                     "': no cam0/cam1 image pair with equal timestamps");
  if (unpaired > 0) spdlog::warn("EuRoC '{}': {} cam0 images without a cam1 partner skipped",
                                 seq.mav0.string(), unpaired);

  std::optional<fs::path> gt_path = gt_file;
  if (gt_path && !is_file(*gt_path))
    throw InputError("EuRoC ground truth '" + gt_path->string() + "': file not found");
  if (!gt_path) gt_path = find_groundtruth(seq.mav0);
  seq.poses.assign(seq.size(), std::nullopt);
  if (gt_path) {
    seq.groundtruth_file = *gt_path;
    const auto trajectory = read_euroc_groundtruth(*gt_path);
    /// Rectified left camera in the world: T_W_camrect = T_WB(t) · T_BS(cam0) · R_rect_leftᵀ.
    Pose T_cam0_camrect = Pose::Identity();
    T_cam0_camrect.linear() = seq.R_rect_left.transpose();
    const Pose T_body_camrect = seq.raw_left.T_body_sensor * T_cam0_camrect;
    for (std::size_t i = 0; i < seq.size(); ++i)
      if (auto T_WB = nearest_pose(trajectory, seq.timestamps_ns[i], kEurocMaxGroundTruthGapNs))
        seq.poses[i] = *T_WB * T_body_camrect;
  }
  return seq;
}

StereoFrame load_euroc_frame(const EurocSequence& sequence, std::size_t index) {
  if (index >= sequence.size())
    throw InputError("EuRoC sequence '" + sequence.mav0.string() + "': frame " +
                     std::to_string(index) + " out of range (" + std::to_string(sequence.size()) +
                     " frames)");
  const cv::Size size(sequence.camera.width, sequence.camera.height);
  auto load = [&](const fs::path& path, const cv::Mat& map1, const cv::Mat& map2) {
    const cv::Mat raw = read_image(path, true);
    if (raw.size() != size)
      throw InputError("EuRoC image '" + path.string() + "': size " + std::to_string(raw.cols) +
                       "x" + std::to_string(raw.rows) + " differs from the calibrated " +
                       std::to_string(size.width) + "x" + std::to_string(size.height));
    cv::Mat rectified;
    cv::remap(raw, rectified, map1, map2, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    return rectified;
  };
  StereoFrame frame;
  frame.frame_id = index;
  frame.timestamp_s = static_cast<double>(sequence.timestamps_ns[index]) * 1e-9;
  frame.left = load(sequence.left_images[index], sequence.left_map1, sequence.left_map2);
  frame.right = load(sequence.right_images[index], sequence.right_map1, sequence.right_map2);
  frame.camera = sequence.camera;
  frame.pose = sequence.poses[index];
  return frame;
}

}  // namespace planecell::io
