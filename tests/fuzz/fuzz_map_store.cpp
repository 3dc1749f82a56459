/// libFuzzer target: bytes → temp file → io::MapStore open + load_map + frame queries. A file
/// that is not a valid planecell map must raise StorageError (or InputError/ConfigError from the
/// map rebuild), never crash.
#include "fuzz_support.hpp"
#include "io/map_store.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace planecell;
  const auto dir = fuzz::scratch_dir();
  std::error_code ec;
  for (const char* name : {"map.db-wal", "map.db-shm", "map.db-journal"})
    std::filesystem::remove(dir / name, ec);  // left by the previous input
  const auto path = fuzz::write_file("map.db", std::span(data, size));
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
