/// libFuzzer target: bytes → temp file → io::MapStore open + load_map + frame queries. A file
/// that is not a valid planecell map must raise StorageError (or InputError/ConfigError from the
/// map rebuild), never crash. The same bytes are also decoded as each blob of every store version
/// (io/map_codec: surface, plane, vertices), where only StorageError may come out.
#include "fuzz_support.hpp"
#include "io/map_codec.hpp"
#include "io/map_store.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace planecell;
  const auto dir = fuzz::scratch_dir();
  std::error_code ec;
  for (const char* name : {"map.db-wal", "map.db-shm", "map.db-journal"})
    std::filesystem::remove(dir / name, ec);  // left by the previous input
  const auto path = fuzz::write_file("map.db", std::span(data, size));
  for (int version = io::map_codec::kOldestVersion; version <= io::map_codec::kCurrentVersion;
       ++version) {
    try {
      (void)io::map_codec::decode_surface(0, data, size, "fuzz", version);
    } catch (const StorageError&) {
    }
    try {
      (void)io::map_codec::decode_plane(data, size, "fuzz", version);
    } catch (const StorageError&) {
    }
    try {
      (void)io::map_codec::decode_vertices(data, size, "fuzz", version);
    } catch (const StorageError&) {
    }
  }
  fuzz::expect_only_planecell_errors([&] {
    const io::MapStore store(path);
    (void)store.frame_count();
    for (const auto id : store.frame_ids()) (void)store.pose(id);
    (void)store.merge_history();
    const map::GlobalMap map = io::load_map(store);
    (void)map;
  });
  return 0;
}
