#include "io/map_store.hpp"

#include <spdlog/spdlog.h>
#include <sqlite3.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cstring>
#include <fstream>
#include <limits>
#include <type_traits>

#include "core/error.hpp"
#include "io/blob_bytes.hpp"
#include "io/map_codec.hpp"

namespace planecell::io {
namespace {

using blob::Reader;
using blob::Writer;

/// How long an operation waits for another connection's lock before failing (ms).
constexpr int kBusyTimeoutMs = 5000;

constexpr const char* kFormat = "planecell-map";
/// 8: surfaces count the frames that observed them (io/map_codec).
constexpr const char* kVersion = "8";
static_assert(map_codec::kCurrentVersion == 8, "kVersion names the codec's current version");
/// Versions upgraded in place: 7 (as 8 without the frame counts: the observation counts stand in),
/// 6 (every surface live, dense histograms), 5 (as 6 with reals and
/// vertices as raw IEEE bytes), 4 (as 5 with raw surface blobs and an unused cells_by_surface
/// index) and 3 (as 4 without frames.input_pose).
constexpr std::array<const char*, 5> kMigratableVersions = {"3", "4", "5", "6", "7"};

constexpr const char* kSchema = R"sql(
CREATE TABLE meta(key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE frames(frame_id INTEGER PRIMARY KEY, pose BLOB NOT NULL, input_cells INTEGER,
                    added_cells INTEGER, fused_cells INTEGER, merge_ms REAL, input_pose BLOB);
CREATE TABLE cells(id INTEGER PRIMARY KEY, frame_id INTEGER NOT NULL, surface INTEGER NOT NULL,
                   plane BLOB NOT NULL, vertices_m BLOB NOT NULL, mean_rgb BLOB NOT NULL,
                   depth_sigma_m REAL NOT NULL);
CREATE VIRTUAL TABLE cell_bounds USING rtree(id, min_x, max_x, min_y, max_y, min_z, max_z);
CREATE TABLE surfaces(id INTEGER PRIMARY KEY, data BLOB NOT NULL);
CREATE TABLE merges(seq INTEGER PRIMARY KEY AUTOINCREMENT, frame_id INTEGER NOT NULL,
                    absorbed INTEGER NOT NULL, into_surface INTEGER NOT NULL);
)sql";

/// A prepared statement bound to the store (finalized on destruction).
class Statement {
 public:
  Statement(sqlite3* db, const char* sql, const MapStore& store) : db_(db) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK)
      throw StorageError("map store '" + store.path().string() + "': " + sqlite3_errmsg(db));
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& bind(int i, std::int64_t v) { return check(sqlite3_bind_int64(stmt_, i, v)); }
  Statement& bind(int i, double v) { return check(sqlite3_bind_double(stmt_, i, v)); }
  Statement& bind(int i, const std::string& v) {
    return check(sqlite3_bind_text(stmt_, i, v.c_str(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
  }
  Statement& bind(int i, const std::vector<std::uint8_t>& v) {
    return check(sqlite3_bind_blob(stmt_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
  }
  /// SQLITE_ROW → true, SQLITE_DONE → false, otherwise the error code is returned via `rc`.
  bool step(int& rc) {
    rc = sqlite3_step(stmt_);
    return rc == SQLITE_ROW;
  }
  void reset() {
    sqlite3_reset(stmt_);
    sqlite3_clear_bindings(stmt_);
  }
  std::int64_t integer(int c) const { return sqlite3_column_int64(stmt_, c); }
  double real(int c) const { return sqlite3_column_double(stmt_, c); }
  std::string text(int c) const {
    const auto* p = sqlite3_column_text(stmt_, c);
    return p ? reinterpret_cast<const char*>(p) : "";
  }
  const void* blob(int c) const { return sqlite3_column_blob(stmt_, c); }
  std::size_t blob_size(int c) const { return static_cast<std::size_t>(sqlite3_column_bytes(stmt_, c)); }
  int last_rc = SQLITE_OK;

 private:
  Statement& check(int rc) {
    if (rc != SQLITE_OK) throw StorageError(std::string("map store: bind failed: ") + sqlite3_errmsg(db_));
    return *this;
  }
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
};

/// Runs a statement to completion; throws via `fail` on an error code.
template <class Fail>
void run(Statement& s, Fail&& fail) {
  int rc = SQLITE_OK;
  while (s.step(rc)) {
  }
  if (rc != SQLITE_DONE) fail();
  s.reset();
}

}  // namespace

void MapStore::fail(const std::string& what) const {
  throw StorageError("map store '" + path_.string() + "': " + what +
                     (db_ ? std::string(" (") + sqlite3_errmsg(db_) + ")" : std::string()));
}

void MapStore::exec(const char* sql) const {
  char* message = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &message) != SQLITE_OK) {
    const std::string text = message ? message : "unknown error";
    sqlite3_free(message);
    throw StorageError("map store '" + path_.string() + "': " + text);
  }
}

MapStore::MapStore(const std::filesystem::path& path) : path_(path) {
  std::error_code ec;
  const bool exists = std::filesystem::exists(path, ec);
  if (exists) {
    // Refuse anything that is not an SQLite file before SQLite touches it.
    std::ifstream in(path, std::ios::binary);
    char header[16] = {};
    in.read(header, sizeof(header));
    if (!in || std::memcmp(header, "SQLite format 3\0", 16) != 0)
      throw StorageError("map store '" + path.string() +
                         "': not a planecell map (not an SQLite database); left unchanged");
  }
  // A write-ahead log beside a missing store is what is left of a deleted one (its writer was
  // killed, or the store was removed while open): SQLite would replay it into the new store's
  // pages and corrupt them ("database disk image is malformed" at the first commit).
  if (!exists)
    for (const char* suffix : {"-wal", "-journal"})
      if (const std::filesystem::path orphan = path.string() + suffix; std::filesystem::exists(orphan, ec))
        throw StorageError("map store '" + path.string() + "': no store there, but '" + orphan.string() +
                           "' is left from a deleted one; restore the store or remove " +
                           orphan.filename().string() + " (and " + path.filename().string() +
                           "-shm) to start a new map");
  // A new store is built as <path>.creating and renamed into place once its schema is committed,
  // so a process killed while creating it never leaves a half-made file at `path` (which the
  // checks below would refuse as foreign). A stale .creating file from such a kill is replaced.
  const std::filesystem::path creating = path.string() + ".creating";
  if (!exists)
    for (const char* suffix : {"", "-wal", "-shm", "-journal"})
      std::filesystem::remove(creating.string() + suffix, ec);
  auto open = [&](const std::filesystem::path& file, int flags) {
    if (sqlite3_open_v2(file.c_str(), &db_, flags, nullptr) != SQLITE_OK) {
      const std::string message = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      db_ = nullptr;
      throw StorageError("map store '" + path.string() + "': cannot open (" + message + ")");
    }
    sqlite3_extended_result_codes(db_, 1);
    // Other processes may read the store while it is written (planners, backups, `sqlite3`): a
    // lock they hold for a moment (WAL recovery, checkpoint) is waited out instead of failing.
    sqlite3_busy_timeout(db_, kBusyTimeoutMs);
  };
  open(exists ? path : creating, SQLITE_OPEN_READWRITE | (exists ? 0 : SQLITE_OPEN_CREATE));
  bool migrate = false;
  std::string from_version;
  try {
    if (exists) {
      // Read-only checks first: integrity, then the format marker.
      {
        Statement check(db_, "PRAGMA quick_check", *this);
        int rc = SQLITE_OK;
        std::string verdict;
        while (check.step(rc)) verdict += check.text(0);
        if (rc != SQLITE_DONE) fail("corrupt or truncated database");
        if (verdict != "ok") fail("corrupt or truncated database: " + verdict);
      }
      {
        Statement has_meta(db_, "SELECT count(*) FROM sqlite_master WHERE type='table' AND name='meta'", *this);
        int rc = SQLITE_OK;
        if (!has_meta.step(rc) || has_meta.integer(0) != 1)
          fail("a foreign SQLite database (no planecell meta table); left unchanged");
      }
      Statement format(db_, "SELECT value FROM meta WHERE key='format'", *this);
      int rc = SQLITE_OK;
      if (!format.step(rc) || format.text(0) != kFormat)
        fail("a foreign SQLite database (format is not 'planecell-map'); left unchanged");
      Statement version(db_, "SELECT value FROM meta WHERE key='version'", *this);
      const std::string found = version.step(rc) ? version.text(0) : std::string();
      migrate = std::find(kMigratableVersions.begin(), kMigratableVersions.end(), found) !=
                kMigratableVersions.end();
      if (found != kVersion && !migrate)
        fail("planecell map version '" + found + "' is not the version " + kVersion +
             " this build reads (written by another planecell release; left unchanged)");
      from_version = found;
    }
    // 2 KiB pages for a new store (SQLite's default is 4 KiB): the cell-bounds R*Tree's nodes and
    // the tables with a few rows (schema, merges) leave less of a page empty; 3 % smaller on a
    // 100-frame street at a lower write cost (1 KiB: no smaller, surface blobs spill into
    // overflow pages; docs/PERFORMANCE.md, "Consolidation and dormancy after 10 frames, 2 KiB
    // pages"). Set before the first table; an existing store keeps its page size.
    if (!exists) exec("PRAGMA page_size=2048");
    exec("PRAGMA journal_mode=WAL");
    exec("PRAGMA synchronous=NORMAL");
    if (migrate) {  // version 3 to 7 → 8 in one transaction
      const int from = std::stoi(from_version);
      exec("BEGIN IMMEDIATE");
      try {
        if (from == 3) exec("ALTER TABLE frames ADD COLUMN input_pose BLOB");  // NULL: as given
        exec("DROP INDEX IF EXISTS cells_by_surface");
        // The ids first: rows updated while a SELECT over their table is pending may be seen twice.
        const auto ids_of = [&](const char* sql, const char* what) {
          std::vector<std::uint32_t> ids;
          int rc = SQLITE_OK;
          Statement list(db_, sql, *this);
          while (list.step(rc)) ids.push_back(static_cast<std::uint32_t>(list.integer(0)));
          if (rc != SQLITE_DONE) fail(std::string("cannot list ") + what);
          return ids;
        };
        int rc = SQLITE_OK;
        // Surfaces written before version 7 do not say when they were last observed: the last
        // frame stands in, so none goes dormant before dormant_after_frames more frames.
        std::uint64_t last_frame = 0;
        {
          Statement last(db_, "SELECT max(frame_id) FROM frames", *this);
          if (last.step(rc)) last_frame = static_cast<std::uint64_t>(last.integer(0));  // NULL: 0
        }
        {
          Statement read(db_, "SELECT data FROM surfaces WHERE id = ?", *this);
          Statement write(db_, "UPDATE surfaces SET data = ? WHERE id = ?", *this);
          for (const std::uint32_t id : ids_of("SELECT id FROM surfaces", "surfaces")) {
            read.bind(1, std::int64_t{id});
            if (!read.step(rc)) fail("cannot read surface " + std::to_string(id));
            map::Surface surface =
                map_codec::decode_surface(id, read.blob(0), read.blob_size(0), path.string(), from);
            if (from < 7) surface.last_observed_frame = last_frame;
            read.reset();
            write.bind(1, map_codec::encode_surface(surface)).bind(2, std::int64_t{id});
            run(write, [&] { fail("cannot rewrite surface " + std::to_string(id)); });
          }
        }
        if (from < 6) {  // version 6 cells are as in 8
          Statement read(db_, "SELECT plane, vertices_m FROM cells WHERE id = ?", *this);
          Statement write(db_, "UPDATE cells SET plane = ?, vertices_m = ? WHERE id = ?", *this);
          for (const std::uint32_t id : ids_of("SELECT id FROM cells", "cells")) {
            read.bind(1, std::int64_t{id});
            if (!read.step(rc)) fail("cannot read cell " + std::to_string(id));
            const std::string what = path.string() + ": cell " + std::to_string(id);
            const Plane3 plane =
                map_codec::decode_plane(read.blob(0), read.blob_size(0), what + " plane", from);
            const auto vertices = map_codec::decode_vertices(read.blob(1), read.blob_size(1),
                                                             what + " vertices_m", from);
            read.reset();
            write.bind(1, map_codec::encode_plane(plane))
                .bind(2, map_codec::encode_vertices(vertices))
                .bind(3, std::int64_t{id});
            run(write, [&] { fail("cannot rewrite cell " + std::to_string(id)); });
          }
        }
        exec((std::string("UPDATE meta SET value = '") + kVersion + "' WHERE key = 'version'")
                 .c_str());
        exec("COMMIT");
      } catch (...) {
        sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
        throw;
      }
      spdlog::info("map store '{}': upgraded from version {} to {} ({}{}surfaces count their frames{})",
                   path.string(), from_version, kVersion, from < 6 ? "compact reals and vertices, " : "",
                   from < 7 ? "sparse histograms, dormant surfaces, " : "",
                   from == 3 ? "; frames keep their input poses from now on" : "");
    }
    if (!exists) {
      exec("BEGIN IMMEDIATE");
      exec(kSchema);
      {
        Statement meta(db_, "INSERT INTO meta(key, value) VALUES (?, ?)", *this);
        for (const auto& [k, v] : {std::pair<std::string, std::string>{"format", kFormat},
                                   {"version", kVersion}, {"next_cell_id", "0"}, {"next_surface_id", "0"}}) {
          meta.bind(1, k).bind(2, v);
          run(meta, [&] { fail("cannot write the schema"); });
        }
      }
      exec("COMMIT");
      // Closing checkpoints and removes the WAL, so the schema is all in `creating`.
      if (sqlite3_close(db_) != SQLITE_OK) fail("cannot finish creating the store");
      db_ = nullptr;
      std::filesystem::rename(creating, path, ec);
      if (ec) throw StorageError("map store '" + path.string() + "': cannot create (" + ec.message() + ")");
      open(path, SQLITE_OPEN_READWRITE);
      exec("PRAGMA synchronous=NORMAL");
    }
  } catch (...) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  }
}

MapStore::~MapStore() { sqlite3_close(db_); }

void MapStore::compact() {
  try {
    // Cells are inserted and deleted frame by frame (replacements, consolidation), which leaves
    // the R*Tree's nodes about a third full; rebuilt in id order (the order of driving, so of
    // place) its nodes fill up: a third fewer pages on long runs. Same rows, one transaction.
    exec("BEGIN IMMEDIATE");
    try {
      exec(
          "CREATE TEMP TABLE rebuilt_bounds AS SELECT * FROM cell_bounds;"
          "DELETE FROM cell_bounds;"
          "INSERT INTO cell_bounds SELECT * FROM rebuilt_bounds ORDER BY id;"
          "DROP TABLE rebuilt_bounds;");
      exec("COMMIT");
    } catch (...) {
      sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
      throw;
    }
    exec("VACUUM");
  } catch (const StorageError& e) {
    throw StorageError(std::string(e.what()) + " (compaction failed; the store is unchanged)");
  }
}

void MapStore::commit_frame(std::uint64_t frame_id, const Pose& T_world_cam,
                            const map::MergeReport& report, const map::GlobalMap& map,
                            const std::optional<Pose>& input_pose) {
  const std::string frame = "frame " + std::to_string(frame_id);
  exec("BEGIN IMMEDIATE");
  try {
    auto failed = [&] { fail("cannot commit " + frame); };
    {
      Writer pose;
      pose.put_matrix(T_world_cam.matrix());
      Statement s(db_, "INSERT INTO frames VALUES (?, ?, ?, ?, ?, ?, ?)", *this);
      s.bind(1, static_cast<std::int64_t>(frame_id)).bind(2, pose.bytes)
          .bind(3, static_cast<std::int64_t>(report.input_cells))
          .bind(4, static_cast<std::int64_t>(report.added_cells.size()))
          .bind(5, static_cast<std::int64_t>(report.fused_cells)).bind(6, report.merge_ms);
      Writer input;
      if (input_pose) {  // unbound: NULL (no refinement, the pose is the input)
        input.put_matrix(input_pose->matrix());
        s.bind(7, input.bytes);
      }
      run(s, failed);
    }
    write_changes(frame, report, map);
    // Cells of this frame are not consolidated yet: the map is no longer settled.
    exec("DELETE FROM meta WHERE key = 'settled_frame'");
    if (sqlite3_exec(db_, "COMMIT", nullptr, nullptr, nullptr) != SQLITE_OK) failed();
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

void MapStore::write_changes(const std::string& what, const map::MergeReport& report,
                             const map::GlobalMap& map) {
  auto failed = [&] { fail("cannot commit " + what); };
    {
      Statement cell(db_, "INSERT INTO cells VALUES (?, ?, ?, ?, ?, ?, ?)", *this);
      Statement bounds(db_, "INSERT INTO cell_bounds VALUES (?, ?, ?, ?, ?, ?, ?)", *this);
      for (std::uint32_t id : report.added_cells) {
        const map::MapCell* c = map.cell(id);
        if (!c) fail(what + ": added cell " + std::to_string(id) + " is not in the map");
        Writer rgb;
        rgb.put_matrix(Eigen::Vector3f(c->mean_rgb));
        cell.bind(1, std::int64_t{id})
            .bind(2, static_cast<std::int64_t>(c->frame_id))
            .bind(3, std::int64_t{c->surface})
            .bind(4, map_codec::encode_plane(c->plane))
            .bind(5, map_codec::encode_vertices(c->vertices_m.vertices()))
            .bind(6, rgb.bytes)
            .bind(7, static_cast<double>(c->depth_sigma_m));
        run(cell, failed);
        Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), hi = -lo;
        for (const auto& v : c->vertices_m) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
        bounds.bind(1, std::int64_t{id}).bind(2, double{lo.x()}).bind(3, double{hi.x()})
            .bind(4, double{lo.y()}).bind(5, double{hi.y()}).bind(6, double{lo.z()}).bind(7, double{hi.z()});
        run(bounds, failed);
      }
    }
    {
      Statement relabel(db_, "UPDATE cells SET surface = ? WHERE id = ?", *this);
      for (std::uint32_t id : report.relabelled_cells) {
        const map::MapCell* c = map.cell(id);
        if (!c) fail(what + ": relabelled cell " + std::to_string(id) + " is not in the map");
        relabel.bind(1, std::int64_t{c->surface}).bind(2, std::int64_t{id});
        run(relabel, failed);
      }
      Statement remove_cell(db_, "DELETE FROM cells WHERE id = ?", *this);
      Statement remove_bounds(db_, "DELETE FROM cell_bounds WHERE id = ?", *this);
      for (std::uint32_t id : report.removed_cells) {
        remove_cell.bind(1, std::int64_t{id});
        run(remove_cell, failed);
        remove_bounds.bind(1, std::int64_t{id});
        run(remove_bounds, failed);
      }
    }
    {
      Statement remove(db_, "DELETE FROM surfaces WHERE id = ?", *this);
      for (std::uint32_t id : report.removed_surfaces) {
        remove.bind(1, std::int64_t{id});
        run(remove, failed);
      }
      Statement upsert(db_, "INSERT OR REPLACE INTO surfaces VALUES (?, ?)", *this);
      // Surfaces gone dormant changed only in RAM's eyes (their detail dropped): rewritten too.
      for (const auto* ids : {&report.updated_surfaces, &report.dormant_surfaces})
        for (std::uint32_t id : *ids) {
          const map::Surface* s = map.surface(id);
          if (!s) fail(what + ": updated surface " + std::to_string(id) + " is not in the map");
          upsert.bind(1, std::int64_t{id}).bind(2, map_codec::encode_surface(*s));
          run(upsert, failed);
        }
      Statement merge(db_, "INSERT INTO merges(frame_id, absorbed, into_surface) VALUES (?, ?, ?)", *this);
      for (const auto& m : report.surface_merges) {
        merge.bind(1, static_cast<std::int64_t>(m.frame_id)).bind(2, std::int64_t{m.absorbed})
            .bind(3, std::int64_t{m.into});
        run(merge, failed);
      }
      Statement meta(db_, "UPDATE meta SET value = ? WHERE key = ?", *this);
      meta.bind(1, std::to_string(map.next_cell_id())).bind(2, std::string("next_cell_id"));
      run(meta, failed);
      meta.bind(1, std::to_string(map.next_surface_id())).bind(2, std::string("next_surface_id"));
      run(meta, failed);
    }
}

void MapStore::commit_settle(const map::MergeReport& report, const map::GlobalMap& map) {
  const std::string what = "the settling after frame " + std::to_string(report.frame_id);
  exec("BEGIN IMMEDIATE");
  try {
    auto failed = [&] { fail("cannot commit " + what); };
    {
      Statement last(db_, "SELECT count(*), max(frame_id) FROM frames", *this);
      int rc = SQLITE_OK;
      if (!last.step(rc)) failed();
      if (last.integer(0) == 0 || static_cast<std::uint64_t>(last.integer(1)) != report.frame_id)
        fail(what + ": it is not the store's last frame");
    }
    write_changes(what, report, map);
    Statement meta(db_, "INSERT OR REPLACE INTO meta(key, value) VALUES ('settled_frame', ?)", *this);
    meta.bind(1, std::to_string(report.frame_id));
    run(meta, failed);
    if (sqlite3_exec(db_, "COMMIT", nullptr, nullptr, nullptr) != SQLITE_OK) failed();
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

StoredMap MapStore::load() const {
  StoredMap out;
  const std::string where = "map store '" + path_.string() + "'";
  int rc = SQLITE_OK;
  {
    Statement meta(db_, "SELECT key, value FROM meta WHERE key IN ('next_cell_id', 'next_surface_id')", *this);
    while (meta.step(rc)) {
      const std::string key = meta.text(0), text = meta.text(1);
      std::uint32_t value = 0;
      const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
      if (ec != std::errc() || end != text.data() + text.size())
        fail("meta '" + key + "' is not an id in [0, 2^32): '" + text.substr(0, 40) + "'");
      (key == "next_cell_id" ? out.next_cell_id : out.next_surface_id) = value;
    }
    if (rc != SQLITE_DONE) fail("cannot read meta");
  }
  {
    Statement cells(db_, "SELECT id, frame_id, surface, plane, vertices_m, mean_rgb, depth_sigma_m "
                         "FROM cells ORDER BY id", *this);
    while (cells.step(rc)) {
      map::MapCell c;
      c.id = static_cast<std::uint32_t>(cells.integer(0));
      const std::string what = where + ": cell " + std::to_string(c.id);
      c.frame_id = static_cast<std::uint64_t>(cells.integer(1));
      c.surface = static_cast<std::uint32_t>(cells.integer(2));
      c.plane = map_codec::decode_plane(cells.blob(3), cells.blob_size(3), what + " plane");
      c.vertices_m = map::StoredPolygon(
          map_codec::decode_vertices(cells.blob(4), cells.blob_size(4), what + " vertices_m"));
      Reader rgb(cells.blob(5), cells.blob_size(5), what + " colour");
      Eigen::Vector3f mean_rgb;
      rgb.get_matrix(mean_rgb);
      c.mean_rgb = mean_rgb;
      rgb.expect_end();
      c.depth_sigma_m = static_cast<float>(cells.real(6));
      out.cells.push_back(std::move(c));
    }
    if (rc != SQLITE_DONE) fail("cannot read cells");
  }
  {
    Statement surfaces(db_, "SELECT id, data FROM surfaces ORDER BY id", *this);
    while (surfaces.step(rc))
      out.surfaces.push_back(
          map_codec::decode_surface(static_cast<std::uint32_t>(surfaces.integer(0)),
                                    surfaces.blob(1), surfaces.blob_size(1), where));
    if (rc != SQLITE_DONE) fail("cannot read surfaces");
  }
  {
    Statement last(db_, "SELECT count(*), max(frame_id) FROM frames", *this);
    if (!last.step(rc)) fail("cannot read frames");
    if (last.integer(0) > 0) out.last_frame_id = static_cast<std::uint64_t>(last.integer(1));
  }
  {
    Statement settled(db_, "SELECT value FROM meta WHERE key = 'settled_frame'", *this);
    if (settled.step(rc))
      out.settled = out.last_frame_id && settled.text(0) == std::to_string(*out.last_frame_id);
    else if (rc != SQLITE_DONE)
      fail("cannot read meta");
  }
  return out;
}

std::size_t MapStore::frame_count() const {
  Statement s(db_, "SELECT count(*) FROM frames", *this);
  int rc = SQLITE_OK;
  if (!s.step(rc)) fail("cannot count frames");
  return static_cast<std::size_t>(s.integer(0));
}

std::vector<std::uint64_t> MapStore::frame_ids() const {
  Statement s(db_, "SELECT frame_id FROM frames ORDER BY frame_id", *this);
  std::vector<std::uint64_t> out;
  int rc = SQLITE_OK;
  while (s.step(rc)) out.push_back(static_cast<std::uint64_t>(s.integer(0)));
  if (rc != SQLITE_DONE) fail("cannot read frames");
  return out;
}

std::optional<Pose> MapStore::pose(std::uint64_t frame_id) const {
  return read_pose("SELECT pose FROM frames WHERE frame_id = ?", frame_id, "pose");
}

std::optional<Pose> MapStore::input_pose(std::uint64_t frame_id) const {
  return read_pose("SELECT input_pose FROM frames WHERE frame_id = ?", frame_id, "input pose");
}

std::optional<Pose> MapStore::read_pose(const char* sql, std::uint64_t frame_id, const char* what) const {
  Statement s(db_, sql, *this);
  s.bind(1, static_cast<std::int64_t>(frame_id));
  int rc = SQLITE_OK;
  if (!s.step(rc)) {
    if (rc != SQLITE_DONE) fail(std::string("cannot read the ") + what + " of frame " + std::to_string(frame_id));
    return std::nullopt;  // no such frame
  }
  if (s.blob_size(0) == 0) return std::nullopt;  // NULL input pose: used as given
  Reader r(s.blob(0), s.blob_size(0),
           "map store '" + path_.string() + "': " + what + " of frame " + std::to_string(frame_id));
  Pose pose;
  r.get_matrix(pose.matrix());
  r.expect_end();
  return pose;
}

std::vector<map::SurfaceMerge> MapStore::merge_history() const {
  Statement s(db_, "SELECT frame_id, absorbed, into_surface FROM merges ORDER BY seq", *this);
  std::vector<map::SurfaceMerge> out;
  int rc = SQLITE_OK;
  while (s.step(rc))
    out.push_back({static_cast<std::uint64_t>(s.integer(0)), static_cast<std::uint32_t>(s.integer(1)),
                   static_cast<std::uint32_t>(s.integer(2))});
  if (rc != SQLITE_DONE) fail("cannot read merge history");
  return out;
}

StoreBytes MapStore::bytes_by_part() const {
  StoreBytes out;
  {
    Statement s(db_, "SELECT name, sum(pgsize) FROM dbstat GROUP BY name", *this);
    int rc = SQLITE_OK;
    while (s.step(rc)) {
      const std::string name = s.text(0);
      const auto bytes = static_cast<std::size_t>(s.integer(1));
      if (name == "cells")
        out.cells += bytes;
      else if (name.starts_with("cell_bounds"))
        out.bounds += bytes;
      else if (name == "surfaces")
        out.surfaces += bytes;
      else if (name == "frames")
        out.frames += bytes;
      else if (name == "merges")
        out.merges += bytes;
      else
        out.other += bytes;
    }
    if (rc != SQLITE_DONE) fail("cannot read page statistics");
  }
  Statement free_pages(db_,
                       "SELECT (SELECT freelist_count FROM pragma_freelist_count) * "
                       "(SELECT page_size FROM pragma_page_size)",
                       *this);
  int rc = SQLITE_OK;
  if (!free_pages.step(rc)) fail("cannot count free pages");
  out.free = static_cast<std::size_t>(free_pages.integer(0));
  return out;
}

std::vector<std::uint32_t> MapStore::cells_in_box(const map::Aabb& box) const {
  Statement s(db_, "SELECT id FROM cell_bounds WHERE max_x >= ? AND min_x <= ? AND max_y >= ? "
                   "AND min_y <= ? AND max_z >= ? AND min_z <= ? ORDER BY id", *this);
  s.bind(1, box.min.x()).bind(2, box.max.x()).bind(3, box.min.y()).bind(4, box.max.y())
      .bind(5, box.min.z()).bind(6, box.max.z());
  std::vector<std::uint32_t> out;
  int rc = SQLITE_OK;
  while (s.step(rc)) out.push_back(static_cast<std::uint32_t>(s.integer(0)));
  if (rc != SQLITE_DONE) fail("cannot query cell bounds");
  return out;
}

}  // namespace planecell::io
