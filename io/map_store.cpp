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

namespace planecell::io {
namespace {

/// How long an operation waits for another connection's lock before failing (ms).
constexpr int kBusyTimeoutMs = 5000;

constexpr const char* kFormat = "planecell-map";
constexpr const char* kVersion = "5";  ///< 5: surface blobs deflated, no cells_by_surface index
/// Versions upgraded in place: 4 (surface blobs raw, an unused cells_by_surface index) and 3
/// (as 4 without frames.input_pose).
constexpr std::array<const char*, 2> kMigratableVersions = {"3", "4"};

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

/// Appends trivially copyable values as raw little-endian bytes (x86-64 / AArch64 hosts).
class Writer {
 public:
  template <class T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
    bytes.insert(bytes.end(), p, p + sizeof(T));
  }
  template <class Derived>
  void put_matrix(const Eigen::MatrixBase<Derived>& m) {
    for (Eigen::Index i = 0; i < m.size(); ++i) put(m(i));
  }
  std::vector<std::uint8_t> bytes;
};

/// Reads what Writer wrote; throws StorageError on a short blob.
class Reader {
 public:
  Reader(const void* data, std::size_t size, std::string what)
      : data_(static_cast<const std::uint8_t*>(data)), size_(size), what_(std::move(what)) {}
  template <class T>
  T get() {
    if (pos_ + sizeof(T) > size_)
      throw StorageError(what_ + ": blob truncated at byte " + std::to_string(pos_));
    T v;
    std::memcpy(&v, data_ + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  template <class Derived>
  void get_matrix(Eigen::MatrixBase<Derived>& m) {
    for (Eigen::Index i = 0; i < m.size(); ++i) m(i) = get<typename Derived::Scalar>();
  }
  std::uint32_t count(std::size_t element_bytes) {
    const auto n = get<std::uint32_t>();
    if (static_cast<std::size_t>(n) * element_bytes > size_ - pos_)
      throw StorageError(what_ + ": count " + std::to_string(n) + " exceeds the blob");
    return n;
  }
  void expect_end() const {
    if (pos_ != size_) throw StorageError(what_ + ": " + std::to_string(size_ - pos_) + " trailing bytes");
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  std::string what_;
};

std::vector<std::uint8_t> encode_surface_raw(const map::Surface& s) {
  Writer w;
  w.put_matrix(s.plane.normal);
  w.put(s.plane.offset);
  w.put(s.moments.weight);
  w.put_matrix(s.moments.sum);
  w.put_matrix(s.moments.sum_outer);
  for (std::uint16_t h : s.histogram) w.put(h);
  w.put(s.histogram_weight_m2);
  w.put_matrix(s.mean_rgb);
  w.put(s.observed_area_m2);
  w.put(s.area_m2);
  w.put_matrix(s.bounds.min);
  w.put_matrix(s.bounds.max);
  w.put_matrix(s.basis.origin);
  w.put_matrix(s.basis.u);
  w.put_matrix(s.basis.v);
  w.put(s.observations);
  w.put(static_cast<std::uint32_t>(s.cells.size()));
  for (auto id : s.cells) w.put(id);
  w.put(s.footprint.resolution_m());
  w.put(static_cast<std::uint32_t>(s.footprint.tiles().size()));
  for (const auto& tile : s.footprint.tiles()) {
    w.put(tile.s), w.put(tile.t);
    for (std::uint32_t row : tile.rows) w.put(row);
  }
  return std::move(w.bytes);
}

map::Surface decode_surface_raw(std::uint32_t id, const void* data, std::size_t size, const std::string& where) {
  Reader r(data, size, where + ": surface " + std::to_string(id));
  map::Surface s;
  s.id = id;
  r.get_matrix(s.plane.normal);
  s.plane.offset = r.get<double>();
  s.moments.weight = r.get<double>();
  r.get_matrix(s.moments.sum);
  r.get_matrix(s.moments.sum_outer);
  for (std::uint16_t& h : s.histogram) h = r.get<std::uint16_t>();
  s.histogram_weight_m2 = r.get<double>();
  r.get_matrix(s.mean_rgb);
  s.observed_area_m2 = r.get<double>();
  s.area_m2 = r.get<double>();
  r.get_matrix(s.bounds.min);
  r.get_matrix(s.bounds.max);
  r.get_matrix(s.basis.origin);
  r.get_matrix(s.basis.u);
  r.get_matrix(s.basis.v);
  s.observations = r.get<std::uint32_t>();
  s.cells.resize(r.count(sizeof(std::uint32_t)));
  for (auto& c : s.cells) c = r.get<std::uint32_t>();
  const auto resolution_m = r.get<double>();
  if (!(resolution_m > 0.0 && resolution_m <= 10.0))
    throw StorageError(where + ": surface " + std::to_string(id) + " has an invalid footprint resolution");
  std::vector<map::FootprintTile> tiles(r.count(sizeof(map::FootprintTile)));
  for (auto& tile : tiles) {
    tile.s = r.get<std::int32_t>(), tile.t = r.get<std::int32_t>();
    for (std::uint32_t& row : tile.rows) row = r.get<std::uint32_t>();
  }
  try {
    s.footprint = map::Footprint::from_tiles(resolution_m, std::move(tiles));
  } catch (const StorageError& e) {
    throw StorageError(where + ": surface " + std::to_string(id) + ": " + e.what());
  }
  r.expect_end();
  return s;
}

/// Largest raw surface encoding a stored blob may claim (a corrupt size is refused, not allocated):
/// 64 MiB ≈ 490 000 footprint tiles, tens of km² at the default 10 cm footprint resolution.
constexpr std::uint32_t kMaxRawSurfaceBytes = 64u << 20;

/// Surface blob (version 5): the raw encoding's size (u32, little-endian), then the raw encoding
/// deflated as a zlib stream (RFC 1950, what zlib's compress2/uncompress read and write). The
/// footprint's occupancy bits and the 64-bin histogram are mostly zeros and runs: a stored surface
/// takes about half the bytes of the raw encoding. Lossless: the decoded surface is bit-identical.
std::vector<std::uint8_t> encode_surface(const map::Surface& s) {
  const std::vector<std::uint8_t> raw = encode_surface_raw(s);
  if (raw.size() > kMaxRawSurfaceBytes)
    throw StorageError("surface " + std::to_string(s.id) + ": encoding of " + std::to_string(raw.size()) +
                       " bytes exceeds the store's limit of " + std::to_string(kMaxRawSurfaceBytes));
  std::vector<std::uint8_t> out(sizeof(std::uint32_t) + compressBound(static_cast<uLong>(raw.size())));
  const auto raw_size = static_cast<std::uint32_t>(raw.size());
  std::memcpy(out.data(), &raw_size, sizeof(raw_size));
  auto deflated = static_cast<uLongf>(out.size() - sizeof(raw_size));
  if (compress2(out.data() + sizeof(raw_size), &deflated, raw.data(), raw.size(), Z_DEFAULT_COMPRESSION) != Z_OK)
    throw StorageError("surface " + std::to_string(s.id) + ": zlib cannot deflate its encoding");
  out.resize(sizeof(raw_size) + deflated);
  return out;
}

map::Surface decode_surface(std::uint32_t id, const void* data, std::size_t size, const std::string& where) {
  const std::string what = where + ": surface " + std::to_string(id);
  Reader r(data, size, what);
  const auto raw_size = r.get<std::uint32_t>();
  if (raw_size > kMaxRawSurfaceBytes)
    throw StorageError(what + ": claims " + std::to_string(raw_size) + " bytes, beyond the limit of " +
                       std::to_string(kMaxRawSurfaceBytes));
  std::vector<std::uint8_t> raw(raw_size);
  auto inflated = static_cast<uLongf>(raw.size());
  const int rc = uncompress(raw.data(), &inflated, static_cast<const Bytef*>(data) + sizeof(raw_size),
                            static_cast<uLong>(size - sizeof(raw_size)));
  if (rc != Z_OK || inflated != raw_size)
    throw StorageError(what + ": compressed data is corrupt (zlib: " +
                       (rc == Z_OK ? std::string("size mismatch") : std::string(zError(rc))) + ")");
  return decode_surface_raw(id, raw.data(), raw.size(), where);
}

template <class Vec>
std::vector<std::uint8_t> encode_vectors(const std::vector<Vec>& vs) {
  Writer w;
  for (const auto& v : vs) w.put_matrix(v);
  return std::move(w.bytes);
}

template <class Vec>
std::vector<Vec> decode_vectors(const void* data, std::size_t size, const std::string& what) {
  constexpr std::size_t kBytes = sizeof(typename Vec::Scalar) * Vec::SizeAtCompileTime;
  if (size % kBytes != 0) throw StorageError(what + ": blob size " + std::to_string(size) + " is not a multiple of " + std::to_string(kBytes));
  Reader r(data, size, what);
  std::vector<Vec> out(size / kBytes);
  for (auto& v : out) r.get_matrix(v);
  return out;
}

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
    exec("PRAGMA journal_mode=WAL");
    exec("PRAGMA synchronous=NORMAL");
    if (migrate) {  // version 3 or 4 → 5 in one transaction
      exec("BEGIN IMMEDIATE");
      try {
        if (from_version == "3") exec("ALTER TABLE frames ADD COLUMN input_pose BLOB");  // NULL: as given
        exec("DROP INDEX IF EXISTS cells_by_surface");
        // The ids first: rows updated while a SELECT over their table is pending may be seen twice.
        std::vector<std::uint32_t> ids;
        int rc = SQLITE_OK;
        {
          Statement list(db_, "SELECT id FROM surfaces", *this);
          while (list.step(rc)) ids.push_back(static_cast<std::uint32_t>(list.integer(0)));
          if (rc != SQLITE_DONE) fail("cannot list surfaces");
        }
        Statement read(db_, "SELECT data FROM surfaces WHERE id = ?", *this);
        Statement write(db_, "UPDATE surfaces SET data = ? WHERE id = ?", *this);
        for (const std::uint32_t id : ids) {
          read.bind(1, std::int64_t{id});
          if (!read.step(rc)) fail("cannot read surface " + std::to_string(id));
          const map::Surface surface = decode_surface_raw(id, read.blob(0), read.blob_size(0), path.string());
          read.reset();
          write.bind(1, encode_surface(surface)).bind(2, std::int64_t{id});
          run(write, [&] { fail("cannot rewrite surface " + std::to_string(id)); });
        }
        exec("UPDATE meta SET value = '5' WHERE key = 'version'");
        exec("COMMIT");
      } catch (...) {
        sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
        throw;
      }
      spdlog::info("map store '{}': upgraded from version {} to {} (surfaces deflated{})", path.string(),
                   from_version, kVersion,
                   from_version == "3" ? "; frames keep their input poses from now on" : "");
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
    {
      Statement cell(db_, "INSERT INTO cells VALUES (?, ?, ?, ?, ?, ?, ?)", *this);
      Statement bounds(db_, "INSERT INTO cell_bounds VALUES (?, ?, ?, ?, ?, ?, ?)", *this);
      for (std::uint32_t id : report.added_cells) {
        const map::MapCell* c = map.cell(id);
        if (!c) fail(frame + ": added cell " + std::to_string(id) + " is not in the map");
        Writer plane, rgb;
        plane.put_matrix(c->plane.normal), plane.put(c->plane.offset);
        rgb.put_matrix(c->mean_rgb);
        cell.bind(1, std::int64_t{id}).bind(2, static_cast<std::int64_t>(c->frame_id))
            .bind(3, std::int64_t{c->surface}).bind(4, plane.bytes)
            .bind(5, encode_vectors(c->vertices_m)).bind(6, rgb.bytes)
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
        if (!c) fail(frame + ": relabelled cell " + std::to_string(id) + " is not in the map");
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
      for (std::uint32_t id : report.updated_surfaces) {
        const map::Surface* s = map.surface(id);
        if (!s) fail(frame + ": updated surface " + std::to_string(id) + " is not in the map");
        upsert.bind(1, std::int64_t{id}).bind(2, encode_surface(*s));
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
      Reader plane(cells.blob(3), cells.blob_size(3), what + " plane");
      plane.get_matrix(c.plane.normal);
      c.plane.offset = plane.get<double>();
      plane.expect_end();
      c.vertices_m = decode_vectors<Eigen::Vector3f>(cells.blob(4), cells.blob_size(4), what + " vertices_m");
      Reader rgb(cells.blob(5), cells.blob_size(5), what + " colour");
      rgb.get_matrix(c.mean_rgb);
      rgb.expect_end();
      c.depth_sigma_m = static_cast<float>(cells.real(6));
      out.cells.push_back(std::move(c));
    }
    if (rc != SQLITE_DONE) fail("cannot read cells");
  }
  {
    Statement surfaces(db_, "SELECT id, data FROM surfaces ORDER BY id", *this);
    while (surfaces.step(rc))
      out.surfaces.push_back(decode_surface(static_cast<std::uint32_t>(surfaces.integer(0)),
                                            surfaces.blob(1), surfaces.blob_size(1), where));
    if (rc != SQLITE_DONE) fail("cannot read surfaces");
  }
  {
    Statement last(db_, "SELECT count(*), max(frame_id) FROM frames", *this);
    if (!last.step(rc)) fail("cannot read frames");
    if (last.integer(0) > 0) out.last_frame_id = static_cast<std::uint64_t>(last.integer(1));
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
