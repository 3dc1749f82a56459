#pragma once
/// report.md of `planecell bench`: readable on its own (tables, embedded figures, definitions),
/// with the command that regenerates the numbers under every table and figure.
#include <string>

#include "services/bench/bench_report.hpp"

namespace planecell::services::bench {

/// The whole markdown report; figures are referenced by their file names (same folder).
std::string format_markdown(const BenchReport& report);

}  // namespace planecell::services::bench
