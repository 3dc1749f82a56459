#include "support/small_street.hpp"

#include "io/synthetic/synthetic_world.hpp"

namespace planecell::test {

void write_small_street(const std::filesystem::path& dir, int frames, std::uint64_t seed, int width,
                        int height) {
  SynthConfig synth;
  synth.frames = frames;
  synth.seed = seed;
  synth.width = width;
  synth.height = height;
  io::write_sequence(io::make_street_world(synth), dir);
}

AppConfig small_street_config() {
  AppConfig config;
  config.sgm.max_disparity = 48;
  config.extraction.target_cells = 150;
  // A third of KITTI's focal length triples σ_Z at a depth: the default gate (0.35 m, 15.4 m on
  // KITTI) would stop at 8.9 m on these frames; 0.6 m keeps cells to 11.6 m, most of what the
  // 20 m scores (map completeness, the kinds of surface) look at.
  config.map.max_depth_sigma_m = 0.6;
  return config;
}

}  // namespace planecell::test
