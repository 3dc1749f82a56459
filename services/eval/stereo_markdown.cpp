#include "services/eval/stereo_markdown.hpp"

#include <cmath>
#include <sstream>

#include "services/report/markdown.hpp"

namespace planecell::services::eval {
namespace {

using report::number;

std::vector<std::string> error_row(const std::string& pair, const MethodResult& m) {
  const DisparityErrors& a = m.all;
  return {pair,
          m.method,
          number(a.all_pct(a.bad1), 2),
          number(a.all_pct(a.bad2), 2),
          number(a.all_pct(a.bad4), 2),
          number(a.all_pct(a.d1), 2),
          number(a.density_pct(), 1),
          number(a.estimated_pct(a.bad2), 2),
          number(a.estimated_pct(a.d1), 2),
          number(a.mae_px(), 2),
          m.noc.gt_pixels > 0 ? number(m.noc.all_pct(m.noc.d1), 2) : "–",
          number(m.time_ms, 0)};
}

std::vector<std::string> points_row(const std::string& pair, const MethodResult& m) {
  std::vector<std::string> row = {pair, m.method};
  for (std::size_t k = 0; k < kPointRadiiM.size(); ++k)
    row.push_back(number(m.points.within_pct(k), 2));
  row.push_back(std::to_string(m.points.gt_pixels));
  return row;
}

}  // namespace

std::string format_markdown(const std::string& dataset, const std::string& command,
                            const std::vector<PairResult>& pairs,
                            const std::vector<StereoMethod>& methods) {
  std::ostringstream md;
  md << "# Stereo accuracy: " << dataset << " (" << pairs.size() << " pair"
     << (pairs.size() == 1 ? "" : "s") << ")\n\n";
  md << "Produced by `" << command << "`.\n\nMethods:\n\n";
  for (const auto& m : methods) md << "- **" << m.name << "**: " << m.parameters << "\n";
  md << "\n## Disparity errors\n\n"
        "Percent of all GT pixels (a missing estimate counts as an error): bad-t = |d − d_gt| > t "
        "px "
        "(Middlebury, GT pixel units), D1 = > 3 px and > 5 % of d_gt (KITTI); density = share of "
        "GT "
        "pixels with an estimate; \"est\" columns count only the estimated pixels; MAE over the "
        "estimated pixels; noc D1 over non-occluded GT (when the dataset has it); time per "
        "pair.\n\n";
  const std::vector<std::string> header = {"pair",     "method", "bad-1 %",   "bad-2 %",
                                           "bad-4 %",  "D1 %",   "density %", "bad-2 est %",
                                           "D1 est %", "MAE px", "noc D1 %",  "ms"};
  std::vector<std::vector<std::string>> rows;
  for (const auto& pair : pairs)
    for (const auto& m : pair.methods) rows.push_back(error_row(pair.pair, m));
  const auto pooled = pooled_results(pairs, methods);
  for (const auto& m : pooled) rows.push_back(error_row("**pooled**", m));
  md << report::table(header, rows) << report::regenerate(command);

  bool any_points = false;
  for (const auto& m : pooled) any_points |= m.points.gt_pixels > 0;
  if (!any_points) {
    md << "\nNo pair has a camera, so there is no 3D accuracy (paper Table 1) for this dataset.\n";
    return md.str();
  }
  md << "\n## 3D accuracy (paper Table 1)\n\n"
        "Percent of all GT pixels whose point X(u, v, d) lies within r of the GT point "
        "X(u, v, d_gt) (a missing estimate counts as outside), pairs with a camera.\n\n";
  std::vector<std::string> points_header = {"pair", "method"};
  for (double r : kPointRadiiM)
    points_header.push_back("≤ " + std::to_string(std::lround(100 * r)) + " cm %");
  points_header.push_back("GT pixels");
  rows.clear();
  for (const auto& pair : pairs)
    for (const auto& m : pair.methods)
      if (m.points.gt_pixels > 0) rows.push_back(points_row(pair.pair, m));
  for (const auto& m : pooled)
    if (m.points.gt_pixels > 0) rows.push_back(points_row("**pooled**", m));
  std::vector<std::string> paper = {"paper Table 1 (its KITTI frames)", "SGBM + planecell"};
  for (double pct : kPaperTable1SgbmPct) paper.push_back(number(pct, 2));
  paper.push_back("–");
  rows.push_back(paper);
  md << report::table(points_header, rows) << report::regenerate(command);
  return md.str();
}

}  // namespace planecell::services::eval
