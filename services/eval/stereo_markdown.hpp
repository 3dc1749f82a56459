#pragma once
/// `planecell eval-stereo --report-md`: the evaluation as a markdown report in the style of the
/// bench report (services/bench), one table per figure type, each followed by its command.
#include <string>
#include <vector>

#include "services/eval/stereo_metrics.hpp"

namespace planecell::services::eval {

/// Markdown of an evaluation: methods and their parameters, disparity errors per pair and pooled
/// (Middlebury bad-t, KITTI D1, density, MAE, time) and, when some pair has a camera, the 3D
/// accuracy within 10/20/50/100 cm (paper Table 1). `command` is the command line that produced
/// it; it is printed under every table.
std::string format_markdown(const std::string& dataset, const std::string& command,
                            const std::vector<PairResult>& pairs,
                            const std::vector<StereoMethod>& methods);

}  // namespace planecell::services::eval
