/// Stereo pairs with ground truth: Middlebury 2001–2006 and 2014, KITTI stereo 2012/2015,
/// synthetic sequences.
#include "io/paths.hpp"
#include "io/stereo_datasets.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <sstream>

#include "core/error.hpp"
#include "io/disparity_io.hpp"
#include "io/image_io.hpp"
#include "io/kitti_odometry.hpp"

namespace planecell::io {
namespace {

namespace fs = std::filesystem;


std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

/// First existing file among `names` in `dir`, or empty.
fs::path first_existing(const fs::path& dir, std::initializer_list<const char*> names) {
  for (const char* name : names)
    if (is_file(dir / name)) return dir / name;
  return {};
}

/// Image width (px) without decoding: the PNG IHDR chunk, else a full decode.
int image_width(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::array<unsigned char, 24> header{};
  if (in.read(reinterpret_cast<char*>(header.data()), header.size()) && header[1] == 'P' &&
      header[2] == 'N' && header[3] == 'G') {
    return (header[16] << 24) | (header[17] << 16) | (header[18] << 8) | header[19];
  }
  return read_image(path, false).cols;
}

/// Middlebury 2001/2003 8-bit GT scale by scene name (vision.middlebury.edu/stereo/data):
/// tsukuba ×16; teddy and cones ×4 at quarter size (450 px wide), ×2 half, ×1 full; the other
/// 2001 scenes (venus, sawtooth, bull, poster, barn1, barn2, map) ×8.
double middlebury_2003_scale(const std::string& scene, const fs::path& left) {
  const std::string name = lower(scene);
  if (name.find("tsukuba") != std::string::npos) return 16.0;
  if (name.find("teddy") != std::string::npos || name.find("cones") != std::string::npos) {
    const int width = image_width(left);
    if (width > 1200) return 1.0;
    if (width > 600) return 2.0;
    return 4.0;
  }
  return 8.0;
}

/// Middlebury 2005/2006 GT scale from the image width: full (≈1300–1400 px) ×1, half
/// (≈620–700) ×2, third (≈410–470) ×3.
double middlebury_2005_scale(const fs::path& left) {
  const int width = image_width(left);
  if (width >= 1000) return 1.0;
  if (width >= 550 && width <= 800) return 2.0;
  if (width >= 350 && width <= 520) return 3.0;
  throw InputError("Middlebury 2005/2006 image '" + left.string() + "': width " +
                   std::to_string(width) + " px is neither full, half nor third size; "
                   "cannot tell the GT disparity scale");
}

/// Adds the Middlebury scene in `dir`, if it is one.
void add_middlebury(const fs::path& dir, std::vector<StereoSampleRef>& out) {
  StereoSampleRef ref;
  ref.dataset = StereoDataset::kMiddlebury;
  ref.name = dir.filename().string();
  if (is_file(dir / "im0.png") && is_file(dir / "im1.png")) {  // 2014
    ref.gt_disparity = first_existing(dir, {"disp0GT.pfm", "disp0.pfm"});
    if (ref.gt_disparity.empty()) return;
    ref.left = dir / "im0.png";
    ref.right = dir / "im1.png";
    ref.gt_scale = 1.0;
  } else if (is_file(dir / "view1.png") && is_file(dir / "view5.png")) {  // 2005/2006
    ref.gt_disparity = first_existing(dir, {"disp1.png", "disp1.pgm"});
    if (ref.gt_disparity.empty()) return;
    ref.left = dir / "view1.png";
    ref.right = dir / "view5.png";
    ref.gt_scale = middlebury_2005_scale(ref.left);
  } else if (fs::path l = first_existing(dir, {"im2.png", "im2.ppm"}),
             r = first_existing(dir, {"im6.png", "im6.ppm"});
             !l.empty() && !r.empty()) {  // 2001/2003
    ref.gt_disparity = first_existing(dir, {"disp2.png", "disp2.pgm"});
    if (ref.gt_disparity.empty()) return;
    ref.left = l;
    ref.right = r;
    ref.gt_scale = middlebury_2003_scale(ref.name, ref.left);
  } else if (fs::path l3 = first_existing(dir, {"im3.png", "im3.ppm"}),
             r4 = first_existing(dir, {"im4.png", "im4.ppm"});
             !l3.empty() && !r4.empty()) {  // tsukuba (im3/im4 + disp3)
    ref.gt_disparity = first_existing(dir, {"disp3.png", "disp3.pgm"});
    if (ref.gt_disparity.empty()) return;
    ref.left = l3;
    ref.right = r4;
    ref.gt_scale = 16.0;
  } else {
    return;
  }
  out.push_back(std::move(ref));
}

/// Adds the frames of a KITTI-like folder: left/right/GT sub-folders with equal file names.
/// `only_10`: KITTI stereo keeps only *_10.png (the frames with ground truth).
void add_kitti_like(const fs::path& dir, StereoDataset dataset, const std::string& prefix,
                    const char* left, const char* right, const char* occ, const char* noc,
                    bool only_10, std::vector<StereoSampleRef>& out) {
  if (!is_dir(dir / left) || !is_dir(dir / right) || !is_dir(dir / occ)) return;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir / occ, ec)) {
    const fs::path gt = entry.path();
    if (!entry.is_regular_file() || lower(gt.extension().string()) != ".png") continue;
    const std::string stem = gt.stem().string();
    if (only_10 && (stem.size() < 3 || stem.substr(stem.size() - 3) != "_10")) continue;
    StereoSampleRef ref;
    ref.dataset = dataset;
    ref.name = prefix + "/" + stem;
    ref.left = dir / left / gt.filename();
    ref.right = dir / right / gt.filename();
    if (!is_file(ref.left) || !is_file(ref.right)) continue;  // GT without a pair
    ref.gt_disparity = gt;
    if (is_file(dir / noc / gt.filename())) ref.gt_disparity_noc = dir / noc / gt.filename();
    ref.gt_scale = 256.0;
    out.push_back(std::move(ref));
  }
}

/// Adds the Scene Flow frames of `dir` when it is a left-view disparity folder,
/// ROOT/disparity/REST/left (REST may be empty: the flat layout of the samples, or e.g.
/// TRAIN/A/0032, 35mm_focallength/scene_forwards/fast as in the released FlyingThings3D, Driving
/// and Monkaa archives): every NAME.pfm there with its pair ROOT/<pass>/REST/left|right/NAME.png,
/// pass = frames_cleanpass, frames_finalpass, RGB_cleanpass or RGB_finalpass (the first that
/// holds the pair), and the optional occlusion mask ROOT/occlusion/REST/left/NAME.png.
void add_sceneflow(const fs::path& dir, std::vector<StereoSampleRef>& out) {
  if (dir.filename() != "left") return;
  const std::vector<fs::path> parts(dir.begin(), dir.end());
  std::size_t at = parts.size();
  for (std::size_t i = parts.size() - 1; i-- > 0;)
    if (parts[i] == "disparity") {
      at = i;
      break;
    }
  if (at == parts.size()) return;
  fs::path root, rest;
  for (std::size_t i = 0; i < at; ++i) root /= parts[i];
  for (std::size_t i = at + 1; i + 1 < parts.size(); ++i) rest /= parts[i];
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const fs::path gt = entry.path();
    if (!entry.is_regular_file() || lower(gt.extension().string()) != ".pfm") continue;
    const fs::path image = fs::path(gt.stem().string() + ".png");
    for (const char* pass : {"frames_cleanpass", "frames_finalpass", "RGB_cleanpass", "RGB_finalpass"}) {
      const fs::path views = root / pass / rest;
      if (!is_file(views / "left" / image) || !is_file(views / "right" / image)) continue;
      StereoSampleRef ref;
      ref.dataset = StereoDataset::kSceneFlow;
      ref.name = (root.filename() / rest / gt.stem()).generic_string();
      ref.left = views / "left" / image;
      ref.right = views / "right" / image;
      ref.gt_disparity = gt;
      if (const fs::path mask = root / "occlusion" / rest / "left" / image; is_file(mask))
        ref.occlusion_mask = mask;
      out.push_back(std::move(ref));
      break;
    }
  }
}

void add_samples_in(const fs::path& dir, StereoDataset dataset, std::vector<StereoSampleRef>& out) {
  switch (dataset) {
    case StereoDataset::kMiddlebury:
      add_middlebury(dir, out);
      break;
    case StereoDataset::kKitti:
      add_kitti_like(dir, dataset, "kitti2012", "colored_0", "colored_1", "disp_occ", "disp_noc",
                     true, out);
      add_kitti_like(dir, dataset, "kitti2015", "image_2", "image_3", "disp_occ_0", "disp_noc_0",
                     true, out);
      break;
    case StereoDataset::kSceneFlow:
      add_sceneflow(dir, out);
      break;
    case StereoDataset::kSynthetic:
      add_kitti_like(dir, dataset, dir.filename().string(), "image_2", "image_3", "disp_occ_0",
                     "disp_noc_0", false, out);
      break;
  }
}

/// Reads Middlebury 8-bit/16-bit GT: d = value / scale, 0 = unknown (→ NaN); PFM as is.
cv::Mat read_middlebury_gt(const fs::path& path, double scale) {
  if (lower(path.extension().string()) == ".pfm") return read_pfm(path);
  const cv::Mat raw = read_image_unchanged(path);
  if (raw.channels() != 1 || (raw.depth() != CV_8U && raw.depth() != CV_16U))
    throw InputError("Middlebury GT '" + path.string() +
                     "': expected a single-channel 8- or 16-bit image");
  cv::Mat value;
  raw.convertTo(value, CV_32F, 1.0 / scale);
  value.setTo(std::numeric_limits<float>::quiet_NaN(), raw == 0);
  return value;
}

/// Middlebury 2014 calib.txt: cam0=[fx 0 cx; 0 fy cy; 0 0 1], cam1=..., doffs, baseline (mm),
/// ndisp. Returns key → text.
std::map<std::string, std::string> read_key_values(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError("Middlebury calibration '" + path.string() + "': cannot be opened");
  std::map<std::string, std::string> values;
  for (std::string line; std::getline(in, line);) {
    const auto eq = line.find('=');
    if (eq == std::string::npos) continue;
    values[line.substr(0, eq)] = line.substr(eq + 1);
  }
  return values;
}

struct Middlebury2014Calibration {
  std::optional<StereoCamera> camera;
  int ndisp = 0;
};

Middlebury2014Calibration read_middlebury_2014_calibration(const fs::path& path, int width,
                                                           int height) {
  const auto values = read_key_values(path);
  auto number = [&](const std::string& key) {
    const auto it = values.find(key);
    if (it == values.end())
      throw InputError("Middlebury calibration '" + path.string() + "': missing '" + key + "='");
    try {
      return std::stod(it->second);
    } catch (const std::logic_error&) {
      throw InputError("Middlebury calibration '" + path.string() + "': '" + key +
                       "' is not a number");
    }
  };
  auto matrix = [&](const std::string& key) {
    const auto it = values.find(key);
    if (it == values.end())
      throw InputError("Middlebury calibration '" + path.string() + "': missing '" + key + "='");
    std::string text = it->second;
    for (char& c : text)
      if (c == '[' || c == ']' || c == ';') c = ' ';
    std::istringstream in(text);
    std::vector<double> m;
    for (double v; in >> v;) m.push_back(v);
    if (m.size() != 9 || !in.eof())
      throw InputError("Middlebury calibration '" + path.string() + "': '" + key +
                       "' must be [fx 0 cx; 0 fy cy; 0 0 1]");
    return m;
  };
  const auto cam0 = matrix("cam0");
  const auto cam1 = matrix("cam1");
  Middlebury2014Calibration out;
  out.ndisp = static_cast<int>(number("ndisp"));
  const double doffs = values.contains("doffs") ? number("doffs") : cam1[2] - cam0[2];
  StereoCamera camera;
  camera.fx = cam0[0];
  camera.fy = cam0[4];
  camera.cx = cam0[2];
  camera.cy = cam0[5];
  camera.baseline_m = number("baseline") / 1000.0;  // mm → m
  camera.width = width;
  camera.height = height;
  try {
    camera.validate("Middlebury calibration '" + path.string() + "'");
  } catch (const ConfigError& e) {
    throw InputError(e.what());
  }
  // StereoCamera has one principal point: Z = fx·B/d. Middlebury 2014 has Z = fx·B/(d + doffs);
  // with doffs ≠ 0 the model would give wrong depths, so no camera is attached then.
  if (std::abs(doffs) < 1e-9) {
    out.camera = camera;
  } else {
    spdlog::debug("Middlebury calibration '{}': doffs = {} px is not representable by "
                  "StereoCamera; no camera attached", path.string(), doffs);
  }
  return out;
}

int round_up_16(double value) { return static_cast<int>(std::ceil(value / 16.0)) * 16; }

void check_same_size(const cv::Mat& a, const cv::Mat& b, const fs::path& b_path,
                     const fs::path& a_path) {
  if (a.size() != b.size())
    throw InputError("'" + b_path.string() + "': size " + std::to_string(b.cols) + "x" +
                     std::to_string(b.rows) + " differs from '" + a_path.string() + "' (" +
                     std::to_string(a.cols) + "x" + std::to_string(a.rows) + ")");
}

}  // namespace

StereoDataset parse_stereo_dataset(const std::string& name) {
  const std::string n = lower(name);
  if (n == "middlebury") return StereoDataset::kMiddlebury;
  if (n == "kitti") return StereoDataset::kKitti;
  if (n == "sceneflow") return StereoDataset::kSceneFlow;
  if (n == "synthetic") return StereoDataset::kSynthetic;
  throw ConfigError("stereo dataset '" + name +
                    "': unknown (use middlebury, kitti, sceneflow or synthetic)");
}

std::vector<StereoSampleRef> find_stereo_samples(StereoDataset dataset, const fs::path& root) {
  if (!is_dir(root)) throw InputError("stereo dataset root '" + root.string() + "': folder not found");
  std::vector<StereoSampleRef> out;
  add_samples_in(root, dataset, out);
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(root, fs::directory_options::skip_permission_denied, ec);
       it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (ec) break;
    if (it->is_directory()) add_samples_in(it->path(), dataset, out);
  }
  std::sort(out.begin(), out.end(),
            [](const StereoSampleRef& a, const StereoSampleRef& b) { return a.name < b.name; });
  return out;
}

StereoSample load_stereo_sample(const StereoSampleRef& ref) {
  StereoSample sample;
  sample.name = ref.name;
  sample.left = read_image(ref.left, true);
  sample.right = read_image(ref.right, true);
  check_same_size(sample.left, sample.right, ref.right, ref.left);
  if (ref.gt_scale <= 0.0 || !std::isfinite(ref.gt_scale))
    throw InputError("stereo sample '" + ref.name + "': GT scale must be > 0");
  auto read_gt = [&](const fs::path& path) {
    cv::Mat gt;
    switch (ref.dataset) {
      case StereoDataset::kMiddlebury:
        gt = read_middlebury_gt(path, ref.gt_scale);
        break;
      case StereoDataset::kSceneFlow:
        gt = read_pfm(path);  // disparity in px, every pixel known
        break;
      case StereoDataset::kKitti:
      case StereoDataset::kSynthetic:
        gt = read_kitti_disparity(path);  // value / 256
        if (ref.gt_scale != 256.0) gt.convertTo(gt, CV_32F, 256.0 / ref.gt_scale);
        break;
    }
    check_same_size(sample.left, gt, path, ref.left);
    return gt;
  };
  sample.gt_disparity = read_gt(ref.gt_disparity);
  if (!ref.gt_disparity_noc.empty()) sample.gt_disparity_noc = read_gt(ref.gt_disparity_noc);
  if (!ref.occlusion_mask.empty()) {
    const cv::Mat occluded = read_image(ref.occlusion_mask, false);
    check_same_size(sample.left, occluded, ref.occlusion_mask, ref.left);
    sample.gt_disparity_noc = sample.gt_disparity.clone();
    sample.gt_disparity_noc.setTo(std::numeric_limits<float>::quiet_NaN(), occluded != 0);
  }

  int calib_disparities = 0;
  const int width = sample.left.cols, height = sample.left.rows;
  if (ref.dataset == StereoDataset::kMiddlebury) {
    const fs::path calib = ref.left.parent_path() / "calib.txt";
    if (is_file(calib)) {
      const auto m = read_middlebury_2014_calibration(calib, width, height);
      sample.camera = m.camera;
      calib_disparities = m.ndisp;
    }
  } else if (ref.dataset == StereoDataset::kSynthetic) {
    const fs::path calib = ref.left.parent_path().parent_path() / "calib.txt";
    if (is_file(calib))
      sample.camera = stereo_camera_from_kitti(read_kitti_calibration(calib), 2, width, height);
  }

  double max_gt = 0.0;
  cv::Mat valid = sample.gt_disparity == sample.gt_disparity;  // not NaN
  if (cv::countNonZero(valid) > 0)
    cv::minMaxLoc(sample.gt_disparity, nullptr, &max_gt, nullptr, nullptr, valid);
  /// max_disparity: the search range [0, max) must hold ⌊max GT⌋, rounded up to 16.
  sample.max_disparity =
      std::max({16, round_up_16(std::floor(max_gt) + 1.0), round_up_16(calib_disparities)});
  return sample;
}

}  // namespace planecell::io
