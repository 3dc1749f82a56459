#pragma once
/// The whole configuration: one plain struct per stage, each with its defaults.
/// Loaded from YAML (services/config_loader) with one top-level section per member.
#include "core/config/map_config.hpp"
#include "core/config/pipeline_config.hpp"
#include "core/config/planecell_config.hpp"
#include "core/config/refine_config.hpp"
#include "core/config/sgm_config.hpp"
#include "core/config/synth_config.hpp"

namespace planecell {

struct AppConfig {
  SgmConfig sgm;
  ExtractionConfig extraction;
  MapConfig map;
  VoxelConfig voxel;
  SynthConfig synth;
  RefineConfig refine;
  PipelineConfig pipeline;
  LcmConfig lcm;
};

/// Visits every section with its YAML key.
template <class Visitor>
void visit_sections(AppConfig& c, Visitor&& visit) {
  visit("sgm", c.sgm);
  visit("extraction", c.extraction);
  visit("map", c.map);
  visit("voxel", c.voxel);
  visit("synth", c.synth);
  visit("refine", c.refine);
  visit("pipeline", c.pipeline);
  visit("lcm", c.lcm);
}

}  // namespace planecell
