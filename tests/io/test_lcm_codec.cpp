/// LCM codec: exact round trips of frames, poses, cells and chunked map updates; malformed bytes
/// and values rejected with InputError; every chunk under the byte budget.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "io/lcm/lcm_codec.hpp"
#include "support/expect_error.hpp"
#include "support/planecell_fixtures.hpp"

namespace planecell::io {
namespace {

StereoFrame test_frame() {
  StereoFrame frame;
  frame.frame_id = 42;
  frame.left = cv::Mat(30, 40, CV_8UC3);
  frame.right = cv::Mat(30, 40, CV_8UC3);
  cv::randu(frame.left, 0, 255);
  cv::randu(frame.right, 0, 255);
  frame.camera.fx = 500.0;
  frame.camera.fy = 501.0;
  frame.camera.cx = 20.5;
  frame.camera.cy = 15.5;
  frame.camera.baseline_m = 0.25;
  return frame;
}

bool same_pixels(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

map::MapCell world_cell(std::uint32_t id) {
  const Planecell cell = test::rect_cell(id, {1.0f * static_cast<float>(id), 0.5f, 10.0f},
                                         {0.3f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.4f}, static_cast<int>(id % 64));
  map::MapCell stored = map::map_cell_of(cell, id, 7, id / 3);
  stored.depth_sigma_m = 0.125f;
  return stored;
}

TEST(LcmCodec, StereoFrameRoundTripsRawAndPngExactly) {
  const StereoFrame frame = test_frame();
  for (const auto encoding : {ImageEncoding::kRaw, ImageEncoding::kPng}) {
    const auto bytes = encode_bytes(to_lcm(frame, encoding, 1234567));
    const StereoFrame back = from_lcm(decode_stereo_frame(bytes));
    EXPECT_EQ(back.frame_id, 42u);
    EXPECT_DOUBLE_EQ(back.timestamp_s, 1.234567);
    EXPECT_TRUE(same_pixels(back.left, frame.left));
    EXPECT_TRUE(same_pixels(back.right, frame.right));
    EXPECT_EQ(back.camera.fy, 501.0);
    EXPECT_EQ(back.camera.baseline_m, 0.25);
    EXPECT_EQ(back.camera.width, 40);
    EXPECT_EQ(back.camera.height, 30);
  }
  const auto raw = to_lcm(frame, ImageEncoding::kRaw, 0);
  EXPECT_EQ(raw.left.size(), 30u * 40u * 3u);
}

TEST(LcmCodec, PngFilesSentAsTheyAreDecodeToTheImagesReadImageGives) {
  // What a sequence on disk holds: a colour PNG (RGB in the file) and a gray one (KITTI image_0).
  const StereoFrame frame = test_frame();
  cv::Mat gray;
  cv::cvtColor(frame.right, gray, cv::COLOR_BGR2GRAY);
  std::vector<std::uint8_t> left_png, right_png;
  ASSERT_TRUE(cv::imencode(".png", frame.left, left_png, {cv::IMWRITE_PNG_COMPRESSION, 9}));
  ASSERT_TRUE(cv::imencode(".png", gray, right_png));
  const auto sent = to_lcm_png(7, frame.camera, left_png, right_png, 99);
  EXPECT_EQ(sent.left, left_png);  // byte for byte
  EXPECT_EQ(sent.width, 40);
  EXPECT_EQ(sent.height, 30);
  const StereoFrame back = from_lcm(decode_stereo_frame(encode_bytes(sent)));
  EXPECT_EQ(back.frame_id, 7u);
  EXPECT_EQ(back.camera.fx, 500.0);
  EXPECT_TRUE(same_pixels(back.left, frame.left));
  // read_image's flags: a gray file arrives as 3 equal BGR channels.
  cv::Mat gray_bgr;
  cv::cvtColor(gray, gray_bgr, cv::COLOR_GRAY2BGR);
  EXPECT_TRUE(same_pixels(back.right, gray_bgr));

  std::vector<std::uint8_t> not_png(left_png.begin() + 1, left_png.end());
  EXPECT_THROW(to_lcm_png(7, frame.camera, left_png, not_png, 0), InputError);
  std::vector<std::uint8_t> smaller;
  ASSERT_TRUE(cv::imencode(".png", frame.left(cv::Rect(0, 0, 39, 30)), smaller));
  try {
    to_lcm_png(7, frame.camera, left_png, smaller, 0);
    ADD_FAILURE() << "PNGs of different sizes accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("40x30 and 39x30"), std::string::npos) << e.what();
  }
}

TEST(LcmCodec, StereoFrameWithBadFieldsIsRejected) {
  const auto good = to_lcm(test_frame(), ImageEncoding::kRaw, 0);
  auto bad = good;
  bad.left.pop_back();  // one byte short of width·height·channels
  bad.left_size = static_cast<std::int32_t>(bad.left.size());
  EXPECT_THROW(from_lcm(bad), InputError);
  bad = good;
  bad.width = 0;
  EXPECT_THROW(from_lcm(bad), InputError);
  bad = good;
  bad.height = kMaxLcmImageSide + 1;
  EXPECT_THROW(from_lcm(bad), InputError);
  bad = good;
  bad.channels = 2;
  EXPECT_THROW(from_lcm(bad), InputError);
  bad = good;
  bad.encoding = 7;
  EXPECT_THROW(from_lcm(bad), InputError);
  bad = good;
  bad.baseline_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(from_lcm(bad), InputError);
  bad = good;
  bad.encoding = planecell_lcm::stereo_frame_t::ENCODING_PNG;  // raw bytes are no PNG
  EXPECT_THROW(from_lcm(bad), InputError);
}

TEST(LcmCodec, MalformedBytesAreRejectedNotDecoded) {
  const auto bytes = encode_bytes(to_lcm(test_frame(), ImageEncoding::kPng, 0));
  std::vector<std::uint8_t> truncated(bytes.begin(), bytes.end() - 10);
  EXPECT_THROW(decode_stereo_frame(truncated), InputError);
  std::vector<std::uint8_t> longer = bytes;
  longer.push_back(0);
  EXPECT_THROW(decode_stereo_frame(longer), InputError);
  std::vector<std::uint8_t> huge_count = bytes;
  huge_count[74] = 0x7f;  // left_size ≈ 2^31: rejected before anything is allocated
  EXPECT_THROW(decode_stereo_frame(huge_count), InputError);
  // A pose's bytes are not a stereo frame (type hash), and garbage is nothing.
  EXPECT_THROW(decode_stereo_frame(encode_bytes(to_lcm(1, Pose::Identity(), 0))), InputError);
  EXPECT_THROW(decode_map_update(std::vector<std::uint8_t>(100, 0xAB)), InputError);
  EXPECT_THROW(decode_pose(std::vector<std::uint8_t>{}), InputError);
  EXPECT_THROW(decode_map_stats(std::vector<std::uint8_t>(3, 1)), InputError);
}

TEST(LcmCodec, PoseRoundTripsAndBadMatricesAreRejected) {
  Pose pose = Pose::Identity();
  pose.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(1.5, -2.0, 30.25);
  const auto message = decode_pose(encode_bytes(to_lcm(9, pose, 5)));
  EXPECT_EQ(message.frame_id, 9);
  EXPECT_EQ(message.T_world_cam[3], 1.5);  // row-major: (0, 3) is x
  EXPECT_TRUE(from_lcm(message).matrix().isApprox(pose.matrix(), 1e-15));
  auto bad = message;
  bad.T_world_cam[5] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(from_lcm(bad), InputError);
  bad = message;
  bad.T_world_cam[15] = 2.0;
  EXPECT_THROW(from_lcm(bad), InputError);
  bad = message;
  bad.T_world_cam[0] *= 1.5;  // not a rotation
  EXPECT_THROW(from_lcm(bad), InputError);
}

TEST(LcmCodec, PlanecellRoundTripsExactlyAndBadCellsAreRejected) {
  const map::MapCell cell = world_cell(5);
  const map::MapCell back = from_lcm(to_lcm(cell));
  EXPECT_TRUE(cell == back);
  auto bad = to_lcm(cell);
  bad.num_vertices = 3;  // disagrees with the 4 stored
  EXPECT_THROW(from_lcm(bad), InputError);
  bad = to_lcm(cell);
  bad.vertices_m[2][1] = std::nanf("");
  EXPECT_THROW(from_lcm(bad), InputError);
  bad = to_lcm(cell);
  bad.mean_rgb[1] = std::numeric_limits<float>::infinity();
  EXPECT_THROW(from_lcm(bad), InputError);
  bad = to_lcm(cell);
  bad.depth_sigma_m = -0.5f;
  EXPECT_THROW(from_lcm(bad), InputError);
  bad = to_lcm(cell);
  bad.frame_id = -1;
  EXPECT_THROW(from_lcm(bad), InputError);
}

MapUpdate big_update(std::uint64_t frame_id, std::uint32_t first_id, std::uint32_t cells) {
  MapUpdate update;
  update.frame_id = frame_id;
  for (std::uint32_t i = 0; i < cells; ++i) update.added_cells.push_back(world_cell(first_id + i));
  for (std::uint32_t i = 0; i < 5000; ++i) update.relabelled_cells.emplace_back(i, i + 1);
  update.removed_cells = {3, 4};
  update.surface_merges = {{frame_id, 8, 2}, {frame_id, 9, 2}};
  update.removed_surfaces = {8, 9};
  update.next_cell_id = first_id + cells;
  update.next_surface_id = 77;
  update.map_cells = 1234;
  update.map_surfaces = 55;
  return update;
}

TEST(LcmCodec, MapUpdatesAreChunkedUnderTheBudgetAndReassembled) {
  const MapUpdate update = big_update(3, 100, 1200);  // 1200 cells × 116 B ≈ 140 kB
  const auto chunks = encode_map_update(update, 99);
  ASSERT_GT(chunks.size(), 3u);
  std::size_t cells = 0;
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    const auto bytes = encode_bytes(chunks[i]);
    EXPECT_LE(bytes.size(), kMaxLcmMessageBytes);
    EXPECT_EQ(chunks[i].chunk_index, static_cast<std::int32_t>(i));
    EXPECT_EQ(chunks[i].chunk_count, static_cast<std::int32_t>(chunks.size()));
    cells += chunks[i].added.size();
  }
  EXPECT_EQ(cells, 1200u);

  // Through bytes, delivered out of chunk order.
  MapUpdateAssembler assembler;
  std::optional<MapUpdate> whole;
  for (std::size_t k = 0; k < chunks.size(); ++k) {
    const std::size_t i = chunks.size() - 1 - k;
    auto result = assembler.add(decode_map_update(encode_bytes(chunks[i])));
    if (k + 1 < chunks.size()) EXPECT_FALSE(result.has_value());
    else whole = std::move(result);
  }
  ASSERT_TRUE(whole.has_value());
  ASSERT_EQ(whole->added_cells.size(), update.added_cells.size());
  for (std::size_t i = 0; i < update.added_cells.size(); ++i)
    EXPECT_TRUE(whole->added_cells[i] == update.added_cells[i]) << i;
  EXPECT_EQ(whole->relabelled_cells, update.relabelled_cells);
  EXPECT_EQ(whole->removed_cells, update.removed_cells);
  EXPECT_EQ(whole->surface_merges, update.surface_merges);
  EXPECT_EQ(whole->removed_surfaces, update.removed_surfaces);
  EXPECT_EQ(whole->next_cell_id, 1300u);
  EXPECT_EQ(whole->next_surface_id, 77u);
  EXPECT_EQ(whole->map_cells, 1234u);
}

TEST(LcmCodec, AnUpdateThatFitsIsOneChunkAndACellTooBigForTheBudgetIsRejected) {
  MapUpdate small;
  small.frame_id = 1;
  small.added_cells = {world_cell(0), world_cell(1)};
  EXPECT_EQ(encode_map_update(small, 0).size(), 1u);
  EXPECT_THROW(encode_map_update(small, 0, 100), InputError);  // one 4-vertex cell is 116 bytes
}

TEST(LcmCodec, OutOfOrderDuplicateAndInconsistentChunksAreRejected) {
  MapUpdateAssembler assembler;
  const auto frame5 = encode_map_update(big_update(5, 0, 200), 0);
  ASSERT_GE(frame5.size(), 2u);
  EXPECT_FALSE(assembler.add(frame5[0]).has_value());
  EXPECT_THROW(assembler.add(frame5[0]), InputError);  // duplicate
  auto inconsistent = frame5[1];
  inconsistent.num_added += 1;
  EXPECT_THROW(assembler.add(inconsistent), InputError);
  auto bad_index = frame5[1];
  bad_index.chunk_index = bad_index.chunk_count;
  EXPECT_THROW(assembler.add(bad_index), InputError);
  for (std::size_t i = 1; i < frame5.size(); ++i) assembler.add(frame5[i]);
  const auto frame4 = encode_map_update(big_update(4, 0, 2), 0);
  EXPECT_THROW(assembler.add(frame4[0]), InputError);  // older than an applied frame
  // Frame 7 starts before frame 6 finished: frame 6 is abandoned and counted.
  const auto frame6 = encode_map_update(big_update(6, 0, 200), 0);
  const auto frame7 = encode_map_update(big_update(7, 0, 2), 0);
  EXPECT_FALSE(assembler.add(frame6[0]).has_value());
  EXPECT_TRUE(assembler.add(frame7[0]).has_value());
  EXPECT_EQ(assembler.incomplete_frames(), 1u);
  EXPECT_THROW(assembler.add(frame6[1]), InputError);  // too late now
}

TEST(LcmCodec, TheSettlingAfterAFrameFollowsItsUpdateOnceAndBeforeTheNextFrame) {
  MapUpdate update5;
  update5.frame_id = 5;
  update5.added_cells = {world_cell(0), world_cell(1)};
  MapUpdate settling = update5;  // consolidation: the two cells leave, their union enters
  settling.settled = true;
  settling.added_cells = {world_cell(2)};
  settling.removed_cells = {0, 1};
  MapUpdate update6;
  update6.frame_id = 6;
  const auto frame5 = encode_map_update(update5, 0);
  const auto settled5 = encode_map_update(settling, 0);
  ASSERT_EQ(settled5.size(), 1u);
  EXPECT_TRUE(settled5[0].settled);
  MapUpdateAssembler assembler;
  const auto frame = assembler.add(decode_map_update(encode_bytes(frame5[0])));
  ASSERT_TRUE(frame.has_value());
  EXPECT_FALSE(frame->settled);
  const auto settled = assembler.add(decode_map_update(encode_bytes(settled5[0])));
  ASSERT_TRUE(settled.has_value());
  EXPECT_TRUE(settled->settled);
  EXPECT_EQ(settled->frame_id, 5u);
  EXPECT_EQ(settled->removed_cells, settling.removed_cells);
  EXPECT_CONTAINS(test::error_of<InputError>([&] { assembler.add(settled5[0]); }),
                  "map_update_t settling the map after frame 5: out of order (the settling after frame 5 "
                  "already applied)");
  EXPECT_THROW(assembler.add(frame5[0]), InputError);  // the frame after its settling
  EXPECT_TRUE(assembler.add(encode_map_update(update6, 0)[0]).has_value());
  // A mirror applies both and counts frames, not settlings.
  MapMirror mirror;
  mirror.apply(*frame);
  mirror.apply(*settled);
  EXPECT_EQ(mirror.frames, 1u);
  EXPECT_EQ(mirror.last_frame_id, 5u);
  ASSERT_EQ(mirror.cells.size(), 1u);
  EXPECT_TRUE(mirror.cells.contains(2));
}

TEST(LcmCodec, MirrorAppliesAddsRelabelsAndRemovalsAndRejectsUnknownCells) {
  MapMirror mirror;
  MapUpdate first;
  first.frame_id = 0;
  first.added_cells = {world_cell(0), world_cell(1), world_cell(2)};
  first.next_cell_id = 3;
  mirror.apply(first);
  MapUpdate second;
  second.frame_id = 1;
  second.added_cells = {world_cell(3)};
  second.relabelled_cells = {{0, 9}};
  second.removed_cells = {2};
  mirror.apply(second);
  EXPECT_EQ(mirror.cells.size(), 3u);
  EXPECT_EQ(mirror.cells.at(0).surface, 9u);
  EXPECT_FALSE(mirror.cells.contains(2));
  MapUpdate bad;
  bad.frame_id = 2;
  bad.relabelled_cells = {{42, 1}};
  EXPECT_THROW(mirror.apply(bad), InputError);
  bad.relabelled_cells.clear();
  bad.added_cells = {world_cell(1)};  // already there
  EXPECT_THROW(mirror.apply(bad), InputError);
  EXPECT_EQ(mirror.cells.size(), 3u);  // a rejected update changes nothing
}

}  // namespace
}  // namespace planecell::io
