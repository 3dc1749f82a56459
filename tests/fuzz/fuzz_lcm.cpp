/// libFuzzer target: every LCM message the daemon or a subscriber receives, decoded and handled as
/// they handle it. The first byte picks the channel's message type, the rest is the datagram:
///   0 stereo_frame_t → from_lcm (daemon's frame input; PNG and raw images)
///   1 pose_t         → from_lcm (daemon's pose input)
///   2 map_update_t   → MapUpdateAssembler::add → MapMirror::apply → mirror_to_map (subscriber)
///   3 map_stats_t    → decode (monitor)
/// Only InputError/StorageError/ConfigError may escape; anything else is a finding.
#include "fuzz_support.hpp"
#include "io/lcm/lcm_codec.hpp"
#include "services/pipeline/mirror_map.hpp"

namespace {

/// A mirror holding two cells (ids 0, 1; surfaces 0, 1), so relabel/remove messages have targets.
planecell::io::MapMirror base_mirror() {
  using namespace planecell;
  io::MapMirror mirror;
  for (std::uint32_t id = 0; id < 2; ++id) {
    map::MapCell c;
    c.id = id;
    c.surface = id;
    c.plane = Plane3{Eigen::Vector3d(0, -1, 0), 1.5};
    const float x0 = static_cast<float>(id);
    c.vertices_m = map::StoredPolygon(std::vector<Eigen::Vector3f>{
        {x0, 1.5f, 5}, {x0 + 1, 1.5f, 5}, {x0 + 1, 1.5f, 6}, {x0, 1.5f, 6}});
    mirror.cells.emplace(id, c);
  }
  mirror.next_cell_id = 2;
  mirror.next_surface_id = 2;
  return mirror;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace planecell;
  if (size < 1) return 0;
  const std::span<const std::uint8_t> bytes(data + 1, size - 1);
  fuzz::expect_only_planecell_errors([&] {
    switch (data[0] % 4) {
      case 0: {
        const StereoFrame frame = io::from_lcm(io::decode_stereo_frame(bytes));
        if (frame.left.size() != frame.right.size()) __builtin_trap();
        break;
      }
      case 1:
        (void)io::from_lcm(io::decode_pose(bytes));
        break;
      case 2: {
        io::MapUpdateAssembler assembler;
        const auto update = assembler.add(io::decode_map_update(bytes));
        if (!update) break;
        io::MapMirror mirror = base_mirror();
        mirror.apply(*update);
        const map::GlobalMap map = services::mirror_to_map(mirror, MapConfig{});
        if (map.cells().size() != mirror.cells.size()) __builtin_trap();
        break;
      }
      default:
        (void)io::decode_map_stats(bytes);
    }
  });
  return 0;
}
