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
  return config;
}

}  // namespace planecell::test
