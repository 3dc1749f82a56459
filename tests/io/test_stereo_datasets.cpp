/// Stereo datasets with ground truth: layout discovery, GT scales, cameras, named errors.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <opencv2/core.hpp>

#include "support/expect_error.hpp"
#include "core/error.hpp"
#include "io/disparity_io.hpp"
#include "io/image_io.hpp"
#include "io/stereo_datasets.hpp"
#include "support/test_data.hpp"

namespace planecell::io {
namespace {

namespace fs = std::filesystem;


using test::input_error_of;

void write_pair(const fs::path& left, const fs::path& right, int width, int height) {
  write_image(left, cv::Mat(height, width, CV_8UC3, cv::Scalar(10, 20, 30)));
  write_image(right, cv::Mat(height, width, CV_8UC3, cv::Scalar(30, 20, 10)));
}

/// 8-bit GT: value 200 at (0, 0), 0 (unknown) at (0, 1), 8 elsewhere.
void write_gt8(const fs::path& path, int width, int height) {
  cv::Mat gt(height, width, CV_8UC1, cv::Scalar(8));
  gt.at<std::uint8_t>(0, 0) = 200;
  gt.at<std::uint8_t>(0, 1) = 0;
  write_image(path, gt);
}

const StereoSampleRef& by_name(const std::vector<StereoSampleRef>& refs, const std::string& name) {
  for (const auto& ref : refs)
    if (ref.name == name) return ref;
  throw std::runtime_error("no sample named " + name);
}

TEST(StereoDatasets, ParsesDatasetNames) {
  EXPECT_EQ(parse_stereo_dataset("middlebury"), StereoDataset::kMiddlebury);
  EXPECT_EQ(parse_stereo_dataset("kitti"), StereoDataset::kKitti);
  EXPECT_EQ(parse_stereo_dataset("sceneflow"), StereoDataset::kSceneFlow);
  EXPECT_EQ(parse_stereo_dataset("synthetic"), StereoDataset::kSynthetic);
  EXPECT_THROW(parse_stereo_dataset("tum"), ConfigError);
}

TEST(Middlebury, ScalesByEraSceneAndSize) {
  test::ScratchDir dir;
  write_pair(dir / "venus" / "im2.png", dir / "venus" / "im6.png", 40, 30);
  write_gt8(dir / "venus" / "disp2.pgm", 40, 30);
  write_pair(dir / "teddy" / "im2.png", dir / "teddy" / "im6.png", 450, 20);  // quarter size
  write_gt8(dir / "teddy" / "disp2.png", 450, 20);
  write_pair(dir / "tsukuba" / "im3.png", dir / "tsukuba" / "im4.png", 40, 30);
  write_gt8(dir / "tsukuba" / "disp3.pgm", 40, 30);
  write_pair(dir / "2006" / "Half" / "view1.png", dir / "2006" / "Half" / "view5.png", 650, 10);
  write_gt8(dir / "2006" / "Half" / "disp1.png", 650, 10);
  write_pair(dir / "2006" / "Third" / "view1.png", dir / "2006" / "Third" / "view5.png", 433, 10);
  write_gt8(dir / "2006" / "Third" / "disp1.png", 433, 10);
  write_pair(dir / "2006" / "Full" / "view1.png", dir / "2006" / "Full" / "view5.png", 1390, 4);
  write_gt8(dir / "2006" / "Full" / "disp1.png", 1390, 4);
  write_pair(dir / "nogt" / "im2.png", dir / "nogt" / "im6.png", 40, 30);  // no GT: ignored

  const auto refs = find_stereo_samples(StereoDataset::kMiddlebury, dir.path());
  ASSERT_EQ(refs.size(), 6u);
  EXPECT_EQ(refs.front().name, "Full");  // sorted by name
  EXPECT_DOUBLE_EQ(by_name(refs, "venus").gt_scale, 8.0);
  EXPECT_DOUBLE_EQ(by_name(refs, "teddy").gt_scale, 4.0);
  EXPECT_DOUBLE_EQ(by_name(refs, "tsukuba").gt_scale, 16.0);
  EXPECT_DOUBLE_EQ(by_name(refs, "Half").gt_scale, 2.0);
  EXPECT_DOUBLE_EQ(by_name(refs, "Third").gt_scale, 3.0);
  EXPECT_DOUBLE_EQ(by_name(refs, "Full").gt_scale, 1.0);
  EXPECT_EQ(by_name(refs, "tsukuba").left.filename(), "im3.png");

  const StereoSample venus = load_stereo_sample(by_name(refs, "venus"));
  EXPECT_EQ(venus.left.type(), CV_8UC3);
  EXPECT_FLOAT_EQ(venus.gt_disparity.at<float>(0, 0), 25.0f);  // 200 / 8
  EXPECT_TRUE(std::isnan(venus.gt_disparity.at<float>(0, 1)));
  EXPECT_FLOAT_EQ(venus.gt_disparity.at<float>(5, 5), 1.0f);
  EXPECT_TRUE(venus.gt_disparity_noc.empty());
  EXPECT_FALSE(venus.camera.has_value());
  EXPECT_EQ(venus.max_disparity, 32);  // ⌊25⌋ + 1 rounded up to 16
  const StereoSample tsukuba = load_stereo_sample(by_name(refs, "tsukuba"));
  EXPECT_FLOAT_EQ(tsukuba.gt_disparity.at<float>(0, 0), 12.5f);  // 200 / 16
  EXPECT_EQ(tsukuba.max_disparity, 16);
  const StereoSample full = load_stereo_sample(by_name(refs, "Full"));
  EXPECT_EQ(full.max_disparity, 208);  // 200 → [0, 208)
}

TEST(Middlebury, UnknownSizeOf2005SceneIsAnError) {
  test::ScratchDir dir;
  write_pair(dir / "odd" / "view1.png", dir / "odd" / "view5.png", 300, 10);
  write_gt8(dir / "odd" / "disp1.png", 300, 10);
  EXPECT_CONTAINS(input_error_of([&] { find_stereo_samples(StereoDataset::kMiddlebury, dir.path()); }),
                  "300");
}

TEST(Middlebury, Reads2014PfmAndCalibration) {
  test::ScratchDir dir;
  const fs::path scene = dir / "Adirondack-perfect";
  write_pair(scene / "im0.png", scene / "im1.png", 20, 10);
  cv::Mat gt(10, 20, CV_32F, cv::Scalar(50.0f));
  gt.at<float>(3, 4) = std::numeric_limits<float>::quiet_NaN();
  write_pfm(scene / "disp0GT.pfm", gt);
  auto write_calib = [&](double doffs) {
    std::ofstream(scene / "calib.txt")
        << "cam0=[4000.5 0 10.25; 0 4000.5 5.5; 0 0 1]\n"
        << "cam1=[4000.5 0 " << 10.25 + doffs << "; 0 4000.5 5.5; 0 0 1]\n"
        << "doffs=" << doffs << "\nbaseline=193.001\nwidth=20\nheight=10\nndisp=100\n";
  };
  write_calib(0.0);
  const auto refs = find_stereo_samples(StereoDataset::kMiddlebury, dir.path());
  ASSERT_EQ(refs.size(), 1u);
  StereoSample sample = load_stereo_sample(refs[0]);
  EXPECT_FLOAT_EQ(sample.gt_disparity.at<float>(0, 0), 50.0f);
  EXPECT_TRUE(std::isnan(sample.gt_disparity.at<float>(3, 4)));
  ASSERT_TRUE(sample.camera.has_value());
  EXPECT_DOUBLE_EQ(sample.camera->fx, 4000.5);
  EXPECT_DOUBLE_EQ(sample.camera->cx, 10.25);
  EXPECT_DOUBLE_EQ(sample.camera->cy, 5.5);
  EXPECT_DOUBLE_EQ(sample.camera->baseline_m, 0.193001);
  EXPECT_EQ(sample.max_disparity, 112);  // ndisp 100 → 112 (> GT-derived 64)
  // A disparity offset is not representable by StereoCamera: no camera rather than a wrong one.
  write_calib(131.1);
  sample = load_stereo_sample(refs[0]);
  EXPECT_FALSE(sample.camera.has_value());
  std::ofstream(scene / "calib.txt") << "cam0=[4000.5 0 10.25; 0 4000.5]\nbaseline=1\nndisp=10\n";
  EXPECT_CONTAINS(input_error_of([&] { load_stereo_sample(refs[0]); }), "cam0");
}

TEST(Kitti, Finds2012And2015FramesWithGroundTruthOnly) {
  test::ScratchDir dir;
  const fs::path k12 = dir / "data_stereo_flow" / "training";
  const fs::path k15 = dir / "data_scene_flow" / "training";
  for (const char* frame : {"000000_10.png", "000000_11.png"}) {
    write_pair(k12 / "colored_0" / frame, k12 / "colored_1" / frame, 12, 6);
    write_pair(k15 / "image_2" / frame, k15 / "image_3" / frame, 12, 6);
  }
  cv::Mat gt(6, 12, CV_32F, cv::Scalar(12.5f));
  gt.at<float>(2, 2) = std::numeric_limits<float>::quiet_NaN();
  write_kitti_disparity(k12 / "disp_occ" / "000000_10.png", gt);
  write_kitti_disparity(k12 / "disp_noc" / "000000_10.png", gt);
  write_kitti_disparity(k12 / "disp_occ" / "000000_11.png", gt);  // not a GT frame (_11)
  write_kitti_disparity(k15 / "disp_occ_0" / "000000_10.png", gt);
  write_kitti_disparity(k15 / "disp_occ_0" / "000001_10.png", gt);  // no image pair: skipped

  const auto refs = find_stereo_samples(StereoDataset::kKitti, dir.path());
  ASSERT_EQ(refs.size(), 2u);
  EXPECT_EQ(refs[0].name, "kitti2012/000000_10");
  EXPECT_EQ(refs[1].name, "kitti2015/000000_10");
  EXPECT_FALSE(refs[0].gt_disparity_noc.empty());
  EXPECT_TRUE(refs[1].gt_disparity_noc.empty());
  const StereoSample s = load_stereo_sample(refs[0]);
  EXPECT_FLOAT_EQ(s.gt_disparity.at<float>(0, 0), 12.5f);
  EXPECT_TRUE(std::isnan(s.gt_disparity.at<float>(2, 2)));
  ASSERT_FALSE(s.gt_disparity_noc.empty());
  EXPECT_FLOAT_EQ(s.gt_disparity_noc.at<float>(5, 11), 12.5f);
  EXPECT_EQ(s.max_disparity, 16);

  // GT of the wrong size and an undecodable image are named.
  write_kitti_disparity(k15 / "disp_occ_0" / "000000_10.png", cv::Mat(5, 12, CV_32F, cv::Scalar(1.0f)));
  EXPECT_CONTAINS(input_error_of([&] { load_stereo_sample(refs[1]); }), "disp_occ_0/000000_10.png");
  std::ofstream(k15 / "image_3" / "000000_10.png") << "not a png";
  EXPECT_CONTAINS(input_error_of([&] { load_stereo_sample(refs[1]); }), "image_3/000000_10.png");
}

TEST(Synthetic, EveryGroundTruthFrameIsASampleWithTheCalibratedCamera) {
  test::ScratchDir dir;
  const fs::path seq = dir / "street";
  for (const char* frame : {"000000.png", "000001.png"}) {
    write_pair(seq / "image_2" / frame, seq / "image_3" / frame, 10, 4);
    write_kitti_disparity(seq / "disp_occ_0" / frame, cv::Mat(4, 10, CV_32F, cv::Scalar(3.25f)));
  }
  std::ofstream(seq / "calib.txt")
      << "P0: 500 0 5 0 0 500 2 0 0 0 1 0\nP1: 500 0 5 -100 0 500 2 0 0 0 1 0\n"
      << "P2: 500 0 5 0 0 500 2 0 0 0 1 0\nP3: 500 0 5 -150 0 500 2 0 0 0 1 0\n";
  const auto refs = find_stereo_samples(StereoDataset::kSynthetic, dir.path());
  ASSERT_EQ(refs.size(), 2u);
  EXPECT_EQ(refs[0].name, "street/000000");
  EXPECT_EQ(refs[1].name, "street/000001");
  const StereoSample s = load_stereo_sample(refs[1]);
  EXPECT_FLOAT_EQ(s.gt_disparity.at<float>(3, 9), 3.25f);
  ASSERT_TRUE(s.camera.has_value());
  EXPECT_DOUBLE_EQ(s.camera->baseline_m, 0.3);  // colour pair: 150 / 500
  EXPECT_EQ(s.camera->width, 10);
}

TEST(SceneFlow, PfmGroundTruthAndOcclusionMaskGiveAllAndNonOccludedDisparity) {
  test::ScratchDir dir;
  const fs::path seq = dir / "flying";
  constexpr int kWidth = 40, kHeight = 20;
  write_pair(seq / "RGB_cleanpass" / "left" / "A-0001.png",
             seq / "RGB_cleanpass" / "right" / "A-0001.png", kWidth, kHeight);
  cv::Mat gt(kHeight, kWidth, CV_32F, cv::Scalar(12.5f));
  gt.at<float>(3, 4) = 33.25f;  // largest: the search range rounds ⌊33.25⌋ + 1 up to 48
  write_pfm(seq / "disparity" / "left" / "A-0001.pfm", gt);
  cv::Mat occluded(kHeight, kWidth, CV_8UC1, cv::Scalar(0));
  occluded(cv::Rect(0, 0, 5, kHeight)).setTo(255);  // 5 occluded columns
  write_image(seq / "occlusion" / "left" / "A-0001.png", occluded);
  // GT without a pair, and a pair in a folder with no disparity/: both ignored.
  write_pfm(seq / "disparity" / "left" / "A-0002.pfm", gt);
  write_pair(dir / "other" / "RGB_cleanpass" / "left" / "A-0001.png",
             dir / "other" / "RGB_cleanpass" / "right" / "A-0001.png", kWidth, kHeight);

  const auto refs = find_stereo_samples(StereoDataset::kSceneFlow, dir.path());
  ASSERT_EQ(refs.size(), 1u);
  EXPECT_EQ(refs[0].name, "flying/A-0001");
  const StereoSample sample = load_stereo_sample(refs[0]);
  EXPECT_FLOAT_EQ(sample.gt_disparity.at<float>(10, 2), 12.5f);
  EXPECT_FLOAT_EQ(sample.gt_disparity.at<float>(3, 4), 33.25f);
  EXPECT_EQ(sample.max_disparity, 48);
  ASSERT_FALSE(sample.gt_disparity_noc.empty());
  EXPECT_EQ(cv::countNonZero(sample.gt_disparity_noc == sample.gt_disparity_noc),
            (kWidth - 5) * kHeight);
  EXPECT_TRUE(std::isnan(sample.gt_disparity_noc.at<float>(10, 4)));
  EXPECT_FLOAT_EQ(sample.gt_disparity_noc.at<float>(10, 5), 12.5f);
}

TEST(SceneFlow, FindsFramesInTheReleasedArchivesNestedLayout) {
  // FlyingThings3D as released: disparity/TRAIN/A/0032/left/0006.pfm beside
  // frames_finalpass/TRAIN/A/0032/left|right/0006.png; the right-view disparity is not a sample.
  test::ScratchDir dir;
  const fs::path root = dir / "FlyingThings3D";
  write_pair(root / "frames_finalpass" / "TRAIN" / "A" / "0032" / "left" / "0006.png",
             root / "frames_finalpass" / "TRAIN" / "A" / "0032" / "right" / "0006.png", 40, 20);
  const cv::Mat gt(20, 40, CV_32F, cv::Scalar(7.0f));
  write_pfm(root / "disparity" / "TRAIN" / "A" / "0032" / "left" / "0006.pfm", gt);
  write_pfm(root / "disparity" / "TRAIN" / "A" / "0032" / "right" / "0006.pfm", gt);
  const auto refs = find_stereo_samples(StereoDataset::kSceneFlow, dir.path());
  ASSERT_EQ(refs.size(), 1u);
  EXPECT_EQ(refs[0].name, "FlyingThings3D/TRAIN/A/0032/0006");
  EXPECT_EQ(refs[0].left, root / "frames_finalpass" / "TRAIN" / "A" / "0032" / "left" / "0006.png");
  EXPECT_TRUE(refs[0].occlusion_mask.empty());
  const StereoSample sample = load_stereo_sample(refs[0]);
  EXPECT_FLOAT_EQ(sample.gt_disparity.at<float>(5, 5), 7.0f);
  EXPECT_TRUE(sample.gt_disparity_noc.empty());
}

TEST(SceneFlow, AnOcclusionMaskOfAnotherSizeIsNamed) {
  test::ScratchDir dir;
  write_pair(dir / "frames_cleanpass" / "left" / "0006.png",
             dir / "frames_cleanpass" / "right" / "0006.png", 40, 20);
  write_pfm(dir / "disparity" / "left" / "0006.pfm", cv::Mat(20, 40, CV_32F, cv::Scalar(4.0f)));
  write_image(dir / "occlusion" / "left" / "0006.png", cv::Mat(10, 40, CV_8UC1, cv::Scalar(0)));
  const auto refs = find_stereo_samples(StereoDataset::kSceneFlow, dir.path());
  ASSERT_EQ(refs.size(), 1u);
  EXPECT_CONTAINS(input_error_of([&] { load_stereo_sample(refs[0]); }), "occlusion");
}

TEST(StereoDatasets, MissingRootIsNamed) {
  EXPECT_CONTAINS(input_error_of([] { find_stereo_samples(StereoDataset::kKitti, "/no/such/root"); }),
                  "/no/such/root");
  test::ScratchDir empty;
  EXPECT_TRUE(find_stereo_samples(StereoDataset::kKitti, empty.path()).empty());
}

TEST(RealData, MiddleburySamplesAndScales) {
  const auto root = test::shared_data("middlebury");
  if (!root) GTEST_SKIP() << "shared data absent";
  const auto refs = find_stereo_samples(StereoDataset::kMiddlebury, *root);
  ASSERT_EQ(refs.size(), 5u);
  // SOURCES.md: tsukuba /16, venus /8, teddy /4, Cloth3 and Wood2 (half size) /2.
  EXPECT_DOUBLE_EQ(by_name(refs, "tsukuba").gt_scale, 16.0);
  EXPECT_DOUBLE_EQ(by_name(refs, "venus").gt_scale, 8.0);
  EXPECT_DOUBLE_EQ(by_name(refs, "teddy").gt_scale, 4.0);
  EXPECT_DOUBLE_EQ(by_name(refs, "Cloth3").gt_scale, 2.0);
  EXPECT_DOUBLE_EQ(by_name(refs, "Wood2").gt_scale, 2.0);
  const StereoSample teddy = load_stereo_sample(by_name(refs, "teddy"));
  EXPECT_EQ(teddy.left.cols, 450);
  EXPECT_EQ(teddy.left.rows, 375);
  double hi = 0;
  cv::minMaxLoc(teddy.gt_disparity, nullptr, &hi, nullptr, nullptr, teddy.gt_disparity == teddy.gt_disparity);
  EXPECT_DOUBLE_EQ(hi, 211.0 / 4.0);  // SOURCES.md: max raw 211
  EXPECT_EQ(teddy.max_disparity, 64);
}

TEST(RealData, KittiStereoSamples) {
  const auto root = test::shared_data("kitti2015");
  if (!root) GTEST_SKIP() << "shared data absent";
  const auto refs = find_stereo_samples(StereoDataset::kKitti, root->parent_path());
  std::vector<std::string> names;
  for (const auto& r : refs) names.push_back(r.name);
  EXPECT_NE(std::find(names.begin(), names.end(), "kitti2015/000000_10"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "kitti2015/000001_10"), names.end());
  const StereoSample s = load_stereo_sample(by_name(refs, "kitti2015/000001_10"));
  EXPECT_EQ(s.left.cols, 1242);
  EXPECT_EQ(s.left.rows, 375);
  EXPECT_EQ(s.max_disparity, 80);  // max raw 20092 / 256 = 78.5
}

}  // namespace
}  // namespace planecell::io
