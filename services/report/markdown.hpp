#pragma once
/// Markdown pieces shared by the reports (`planecell bench` report.md, `eval-stereo --report-md`):
/// tables, figures, number formats and the line naming the command that regenerates the numbers
/// above it, so a report reads on its own.
#include <string>
#include <vector>

namespace planecell::services::report {

/// A GitHub-flavoured table: header, alignment row, rows. A column is right-aligned when every
/// non-empty cell of it below the header is a number (starts with a digit, a sign or "–"), else
/// left-aligned. A '|' inside a cell is escaped.
std::string table(const std::vector<std::string>& header,
                  const std::vector<std::vector<std::string>>& rows);

/// "_Regenerate:_ `command`" on its own line (follows every table and figure).
std::string regenerate(const std::string& command);

/// An embedded image: ![alt](relative_path).
std::string image(const std::string& alt, const std::string& relative_path);

/// Fixed notation with `precision` decimals; "–" for NaN or infinity.
std::string number(double value, int precision = 1);

/// Bytes in binary units with the unit named: "812 B", "12.3 KiB", "4.56 MiB", "1.20 GiB"
/// (as in `planecell replay`'s summary).
std::string bytes(double value);

/// The argument quoted for a POSIX shell when it needs it ('…' with ' escaped), else unchanged.
std::string shell_quote(const std::string& argument);

/// Markdown text with every heading one level deeper ("# A" → "## A"), outside fenced code;
/// for appending one report as a section of another.
std::string demote_headings(const std::string& markdown);

}  // namespace planecell::services::report
