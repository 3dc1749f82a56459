#pragma once
/// A synthetic street sequence small enough for fast end-to-end tests, and the stage settings
/// that suit its frames.
#include <cstdint>
#include <filesystem>

#include "core/config/app_config.hpp"

namespace planecell::test {

/// Writes `frames` frames of io::make_street_world(seed) at width × height (default: a third of
/// KITTI's 1242 × 375, which keeps the tests fast) to `dir` in KITTI odometry layout.
void write_small_street(const std::filesystem::path& dir, int frames, std::uint64_t seed,
                        int width = 414, int height = 125);

/// Defaults scaled to such frames: 48 disparities, 150 target cells, cells up to σ_Z 0.6 m.
AppConfig small_street_config();

}  // namespace planecell::test
