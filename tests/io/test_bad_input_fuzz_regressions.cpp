/// Inputs found by the libFuzzer targets (tests/fuzz, scripts/fuzz.sh) and the crash-recovery
/// work that escaped the readers as something other than the documented InputError/StorageError,
/// kept as plain regression tests with the crashing bytes inline (fuzz selector byte removed).
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <fstream>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "io/disparity_io.hpp"
#include "io/euroc.hpp"
#include "io/image_io.hpp"
#include "io/lcm/lcm_codec.hpp"
#include "io/map_codec.hpp"
#include "io/map_store.hpp"
#include "services/pipeline/mirror_map.hpp"
#include "support/expect_error.hpp"
#include "support/planecell_fixtures.hpp"
#include "support/test_data.hpp"
#include "support/text_files.hpp"

namespace planecell::io {
namespace {

using test::write_text;

using test::input_error_of;

/// The bytes of a fuzzer finding written inline as hex ("03e844…").
std::vector<std::uint8_t> bytes_of_hex(const std::string& hex) {
  std::vector<std::uint8_t> bytes;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2)
    bytes.push_back(static_cast<std::uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  return bytes;
}

/// fuzz_euroc crash-66e30fa8: `distortion_model` given as a list escaped read_euroc_camera as
/// YAML::TypedBadConversion<std::string> (an uncaught exception: the CLI exited with the wrong
/// code, the daemon would have died).
TEST(FuzzRegression, EurocSensorYamlWithAListAsDistortionModel) {
  test::ScratchDir dir;
  write_text(dir / "sensor.yaml",
             "%YAML:1.0\nsensor_type: camera\nT_BS:\n  cols: 4\n  rows: 4\n"
             "  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,\n"
             "         0.9995)4498016, 0.0149672133247, 0.025715529948, -0.064676986768,\n"
             "    A    -0.0257744366974, 0.00375618835797, 0.999660727178, 0./0981073058949,\n"
             "         0.0, 0.0, 0.0, 1.0]\nrate_hz: 20\nresolution: [65, 48]\n"
             "camera_model: pinhole\nintrinsics: [458.654, 457.296, 31.5, 23.5] #fu, fv, cu, cv\n"
             "distortion_model: [458.654, 457.296, 31.5, 23.5] #fu,cients: [340811, 0.07395907, "
             "0.00019359, 1.76187114e-05]\n");
  const std::string message = input_error_of([&] { (void)read_euroc_camera(dir / "sensor.yaml"); });
  EXPECT_CONTAINS(message, "sensor.yaml");
  EXPECT_CONTAINS(message, "'distortion_model' must be a name");
  // The same for camera_model given as a mapping.
  write_text(dir / "model.yaml", "camera_model: {a: b}\n");
  EXPECT_CONTAINS(input_error_of([&] { (void)read_euroc_camera(dir / "model.yaml"); }),
                  "'camera_model' must be a name");
}

/// Found reviewing fuzz_euroc's surface: a resolution of 1e300 was cast to int (undefined
/// behaviour); now refused as a number outside [1, 65535].
TEST(FuzzRegression, EurocSensorYamlWithAHugeResolution) {
  test::ScratchDir dir;
  write_text(dir / "sensor.yaml",
             "T_BS:\n  data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n"
             "resolution: [1e300, 48]\ncamera_model: pinhole\n"
             "intrinsics: [458.654, 457.296, 31.5, 23.5]\ndistortion_model: radial-tangential\n"
             "distortion_coefficients: [-0.28, 0.07, 0.0002, 1.7e-05]\n");
  EXPECT_CONTAINS(input_error_of([&] { (void)read_euroc_camera(dir / "sensor.yaml"); }),
                  "resolution must be within [1, 65535]");
}

/// fuzz_euroc crash-1399a810: a TUM ground-truth time of 9 403 715 273 s (ten digits, so read
/// as exact decimal text) overflowed int64 nanoseconds (signed overflow, undefined behaviour);
/// now refused as a time outside ±9 223 372 035 s, naming the file and line.
TEST(FuzzRegression, EurocGroundTruthTimeBeyondInt64Nanoseconds) {
  test::ScratchDir dir;
  write_text(dir / "gt.txt",
             "# t tx ty tz qx qy qz qw\n"
             "9403715273.262142976 4.688319 -1.78693 .78083338 -0.153029 -0.827383 -0.084304 "
             "0.534108\n");
  const std::string message = input_error_of([&] { (void)read_euroc_groundtruth(dir / "gt.txt"); });
  EXPECT_CONTAINS(message, "gt.txt' line 2");
  EXPECT_CONTAINS(message, "time '9403715273.262142976' s is outside");
}

/// Found writing the crash-recovery test (tests/services/test_crash_recovery.cpp): a replay
/// killed between the creation of the store file and the commit of its schema left an empty file
/// that every later open refused as "not an SQLite database". A store is now created as
/// `<path>.creating` and renamed into place; a stale half-created one (and its WAL) is replaced.
TEST(FuzzRegression, StaleHalfCreatedStoreIsReplacedNotAdopted) {
  test::ScratchDir dir;
  const auto path = dir / "map.db";
  write_text(dir / "map.db.creating", "half a database");
  write_text(dir / "map.db.creating-wal", "stale log");
  {
    MapStore store(path);
    EXPECT_EQ(store.frame_count(), 0u);
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "map.db.creating"));
  EXPECT_FALSE(std::filesystem::exists(dir / "map.db.creating-wal"));
  const MapStore reopened(path);  // the created file is a valid, empty planecell map
  EXPECT_EQ(reopened.frame_count(), 0u);
}

/// fuzz_map_store crash-08aa3a15 (CI, one flipped bit): a meta value 'next_cell_id' that is not a
/// number escaped MapStore::load as std::invalid_argument from std::stoul. It is now a
/// StorageError naming the store and the key; the same for a value beyond 32 bits.
TEST(FuzzRegression, MapStoreMetaIdThatIsNotANumber) {
  test::ScratchDir dir;
  const auto path = dir / "map.db";
  { MapStore store(path); }
  for (const std::string bad : {"12x", "", "-1", "4294967296"}) {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    const std::string sql = "UPDATE meta SET value = '" + bad + "' WHERE key = 'next_cell_id';";
    ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
    const MapStore store(path);
    try {
      (void)store.load();
      ADD_FAILURE() << "meta value '" << bad << "' was accepted";
    } catch (const StorageError& e) {
      EXPECT_CONTAINS(std::string(e.what()), "map.db");
      EXPECT_CONTAINS(std::string(e.what()), "meta 'next_cell_id' is not an id");
    }
  }
}

/// fuzz_map_store crash-dcd31fbf (CI, UBSan): a stored vertex of 9·10²⁴ m reached the spatial
/// index, whose float → int64 bucket conversion overflowed. GlobalMap::restore now refuses cells
/// beyond the index's range or larger than a planecell can be (StorageError naming the cell);
/// integrate rejects such cells from a live frame instead of indexing them.
TEST(FuzzRegression, MapStoreCellWithAVertexBeyondTheIndexRange) {
  test::ScratchDir dir;
  const auto path = dir / "map.db";
  const Eigen::Vector3f x(1, 0, 0), z(0, 0, 1);
  {
    MapStore store(path);
    map::GlobalMap map;
    const auto report = map.integrate(0, Pose::Identity(), std::vector{test::rect_cell(0, {0, 1.5f, 5}, x, z, 3)});
    ASSERT_EQ(map.cells().size(), 1u);
    store.commit_frame(0, Pose::Identity(), report, map);
  }
  ASSERT_EQ(load_map(MapStore(path)).cells().size(), 1u);  // intact store loads
  for (const float bad : {9.19716e24f, -3e7f, 250.0f}) {
    SCOPED_TRACE(bad);
    // Vertices (0,1.5,5) (bad,1.5,5) (bad,1.5,6) (0,1.5,6): beyond ±2097 km, or 250 m across.
    const std::vector<std::uint8_t> xyz =
        map_codec::encode_vertices({{0, 1.5f, 5}, {bad, 1.5f, 5}, {bad, 1.5f, 6}, {0, 1.5f, 6}});
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    sqlite3_stmt* stmt = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "UPDATE cells SET vertices_m = ?", -1, &stmt, nullptr), SQLITE_OK);
    sqlite3_bind_blob(stmt, 1, xyz.data(), static_cast<int>(xyz.size()), SQLITE_TRANSIENT);
    ASSERT_EQ(sqlite3_step(stmt), SQLITE_DONE);
    sqlite3_finalize(stmt);
    sqlite3_close(db);
    const MapStore store(path);
    try {
      (void)load_map(store);
      ADD_FAILURE() << "a cell with a vertex at x = " << bad << " was restored";
    } catch (const StorageError& e) {
      EXPECT_CONTAINS(std::string(e.what()), "map restore: cell 0");
      EXPECT_CONTAINS(std::string(e.what()), bad == 250.0f ? "spans more than" : "has a vertex beyond");
    }
  }
}

/// The live path of the same finding: a frame cell far outside the index range (a corrupt pose or
/// disparity) is rejected by integrate and the map keeps what it had.
TEST(FuzzRegression, FrameCellBeyondTheIndexRangeIsRejectedNotIndexed) {
  const Eigen::Vector3f x(1, 0, 0), z(0, 0, 1);
  MapConfig config;
  config.max_range_m = 1e30;  // the range gate would otherwise hide the case
  map::GlobalMap map(config);
  (void)map.integrate(0, Pose::Identity(), std::vector{test::rect_cell(0, {0, 1.5f, 5}, x, z, 3)});
  ASSERT_EQ(map.cells().size(), 1u);
  const auto report = map.integrate(1, Pose::Identity(), std::vector{test::rect_cell(0, {1e25f, 1.5f, 5}, x, z, 3)});
  EXPECT_EQ(report.rejected_cells, 1u);
  EXPECT_EQ(map.cells().size(), 1u);
}

/// fuzz_lcm crash-3e7010a1 (UBSan): a map update whose cell has a vertex at -1.2·10³¹ m reached the
/// subscriber's mirror_to_map, and the surface footprint converted it to int64 (overflow).
/// Footprints now ignore rings beyond ±2³⁰ bits, and restoring the mirrored map refuses the cell.
/// The finding's bytes predate the slim planecell_t (map store v3): they are now rejected as a
/// foreign layout, and the same update is rebuilt with today's message type.
TEST(FuzzRegression, LcmMapUpdateWithACellAtTenToTheThirtyOneMetres) {
  const std::string hex =
      "02cf23807268959f0900000000000003e800000000000000040000000000000001000000030000000200000003000000"
      "010000000100000002000000000000000000000000010000000000000000000000000000000000000000000000000000"
      "000000000000bff000000000000000000000000000003ff800000000000000000004000000000000000041a000000000"
      "000041a0000041a000000000000041a00000400000003fc0000040a00000404000003fc0000040444d445f4c4f4e474e"
      "414d453d5a61727200003fc0000040c000004140000042c80000424800000000000000000000000000003f8000000000"
      "000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000"
      "000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000"
      "000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000"
      "000000000000000000000007000000000000000000000000000000000000000000000000000000000000000000000000"
      "000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000"
      "019000000000000000000000000000000001000000010000000000000000000000010000000100000000000000010000"
      "0001";
  const std::vector<std::uint8_t> old_bytes = bytes_of_hex(hex);
  ASSERT_EQ(old_bytes.front() % 4, 2);  // fuzz_lcm's selector: map_update_t
  EXPECT_THROW((void)io::decode_map_update(std::span(old_bytes).subspan(1)), InputError);

  io::MapUpdate far;
  far.frame_id = 4;
  map::MapCell cell = map::map_cell_of(test::rect_cell(2, {2, 1.5f, 5}, {1, 0, 0}, {0, 0, 1}, 3), 2, 4, 1);
  std::vector<Eigen::Vector3f> vertices = cell.vertices_m.vertices();
  vertices[1].x() = -1.2e31f;
  cell.vertices_m = map::StoredPolygon(vertices);
  far.added_cells = {cell};
  far.relabelled_cells = {{0, 1}};
  far.next_cell_id = 3;
  far.next_surface_id = 2;
  io::MapUpdateAssembler assembler;
  const auto update =
      assembler.add(io::decode_map_update(io::encode_bytes(io::encode_map_update(far, 1000).at(0))));
  ASSERT_TRUE(update.has_value());
  io::MapMirror mirror;  // as in fuzz_lcm: two mirrored road cells the update relabels
  for (std::uint32_t id = 0; id < 2; ++id)
    mirror.cells.emplace(id, map::map_cell_of(test::rect_cell(id, {static_cast<float>(id), 1.5f, 5},
                                                              {1, 0, 0}, {0, 0, 1}, 3),
                                               id, 0, id));
  mirror.apply(*update);
  EXPECT_THROW((void)services::mirror_to_map(mirror, MapConfig{}), StorageError);
}

/// fuzz_kitti_disparity_png crash-bee5897b (abort): "P5#…" passed the PNM signature check, but
/// OpenCV's PNM decoder wants white space after the magic, so imread went on to its DICOM decoder
/// ("DICM" at byte 128), where gdcm asserts. The signature check now mirrors OpenCV's and refuses
/// a DICOM tag at byte 128 whatever the first bytes say.
TEST(FuzzRegression, PnmMagicWithoutWhiteSpaceAndADicomTag) {
  test::ScratchDir dir;
  const std::vector<std::uint8_t> bytes = bytes_of_hex(
      "5035233535353535ffffffffffffffffffffffffffffffffffffffffff35373535ff093530ffffffff50ffd8ff353050"
      "b1ffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffff"
      "ffffffffffffffffffffffffffffffffffffffffffff7a35ffffffffffffffff4449434db1");
  ASSERT_EQ(bytes.size(), 133u);
  std::ofstream(dir / "finding.png", std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  EXPECT_CONTAINS(input_error_of([&] { (void)read_kitti_disparity(dir / "finding.png"); }),
                  "unrecognised signature");
  // A well-formed PNM whose byte 128 happens to start a DICOM tag is refused the same way.
  std::string pnm = "P5\n16 8\n255\n";
  pnm.resize(pnm.size() + 16 * 8, '\x40');  // 12 header bytes + 128 pixels: byte 128 is a pixel
  pnm.replace(128, 4, "DICM");
  write_text(dir / "tagged.pgm", pnm);
  EXPECT_CONTAINS(input_error_of([&] { (void)read_image_unchanged(dir / "tagged.pgm"); }),
                  "unrecognised signature");
  // Without the tag it reads.
  pnm.replace(128, 4, "@@@@");
  write_text(dir / "plain.pgm", pnm);
  EXPECT_EQ(read_image_unchanged(dir / "plain.pgm").size(), cv::Size(16, 8));
}

/// fuzz_kitti_disparity_png oom-b5ee2a71 (out-of-memory): an ASCII PPM header whose comments end
/// at '\r'. OpenCV ends a comment at '\n' or '\r' and read 399999 × 1930 px; the size peek ended
/// them at '\n' only, found no height and let imread allocate 2.3 GB. The peek now reads comments
/// like OpenCV, and a header it cannot read is refused before decoding.
TEST(FuzzRegression, PnmCommentsEndingAtCarriageReturnDoNotHideAHugeSize) {
  test::ScratchDir dir;
  const std::string finding =
      "P3\t399999\n##9P9\n##9P3\r#3\t3\r#\r\n##\r#3020\r#\r\n##\r1930\n#03\r#3\t3\r#\r\n##\r"
      "#3020\r#\r\n##\r1930\n#02";
  write_text(dir / "finding.png", finding);
  const std::string message = input_error_of([&] { (void)read_kitti_disparity(dir / "finding.png"); });
  EXPECT_CONTAINS(message, "399999");
  EXPECT_CONTAINS(message, "exceeds the limit");
  auto peek = [&](const std::string& header) {
    write_text(dir / "h.pgm", header);
    return peek_image_size(dir / "h.pgm");
  };
  EXPECT_EQ(peek("P5 # comment\r16\r# another\r8\r255\r"), (std::pair<std::int64_t, std::int64_t>{16, 8}));
  EXPECT_EQ(peek("P5\n# comment\n16 8\n255\n"), (std::pair<std::int64_t, std::int64_t>{16, 8}));
  // No height at all: refused before any decoder sees it.
  write_text(dir / "headless.pgm", "P5\n16\n# no height\n");
  EXPECT_CONTAINS(input_error_of([&] { (void)read_image_unchanged(dir / "headless.pgm"); }),
                  "cannot read the image size");
}

/// fuzz_lcm crash-f0f7ba7d (ASan out-of-memory): a map_stats_t whose queue count claims ~10⁹
/// names made the generated decoder resize a vector<string> to 31 GB. decode_map_stats now walks
/// the whole layout (every count and string length against the bytes left) before decoding.
TEST(FuzzRegression, LcmMapStatsWithAHugeQueueCount) {
  const std::string hex =
      "03e8441ba7abe8fe55000000000000000000000000000000000000000000000000000000000000000000000000000000"
      "000000000000000000000000010000000473676d0042700000428c0000000200003a2f2f000000000000000000000000"
      "0000";
  const std::vector<std::uint8_t> bytes = bytes_of_hex(hex);
  ASSERT_EQ(bytes.front() % 4, 3);  // fuzz_lcm's selector: map_stats_t
  EXPECT_CONTAINS(input_error_of([&] { (void)io::decode_map_stats(std::span(bytes).subspan(1)); }),
                  "map_stats_t: 97 bytes are not one whole message");
  // A well-formed message with the same stage still decodes.
  planecell_lcm::map_stats_t stats{};
  stats.num_stages = 1;
  stats.stage = {"sgm"};
  stats.p50_ms = {60.0f};
  stats.p95_ms = {70.0f};
  stats.p99_ms = {80.0f};
  stats.num_queues = 2;
  stats.queue = {"frames", "cells"};
  stats.queue_depth = {2, 0};
  stats.map_cells = 7;
  const auto back = io::decode_map_stats(io::encode_bytes(stats));
  EXPECT_EQ(back.queue, stats.queue);
  EXPECT_EQ(back.map_cells, 7);
}

}  // namespace
}  // namespace planecell::io
