/// Map store: round trip of a merged map through SQLite, reopen, foreign/truncated files,
/// and a failed write (file-size limit in a forked child) leaving committed frames intact.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

#include <csignal>
#include <cstring>
#include <fstream>
#include <functional>
#include <sstream>
#include <tuple>

#include "core/error.hpp"
#include "io/map_codec.hpp"
#include "io/map_store.hpp"
#include "support/expect_error.hpp"
#include "support/planecell_fixtures.hpp"
#include "support/test_data.hpp"

namespace planecell::io {
namespace {

const Eigen::Vector3f kX(1, 0, 0), kY(0, 1, 0), kZ(0, 0, 1);

/// The shared rectangular cell with every stored field set to a non-default value (so a lossy
/// round trip of any field shows).
Planecell rect_cell(std::uint32_t id, const Eigen::Vector3f& corner, const Eigen::Vector3f& e1,
                    const Eigen::Vector3f& e2, int colour_bin) {
  Planecell c = test::rect_cell(id, corner, e1, e2, colour_bin);
  c.disparity_plane = {0.01 * id, -0.02, 30.0 + id};
  c.histogram[colour_bin] = 0.75f;
  c.histogram[(colour_bin + 1) % kColourHistogramBins] = 0.25f;
  c.mean_rgb = Eigen::Vector3f(4.0f * colour_bin, 100.3f, 50.1f);
  c.area_px = 400 + id;
  c.inlier_count = 350 + id;
  c.inlier_ratio = 0.875f;
  c.depth_sigma_m = 0.0625f + 0.001f * static_cast<float>(id);
  c.vertices_px = {{0, 0}, {20.5f, 0}, {20, 20}, {0, 20.25f}};
  return c;
}

/// Frame f of a synthetic drive: a road strip (merging, fusing) plus a wall cell per frame; frame 2
/// bridges two road pieces so a surface merge happens. `cells_per_row` scales the frame's size.
std::vector<Planecell> frame_cells(int f, int cells_per_row = 4) {
  std::vector<Planecell> cells;
  if (f == 0) {
    cells.push_back(rect_cell(0, {0, 1.5f, 5}, kX, kZ, 3));
    cells.push_back(rect_cell(1, {2, 1.5f, 5}, kX, kZ, 3));
    return cells;
  }
  if (f == 1) {
    cells.push_back(rect_cell(0, {1, 1.5f, 5}, kX, kZ, 3));  // bridge: merges the two surfaces
    return cells;
  }
  for (int i = 0; i < cells_per_row; ++i)
    cells.push_back(rect_cell(static_cast<std::uint32_t>(i), {static_cast<float>(i), 1.5f, 4.0f + f}, kX, kZ, 3));
  cells.push_back(rect_cell(static_cast<std::uint32_t>(cells_per_row), {-1, 0, 4.0f + f}, kZ, kY, 20));
  return cells;
}

Pose frame_pose(int f) {
  Pose pose = Pose::Identity();
  pose.translation() = Eigen::Vector3d(0.1 * f, 0, f);
  return pose;
}

/// Integrates frames [0, count) into `map` and, when given, commits each to `store`.
void drive(map::GlobalMap& map, int count, MapStore* store, int cells_per_row = 4) {
  for (int f = 0; f < count; ++f) {
    const auto report = map.integrate(static_cast<std::uint64_t>(f), frame_pose(f),
                                      frame_cells(f, cells_per_row));
    if (store) store->commit_frame(static_cast<std::uint64_t>(f), frame_pose(f), report, map);
  }
}

std::string read_bytes(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Runs `body` in a forked child with SIGXFSZ ignored (a write past RLIMIT_FSIZE then fails
/// with EFBIG instead of killing the process) and returns the child's exit code: body's result,
/// or 4 when it throws.
int exit_code_in_child(const std::function<int()>& body) {
  const pid_t child = fork();
  if (child < 0) return -1;
  if (child == 0) {
    int code = 4;
    try {
      std::signal(SIGXFSZ, SIG_IGN);
      code = body();
    } catch (...) {
    }
    _exit(code);
  }
  int status = 0;
  if (waitpid(child, &status, 0) != child || !WIFEXITED(status)) return -1;
  return WEXITSTATUS(status);
}

/// Caps the size of every file this process writes at `bytes`.
void cap_file_size(rlim_t bytes) {
  const rlimit limit{bytes, bytes};
  setrlimit(RLIMIT_FSIZE, &limit);
}

/// 0 when `write` raises a StorageError naming `path`, 3 when its message lacks the path, 2 when
/// it succeeds.
int storage_error_code(const std::filesystem::path& path, const std::function<void()>& write) {
  try {
    write();
    return 2;
  } catch (const StorageError& e) {
    return std::string(e.what()).find(path.string()) != std::string::npos ? 0 : 3;
  }
}

constexpr const char* kChildCodes =
    "child exit codes: 2 = the write succeeded, 3 = message without the path, 4 = unexpected "
    "error, -1 = the child did not exit";

TEST(MapStoreTest, RoundTripReopenResumesTheMapExactly) {
  test::ScratchDir dir;
  const auto path = dir / "map.db";
  map::GlobalMap map;
  {
    MapStore store(path);
    drive(map, 6, &store);
    EXPECT_EQ(store.frame_count(), 6u);
  }
  ASSERT_EQ(map.surfaces().size(), 2u);  // road and wall
  MapStore reopened(path);
  EXPECT_EQ(reopened.frame_ids(), (std::vector<std::uint64_t>{0, 1, 2, 3, 4, 5}));
  const auto pose3 = reopened.pose(3);
  ASSERT_TRUE(pose3.has_value());
  EXPECT_TRUE(pose3->matrix() == frame_pose(3).matrix());
  EXPECT_FALSE(reopened.pose(99).has_value());
  // The bridging frame merged surface 1 into surface 0.
  const auto merges = reopened.merge_history();
  ASSERT_EQ(merges.size(), 1u);
  EXPECT_EQ(merges[0], (map::SurfaceMerge{1, 1, 0}));
  map::GlobalMap loaded = load_map(reopened);
  EXPECT_TRUE(loaded.same_content(map));
  EXPECT_EQ(loaded.map_bytes() > 0, true);

  // Resume: continuing on the loaded map gives the same result as never stopping.
  map::GlobalMap continuous = map;
  const auto r_cont = continuous.integrate(6, frame_pose(6), frame_cells(6));
  const auto r_loaded = loaded.integrate(6, frame_pose(6), frame_cells(6));
  EXPECT_EQ(r_loaded.added_cells, r_cont.added_cells);
  EXPECT_TRUE(loaded.same_content(continuous));
  reopened.commit_frame(6, frame_pose(6), r_loaded, loaded);
  EXPECT_TRUE(load_map(reopened).same_content(continuous));
  // A frame id can be committed once.
  EXPECT_THROW(reopened.commit_frame(6, frame_pose(6), r_loaded, loaded), StorageError);
  EXPECT_EQ(reopened.frame_count(), 7u);
}

TEST(MapStoreTest, SettlingIsCommittedAfterTheLastFrameAndResumes) {
  test::ScratchDir dir;
  const auto path = dir / "map.db";
  MapConfig config;
  config.consolidate_after_frames = 3;
  config.dormant_after_frames = 3;
  map::GlobalMap map(config);
  MapStore store(path);
  for (int f = 0; f < 8; ++f) {
    const auto report = map.integrate(static_cast<std::uint64_t>(f), frame_pose(f), frame_cells(f));
    store.commit_frame(static_cast<std::uint64_t>(f), frame_pose(f), report, map);
  }
  EXPECT_FALSE(store.load().settled);
  // Only after the store's last frame.
  map::GlobalMap early = map;
  const auto early_report = early.settle(5);
  EXPECT_CONTAINS(test::error_of<StorageError>([&] { store.commit_settle(early_report, early); }),
                  "the settling after frame 5: it is not the store's last frame");
  EXPECT_TRUE(load_map(store, config).same_content(map));
  const auto report = map.settle(7);
  ASSERT_FALSE(report.dormant_surfaces.empty());
  ASSERT_GT(report.consolidated_cells, 0u);
  store.commit_settle(report, map);
  EXPECT_EQ(store.frame_count(), 8u);  // no frame row
  {
    MapStore reopened(path);
    const StoredMap stored = reopened.load();
    EXPECT_TRUE(stored.settled);
    EXPECT_EQ(stored.last_frame_id, std::optional<std::uint64_t>(7));
    map::GlobalMap loaded = load_map(reopened, config);
    EXPECT_TRUE(loaded.same_content(map));
    // The next frame: the same on the reopened map as in memory, and the store no longer settled.
    const auto next = loaded.integrate(8, frame_pose(8), frame_cells(8));
    map.integrate(8, frame_pose(8), frame_cells(8));
    EXPECT_TRUE(loaded.same_content(map));
    reopened.commit_frame(8, frame_pose(8), next, loaded);
    EXPECT_FALSE(reopened.load().settled);
    EXPECT_TRUE(load_map(reopened, config).same_content(map));
  }
}

TEST(MapStoreTest, RTreeAnswersBoxQueriesOverCellBounds) {
  test::ScratchDir dir;
  map::GlobalMap map;
  MapStore store(dir / "map.db");
  drive(map, 4, &store);
  map::Aabb box;
  box.extend(Eigen::Vector3d(-2, -1, 0));
  box.extend(Eigen::Vector3d(10, 2, 6.5));  // z ≤ 6.5: frames 0–2 (z from 5 to 7 overlap)
  EXPECT_EQ(store.cells_in_box(box), map.cells_near(box));
  EXPECT_FALSE(store.cells_in_box(box).empty());
}

/// The integer `sql` selects from the database at `path`, read by a second connection (it sees
/// the frames committed to the WAL too).
std::size_t query_integer(const std::filesystem::path& path, const char* sql) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  std::size_t value = 0;
  sqlite3_stmt* s = nullptr;
  if (sqlite3_prepare_v2(db, sql, -1, &s, nullptr) == SQLITE_OK && sqlite3_step(s) == SQLITE_ROW)
    value = static_cast<std::size_t>(sqlite3_column_int64(s, 0));
  else
    ADD_FAILURE() << sql << ": " << sqlite3_errmsg(db);
  sqlite3_finalize(s);
  sqlite3_close(db);
  return value;
}

TEST(MapStoreTest, BytesByPartAccountForEveryPage) {
  test::ScratchDir dir;
  const auto path = dir / "map.db";
  MapStore store(path);
  const std::size_t page = query_integer(path, "PRAGMA page_size");
  const char* kDatabaseBytes =
      "SELECT page_count * page_size FROM pragma_page_count, pragma_page_size";
  EXPECT_EQ(page, 2048u);  // a new store's pages (SQLite's default is 4096)
  // A new store: every table is an empty B-tree of one root page; the R*Tree is three tables
  // (nodes, holding the empty root node; rowid map; parent map).
  const StoreBytes empty = store.bytes_by_part();
  EXPECT_EQ(empty.cells, page);
  EXPECT_EQ(empty.surfaces, page);
  EXPECT_EQ(empty.frames, page);
  EXPECT_EQ(empty.merges, page);
  EXPECT_EQ(empty.bounds, 3 * page);
  EXPECT_EQ(empty.free, 0u);
  EXPECT_EQ(empty.total(), query_integer(path, kDatabaseBytes));
  // 40 frames of 24 road cells and a wall cell: cells, bounds and frames outgrow their root page,
  // and the parts still add up to the whole database.
  map::GlobalMap map;
  drive(map, 40, &store, 24);
  const StoreBytes full = store.bytes_by_part();
  EXPECT_GT(full.cells, page);
  EXPECT_GT(full.bounds, 3 * page);
  EXPECT_GT(full.frames, page);
  EXPECT_EQ(full.total(), query_integer(path, kDatabaseBytes));
}

TEST(MapStoreTest, ForeignTextFileIsRejectedAndLeftUnchanged) {
  test::ScratchDir dir;
  const auto path = dir / "map.db";
  {
    std::ofstream out(path);
    out << "this is not a map\n";
  }
  const std::string before = read_bytes(path);
  try {
    MapStore store(path);
    FAIL() << "expected StorageError";
  } catch (const StorageError& e) {
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
  }
  EXPECT_EQ(read_bytes(path), before);
}

TEST(MapStoreTest, ForeignSqliteDatabaseIsRejectedAndLeftUnchanged) {
  test::ScratchDir dir;
  const auto path = dir / "other.db";
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "CREATE TABLE t(x); INSERT INTO t VALUES (1);", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  const std::string before = read_bytes(path);
  EXPECT_THROW(MapStore{path}, StorageError);
  EXPECT_EQ(read_bytes(path), before);
}

/// A store of another format version (v2 kept the image-side cell fields) is refused with both
/// versions named, and not touched.
TEST(MapStoreTest, OtherFormatVersionIsRejectedByNameAndLeftUnchanged) {
  test::ScratchDir dir;
  const auto path = dir / "old.db";
  {
    MapStore store(path);
    map::GlobalMap map;
    drive(map, 2, &store);
  }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "UPDATE meta SET value='2' WHERE key='version';", nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  const std::string before = read_bytes(path);
  try {
    MapStore store(path);
    FAIL() << "expected StorageError";
  } catch (const StorageError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("version '2' is not the version 8"), std::string::npos) << what;
    EXPECT_NE(what.find(path.string()), std::string::npos) << what;
  }
  EXPECT_EQ(read_bytes(path), before);
}

TEST(MapStoreTest, RefinedFramesKeepTheirInputPoseBesideTheRefinedOne) {
  test::ScratchDir dir;
  MapStore store(dir / "map.db");
  map::GlobalMap map;
  const auto report = map.integrate(0, frame_pose(0), frame_cells(0));
  Pose odometry = frame_pose(0);
  odometry.translation() += Eigen::Vector3d(0.03, -0.01, 0.02);
  store.commit_frame(0, frame_pose(0), report, map, odometry);
  const auto second = map.integrate(1, frame_pose(1), frame_cells(1));
  store.commit_frame(1, frame_pose(1), second, map);  // not refined: no input pose
  ASSERT_TRUE(store.input_pose(0).has_value());
  EXPECT_TRUE(store.input_pose(0)->isApprox(odometry, 0.0));
  EXPECT_TRUE(store.pose(0)->isApprox(frame_pose(0), 0.0));
  EXPECT_FALSE(store.input_pose(1).has_value());
  EXPECT_FALSE(store.input_pose(7).has_value());  // no such frame
}

/// Applies `edit` to the stored surface blobs (all, or only the one with the smallest id) and
/// writes them back; returns how many were edited.
std::size_t edit_surfaces(const std::filesystem::path& path,
                          const std::function<void(std::vector<std::uint8_t>&)>& edit, bool first_only = false) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  std::vector<std::pair<std::int64_t, std::vector<std::uint8_t>>> blobs;
  sqlite3_stmt* read = nullptr;
  const char* select = first_only ? "SELECT id, data FROM surfaces ORDER BY id LIMIT 1" : "SELECT id, data FROM surfaces";
  EXPECT_EQ(sqlite3_prepare_v2(db, select, -1, &read, nullptr), SQLITE_OK);
  while (sqlite3_step(read) == SQLITE_ROW) {
    const auto* blob = static_cast<const std::uint8_t*>(sqlite3_column_blob(read, 1));
    blobs.emplace_back(sqlite3_column_int64(read, 0),
                       std::vector<std::uint8_t>(blob, blob + sqlite3_column_bytes(read, 1)));
  }
  sqlite3_finalize(read);
  sqlite3_stmt* write = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(db, "UPDATE surfaces SET data = ? WHERE id = ?", -1, &write, nullptr), SQLITE_OK);
  for (auto& [id, data] : blobs) {
    edit(data);
    sqlite3_bind_blob(write, 1, data.data(), static_cast<int>(data.size()), SQLITE_TRANSIENT);
    sqlite3_bind_int64(write, 2, id);
    EXPECT_EQ(sqlite3_step(write), SQLITE_DONE);
    sqlite3_reset(write);
  }
  sqlite3_finalize(write);
  sqlite3_close(db);
  return blobs.size();
}

void edit_first_surface(const std::filesystem::path& path,
                        const std::function<void(std::vector<std::uint8_t>&)>& edit) {
  ASSERT_EQ(edit_surfaces(path, edit, true), 1u);
}

/// Rewrites a current (version 7) store as an earlier release wrote it: surface blobs (the
/// deflated stream after the 4-byte raw size, inflated here with zlib directly, which also checks
/// the documented layout) and cell planes and vertices re-encoded as `version` wrote them, for
/// 3 and 4 the cells_by_surface index, and for 3 no frames.input_pose.
void make_legacy_store(const std::filesystem::path& path, int version) {
  const std::size_t surfaces = edit_surfaces(path, [&](std::vector<std::uint8_t>& data) {
    ASSERT_GT(data.size(), 4u);
    std::uint32_t raw_size = 0;
    std::memcpy(&raw_size, data.data(), 4);
    std::vector<std::uint8_t> raw(raw_size);
    uLongf inflated = raw_size;
    ASSERT_EQ(uncompress(raw.data(), &inflated, data.data() + 4, data.size() - 4), Z_OK);
    ASSERT_EQ(inflated, raw_size);
    data = map_codec::encode_surface(map_codec::decode_surface(0, data.data(), data.size(), "test"),
                                     version);
  });
  ASSERT_GT(surfaces, 0u);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  std::vector<std::tuple<std::int64_t, std::vector<std::uint8_t>, std::vector<std::uint8_t>>> cells;
  sqlite3_stmt* read = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT id, plane, vertices_m FROM cells", -1, &read, nullptr),
            SQLITE_OK);
  while (sqlite3_step(read) == SQLITE_ROW) {
    const auto plane = map_codec::decode_plane(sqlite3_column_blob(read, 1),
                                               sqlite3_column_bytes(read, 1), "test");
    const auto vertices = map_codec::decode_vertices(sqlite3_column_blob(read, 2),
                                                     sqlite3_column_bytes(read, 2), "test");
    cells.emplace_back(sqlite3_column_int64(read, 0), map_codec::encode_plane(plane, version),
                       map_codec::encode_vertices(vertices, version));
  }
  sqlite3_finalize(read);
  ASSERT_FALSE(cells.empty());
  sqlite3_stmt* write = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "UPDATE cells SET plane = ?, vertices_m = ? WHERE id = ?", -1,
                               &write, nullptr),
            SQLITE_OK);
  for (const auto& [id, plane, vertices] : cells) {
    sqlite3_bind_blob(write, 1, plane.data(), static_cast<int>(plane.size()), SQLITE_TRANSIENT);
    sqlite3_bind_blob(write, 2, vertices.data(), static_cast<int>(vertices.size()),
                      SQLITE_TRANSIENT);
    sqlite3_bind_int64(write, 3, id);
    EXPECT_EQ(sqlite3_step(write), SQLITE_DONE);
    sqlite3_reset(write);
  }
  sqlite3_finalize(write);
  const std::string sql =
      std::string(version <= 4 ? "CREATE INDEX cells_by_surface ON cells(surface);" : "") +
      "UPDATE meta SET value='" + std::to_string(version) + "' WHERE key='version';" +
      (version == 3 ? "ALTER TABLE frames DROP COLUMN input_pose;" : "");
  ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
  sqlite3_close(db);
}

/// The schema's index names (sqlite_master), to see the upgrade drop cells_by_surface.
std::vector<std::string> index_names(const std::filesystem::path& path) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  std::vector<std::string> names;
  sqlite3_exec(db, "SELECT name FROM sqlite_master WHERE type='index' AND name NOT LIKE 'sqlite_%'",
               [](void* out, int, char** values, char**) {
                 static_cast<std::vector<std::string>*>(out)->push_back(values[0]);
                 return 0;
               },
               &names, nullptr);
  sqlite3_close(db);
  return names;
}

/// What a store of a version before 8 gives back of `map`: each surface's frame count is its
/// observation count (those versions did not count frames).
map::GlobalMap with_observations_as_frame_counts(const map::GlobalMap& map) {
  std::vector<map::MapCell> cells;
  for (const auto& [id, cell] : map.cells()) cells.push_back(cell);
  std::vector<map::Surface> surfaces;
  for (const auto& [id, surface] : map.surfaces()) {
    surfaces.push_back(surface);
    surfaces.back().frames_observed = surface.observations;
  }
  return map::GlobalMap::restore(map.config(), std::move(cells), std::move(surfaces), map.next_cell_id(),
                                 map.next_surface_id());
}

/// Versions 7 (no frame counts), 6 (dense histograms, no dormant surfaces, no last observed
/// frame), 5 (as 6 with raw reals and float vertices) and 4 (as 5 with raw surface blobs and the
/// cells_by_surface index) are upgraded to version 8: the map and input poses read back are the
/// ones written, with each surface's observation count as its frame count (every surface of this
/// drive was observed in its last frame, which the upgrade from 6 and before takes as each
/// surface's last observed frame), and the store reads as version 8 afterwards.
TEST(MapStoreTest, VersionSevenSixFiveAndFourStoresAreUpgradedInPlaceAndResume) {
  for (const int version : {7, 6, 5, 4}) {
    SCOPED_TRACE(version);
    test::ScratchDir dir;
    const auto path = dir / "old.db";
    map::GlobalMap written;
    {
      MapStore store(path);
      drive(written, 4, &store);
      store.commit_frame(4, frame_pose(4), written.integrate(4, frame_pose(4), frame_cells(4)),
                         written, frame_pose(3));
    }
    for (const auto& [id, surface] : written.surfaces()) ASSERT_EQ(surface.last_observed_frame, 4u);
    // The drive's surfaces hold more cells than frames: the upgrade changes their counts.
    ASSERT_TRUE(std::any_of(written.surfaces().begin(), written.surfaces().end(), [](const auto& entry) {
      return entry.second.observations != entry.second.frames_observed;
    }));
    const map::GlobalMap upgraded = with_observations_as_frame_counts(written);
    make_legacy_store(path, version);
    ASSERT_EQ(index_names(path).size(), version == 4 ? 1u : 0u);
    {
      MapStore store(path);
      EXPECT_EQ(store.frame_count(), 5u);
      EXPECT_TRUE(store.input_pose(4)->isApprox(frame_pose(3), 0.0));  // kept through the upgrade
      EXPECT_TRUE(load_map(store).same_content(upgraded));
    }
    EXPECT_TRUE(index_names(path).empty());
    MapStore again(path);  // version 8 now: read as it is
    EXPECT_TRUE(load_map(again).same_content(upgraded));
  }
}

TEST(MapStoreTest, VersionThreeStoreIsUpgradedInPlaceAndResumes) {
  test::ScratchDir dir;
  const auto path = dir / "v3.db";
  map::GlobalMap written;
  {
    MapStore store(path);
    drive(written, 3, &store);
  }
  make_legacy_store(path, 3);
  {
    MapStore store(path);
    EXPECT_EQ(store.frame_count(), 3u);
    EXPECT_TRUE(store.pose(2)->isApprox(frame_pose(2), 0.0));
    EXPECT_FALSE(store.input_pose(2).has_value());
    map::GlobalMap resumed = load_map(store);
    EXPECT_TRUE(resumed.same_content(with_observations_as_frame_counts(written)));
    // New frames record their input pose in the upgraded store.
    const auto report = resumed.integrate(3, frame_pose(3), frame_cells(3));
    store.commit_frame(3, frame_pose(3), report, resumed, frame_pose(2));
    EXPECT_TRUE(store.input_pose(3)->isApprox(frame_pose(2), 0.0));
  }
  // Reopened: version 8 now, no second upgrade.
  MapStore again(path);
  EXPECT_EQ(again.frame_count(), 4u);
  EXPECT_TRUE(again.input_pose(3)->isApprox(frame_pose(2), 0.0));
}

/// A surface whose deflated bytes were damaged (zlib's Adler-32 catches a flipped byte) or whose
/// raw size lies is a StorageError naming the surface, not a wrong map.
TEST(MapStoreTest, CorruptDeflatedSurfaceIsNamed) {
  test::ScratchDir dir;
  const auto path = dir / "map.db";
  const auto load_error = [&] {
    try {
      MapStore store(path);
      (void)store.load();
    } catch (const StorageError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const auto set_raw_size = [](std::uint32_t size) {
    return [size](std::vector<std::uint8_t>& data) { std::memcpy(data.data(), &size, 4); };
  };
  {
    map::GlobalMap map;
    MapStore store(path);
    drive(map, 3, &store);
  }
  std::uint32_t raw_size = 0;
  edit_first_surface(path, [&](std::vector<std::uint8_t>& data) {
    std::memcpy(&raw_size, data.data(), 4);
    data[data.size() / 2] ^= 0x55;
  });
  EXPECT_CONTAINS(load_error(), "compressed data is corrupt");
  edit_first_surface(path, [](std::vector<std::uint8_t>& data) { data[data.size() / 2] ^= 0x55; });  // mended
  EXPECT_EQ(load_error(), "no error");

  edit_first_surface(path, set_raw_size(raw_size + 1));  // inflates to fewer bytes than claimed
  EXPECT_CONTAINS(load_error(), "size mismatch");
  edit_first_surface(path, set_raw_size(raw_size - 1));  // the inflated bytes do not fit
  EXPECT_CONTAINS(load_error(), "compressed data is corrupt");
  edit_first_surface(path, set_raw_size(0xFFFFFFFFu));  // refused before any allocation
  const std::string huge = load_error();
  EXPECT_CONTAINS(huge, "claims 4294967295 bytes, beyond the limit");
  EXPECT_CONTAINS(huge, "surface ");
  edit_first_surface(path, [](std::vector<std::uint8_t>& data) { data.resize(3); });
  EXPECT_CONTAINS(load_error(), "truncated");
}

TEST(MapStoreTest, LogLeftFromADeletedStoreIsRefusedNotReplayedIntoANewOne) {
  test::ScratchDir dir;
  const auto path = dir / "map.db";
  const std::filesystem::path wal = path.string() + "-wal";
  std::string log;
  {
    map::GlobalMap map;
    MapStore store(path);
    drive(map, 4, &store);
    log = read_bytes(wal);  // the open store's log, as a killed writer leaves it
  }
  ASSERT_FALSE(log.empty());
  std::filesystem::remove(path);
  {
    std::ofstream out(wal, std::ios::binary);
    out.write(log.data(), static_cast<std::streamsize>(log.size()));
  }
  try {
    MapStore store(path);
    FAIL() << "expected StorageError";
  } catch (const StorageError& e) {
    EXPECT_CONTAINS(std::string(e.what()), "map store '" + path.string() + "': no store there, but '" +
                                               wal.string() + "' is left from a deleted one");
  }
  EXPECT_FALSE(std::filesystem::exists(path));  // nothing created
  EXPECT_EQ(read_bytes(wal), log);              // nor the log touched
  // Removed, a new map starts there.
  std::filesystem::remove(wal);
  map::GlobalMap map;
  MapStore store(path);
  drive(map, 2, &store);
  EXPECT_EQ(store.frame_count(), 2u);
}

TEST(MapStoreTest, TruncatedCopyIsRejected) {
  test::ScratchDir dir;
  const auto path = dir / "map.db";
  {
    map::GlobalMap map;
    MapStore store(path);
    drive(map, 8, &store);
  }
  const std::string full = read_bytes(path);
  ASSERT_GT(full.size(), 8192u);
  const auto copy = dir / "truncated.db";
  {
    std::ofstream out(copy, std::ios::binary);
    out.write(full.data(), static_cast<std::streamsize>(full.size() / 2));
  }
  try {
    MapStore store(copy);
    // Some truncations leave a readable prefix: the map must then fail to load, never be wrong.
    EXPECT_THROW(store.load(), StorageError);
  } catch (const StorageError& e) {
    EXPECT_NE(std::string(e.what()).find(copy.string()), std::string::npos) << e.what();
  }
}

TEST(MapStoreTest, CompactionShrinksTheFileAndKeepsTheMapWritable) {
  test::ScratchDir dir;
  const auto path = dir / "map.db";
  map::GlobalMap map;
  {
    MapStore store(path);
    drive(map, 120, &store, 24);
  }
  const auto before = std::filesystem::file_size(path);
  {
    MapStore store(path);
    store.compact();
  }
  const auto after = std::filesystem::file_size(path);
  // Surfaces rewritten frame after frame (the road's grows past a page: 120 frames, its deflated
  // blob then spills over) left free and half-empty pages behind.
  EXPECT_LT(after, before);
  MapStore store(path);
  EXPECT_EQ(store.frame_count(), 120u);
  EXPECT_TRUE(load_map(store).same_content(map));
  // The rebuilt R*Tree answers box queries as the map's own index does.
  for (const map::Aabb& box :
       {map::Aabb{Eigen::Vector3d(-2, -2, 0), Eigen::Vector3d(2, 2, 30)},
        map::Aabb{Eigen::Vector3d(-50, -50, -50), Eigen::Vector3d(50, 50, 500)}}) {
    EXPECT_EQ(store.cells_in_box(box), map.cells_near(box));
    EXPECT_FALSE(store.cells_in_box(box).empty());
  }
  const auto report = map.integrate(120, frame_pose(120), frame_cells(120, 24));
  store.commit_frame(120, frame_pose(120), report, map);
  EXPECT_TRUE(load_map(store).same_content(map));
}

TEST(MapStoreTest, CompactionWithoutDiskRoomLeavesTheStoreAsItWas) {
  test::ScratchDir dir;
  const auto path = dir / "map.db";
  constexpr int kCommitted = 12;
  {
    map::GlobalMap map;
    MapStore store(path);
    drive(map, kCommitted, &store, 8);
  }
  // Child: no room for VACUUM's copy (files capped at 1 KiB); compaction must fail with a
  // StorageError naming the store.
  const int code = exit_code_in_child([&] {
    MapStore store(path);
    cap_file_size(1024);
    return storage_error_code(path, [&] { store.compact(); });
  });
  ASSERT_EQ(code, 0) << kChildCodes;
  MapStore store(path);
  EXPECT_EQ(store.frame_count(), static_cast<std::size_t>(kCommitted));
  map::GlobalMap expected;
  drive(expected, kCommitted, nullptr, 8);
  EXPECT_TRUE(load_map(store).same_content(expected));
}

TEST(MapStoreTest, FailedWriteRaisesStorageErrorAndKeepsCommittedFrames) {
  test::ScratchDir dir;
  const auto path = dir / "map.db";
  constexpr int kCommitted = 4;
  // Child: commit frames, then cap the file size just above the current files and write a big
  // frame, which must fail with a StorageError naming the store.
  const int code = exit_code_in_child([&] {
    map::GlobalMap map;
    MapStore store(path);
    drive(map, kCommitted, &store);
    std::error_code ec;
    std::uintmax_t biggest = std::filesystem::file_size(path, ec);
    const auto wal = std::filesystem::path(path.string() + "-wal");
    if (std::filesystem::exists(wal)) biggest = std::max(biggest, std::filesystem::file_size(wal));
    cap_file_size(biggest + 1024);
    const auto report = map.integrate(kCommitted, frame_pose(kCommitted), frame_cells(kCommitted, 400));
    return storage_error_code(path, [&] { store.commit_frame(kCommitted, frame_pose(kCommitted), report, map); });
  });
  ASSERT_EQ(code, 0) << kChildCodes;
  // The committed frames are intact and equal to a map built from the same frames.
  MapStore store(path);
  EXPECT_EQ(store.frame_count(), static_cast<std::size_t>(kCommitted));
  map::GlobalMap expected;
  drive(expected, kCommitted, nullptr);
  EXPECT_TRUE(load_map(store).same_content(expected));
}

}  // namespace
}  // namespace planecell::io
