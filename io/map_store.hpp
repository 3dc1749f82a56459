#pragma once
/// Durable store of the global planecell map: SQLite in WAL mode, one transaction per frame.
///
/// Schema: meta(key, value) with format = 'planecell-map', version, the map's id counters and
/// settled_frame (present while the map is settled after that frame, GlobalMap::settle);
/// frames(frame_id, pose, counts, input_pose: the odometry pose before refinement, NULL when the
/// pose was used as given); cells(id, frame_id, surface, fields as columns, plane and polygon as
/// little-endian blobs); cell_bounds (R*Tree on each cell's 3D bounds); surfaces(id, blob: the
/// encoding's size as u32, then that encoding deflated by zlib); merges(seq, frame_id, absorbed,
/// into_surface). Blob layouts: io/map_codec (version 6: reals as floats and vertices as
/// millimetre varints wherever that is exact, which the map's storage precision makes nearly
/// everywhere). Every value is stored exactly, so a reopened store rebuilds a GlobalMap equal to
/// the one committed. Other tools can read it while
/// it is written (their brief locks are waited out for up to 5 s before a StorageError).
/// (io/planecell_codec is not used: it is lossy and camera-frame; the map needs exact world cells.)
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/config/map_config.hpp"
#include "core/pose.hpp"
#include "mapping/map/global_map.hpp"

struct sqlite3;

namespace planecell::io {

/// Everything needed to rebuild a GlobalMap (GlobalMap::restore).
struct StoredMap {
  std::vector<map::MapCell> cells;
  std::vector<map::Surface> surfaces;
  std::uint32_t next_cell_id = 0;
  std::uint32_t next_surface_id = 0;
  std::optional<std::uint64_t> last_frame_id;  ///< the last committed frame; none in a new store
  /// The map was settled after last_frame_id (MapStore::commit_settle) and no frame came since.
  bool settled = false;
};

/// Bytes of the store's pages by what they hold (MapStore::bytes_by_part): SQLite pages of each
/// table and its indexes, as SQLite's dbstat table counts them (page size × pages).
struct StoreBytes {
  std::size_t cells = 0;     ///< cells table
  std::size_t bounds = 0;    ///< the R*Tree on cell bounds (its node, rowid and parent tables)
  std::size_t surfaces = 0;  ///< surfaces table (deflated blobs)
  std::size_t frames = 0;    ///< frames table (poses, counts)
  std::size_t merges = 0;    ///< merge history
  std::size_t other = 0;     ///< schema, meta, sequence counters, indexes of those
  std::size_t free = 0;      ///< free pages (reused by later frames; compact() drops them)
  std::size_t total() const { return cells + bounds + surfaces + frames + merges + other + free; }
};

class MapStore {
 public:
  /// Opens the store at `path`, creating it when the file does not exist. An existing file that is
  /// not a planecell map (not SQLite, a foreign SQLite database, truncated or corrupt) raises
  /// StorageError naming the path and is left untouched. A store of an earlier version is upgraded
  /// in place in one transaction: 5 (reals and vertices as raw IEEE bytes), 4 (as 5 with raw
  /// surface blobs and an unused cells_by_surface index) and 3 (as 4, and before frames kept their
  /// input poses). An upgraded map keeps its values bit for bit (raw forms where they are not
  /// floats).
  explicit MapStore(const std::filesystem::path& path);
  ~MapStore();
  MapStore(const MapStore&) = delete;
  MapStore& operator=(const MapStore&) = delete;

  /// Writes one integrated frame in one transaction: the frame and its pose, the report's added
  /// cells (from `map`), relabelled and removed cells, updated and removed surfaces, the merge
  /// events and the id counters. On failure (disk full, I/O error, duplicate frame id) the
  /// transaction is rolled back, earlier frames stay intact, and StorageError names the path.
  /// `input_pose`: the pose the frame came with when pose refinement replaced it by T_world_cam.
  void commit_frame(std::uint64_t frame_id, const Pose& T_world_cam, const map::MergeReport& report,
                    const map::GlobalMap& map, const std::optional<Pose>& input_pose = std::nullopt);

  /// Writes the report of GlobalMap::settle (after the store's last frame, report.frame_id) in one
  /// transaction, like a frame's changes but without a frame row, and marks the store settled
  /// after that frame (meta 'settled_frame'; the next commit_frame clears it). StorageError when
  /// report.frame_id is not the store's last frame or the write fails (rolled back, the store is
  /// left as it was).
  void commit_settle(const map::MergeReport& report, const map::GlobalMap& map);

  /// Rewrites the database without free pages and with full B-tree pages (the R*Tree rebuilt in
  /// cell id order, then SQLite VACUUM), for the end of a session: frames committed one by one
  /// leave pages of updated surfaces and R*Tree nodes of deleted cells part-empty.
  /// The map read back is unchanged. Needs free disk room for a copy of the store; on failure
  /// (a full disk) the store is left as it was and StorageError names the path.
  void compact();

  /// Reads the whole map back. Throws StorageError on corrupt rows.
  StoredMap load() const;

  std::size_t frame_count() const;
  std::vector<std::uint64_t> frame_ids() const;
  std::optional<Pose> pose(std::uint64_t frame_id) const;
  /// The frame's pose before refinement; nullopt when it was used as given (or no such frame).
  std::optional<Pose> input_pose(std::uint64_t frame_id) const;
  std::vector<map::SurfaceMerge> merge_history() const;
  /// Where the store's pages go. total() = page count × page size of the database (committed
  /// frames, including those still in the WAL file). Throws StorageError when the SQLite library
  /// lacks its dbstat table (SQLITE_ENABLE_DBSTAT_VTAB; Debian's has it).
  StoreBytes bytes_by_part() const;
  /// Ids of cells whose stored bounds overlap `box` (R*Tree query; bounds are rounded outward
  /// to float by SQLite).
  std::vector<std::uint32_t> cells_in_box(const map::Aabb& box) const;

  const std::filesystem::path& path() const { return path_; }

 private:
  [[noreturn]] void fail(const std::string& what) const;
  /// The pose blob `sql` selects for `frame_id` (one `?`); nullopt when no row or NULL.
  std::optional<Pose> read_pose(const char* sql, std::uint64_t frame_id, const char* what) const;
  void exec(const char* sql) const;
  /// The report's cell and surface changes, merge events and id counters (inside a transaction);
  /// `what` names the commit in errors.
  void write_changes(const std::string& what, const map::MergeReport& report, const map::GlobalMap& map);

  std::filesystem::path path_;
  sqlite3* db_ = nullptr;
};

/// Rebuilds a map read from a store (MapStore::load) as a GlobalMap with `config`.
inline map::GlobalMap load_map(StoredMap stored, const MapConfig& config = {}) {
  return map::GlobalMap::restore(config, std::move(stored.cells), std::move(stored.surfaces),
                                 stored.next_cell_id, stored.next_surface_id, stored.last_frame_id,
                                 stored.settled);
}

/// Rebuilds the stored map as a GlobalMap with `config`.
inline map::GlobalMap load_map(const MapStore& store, const MapConfig& config = {}) {
  return load_map(store.load(), config);
}

}  // namespace planecell::io
