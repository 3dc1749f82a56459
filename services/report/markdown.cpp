#include "services/report/markdown.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace planecell::services::report {
namespace {

std::string escape_cell(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '|') out += '\\';
    out += c == '\n' ? ' ' : c;
  }
  return out;
}

bool looks_numeric(const std::string& cell) {
  const unsigned char c = static_cast<unsigned char>(cell[0]);
  return std::isdigit(c) || c == '-' || c == '+' || cell.rfind("–", 0) == 0;
}

}  // namespace

std::string table(const std::vector<std::string>& header,
                  const std::vector<std::vector<std::string>>& rows) {
  std::ostringstream out;
  out << "|";
  for (const auto& h : header) out << " " << escape_cell(h) << " |";
  out << "\n|";
  for (std::size_t i = 0; i < header.size(); ++i) {
    bool numeric = !rows.empty();
    for (const auto& row : rows)
      if (i < row.size() && !row[i].empty()) numeric = numeric && looks_numeric(row[i]);
    out << (numeric ? "---:|" : "---|");
  }
  out << "\n";
  for (const auto& row : rows) {
    out << "|";
    for (std::size_t i = 0; i < header.size(); ++i)
      out << " " << (i < row.size() ? escape_cell(row[i]) : std::string()) << " |";
    out << "\n";
  }
  return out.str();
}

std::string regenerate(const std::string& command) { return "\n_Regenerate:_ `" + command + "`\n"; }

std::string image(const std::string& alt, const std::string& relative_path) {
  return "![" + alt + "](" + relative_path + ")\n";
}

std::string number(double value, int precision) {
  if (!std::isfinite(value)) return "–";
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", precision, value);
  return text;
}

std::string bytes(double value) {
  if (!std::isfinite(value)) return "–";
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB"};  // powers of 1024
  int unit = 0;
  while (std::abs(value) >= 1024.0 && unit < 4) {
    value /= 1024.0;
    ++unit;
  }
  char text[64];
  if (unit == 0)
    std::snprintf(text, sizeof(text), "%.0f B", value);
  else
    std::snprintf(text, sizeof(text), "%.*f %s",
                  std::abs(value) < 10.0 ? 2 : (std::abs(value) < 100.0 ? 1 : 0), value,
                  units[unit]);
  return text;
}

std::string shell_quote(const std::string& argument) {
  const bool plain = !argument.empty() && argument.find_first_not_of(
                                              "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                              "0123456789_-+=.,/:@%") == std::string::npos;
  if (plain) return argument;
  std::string out = "'";
  for (char c : argument) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string demote_headings(const std::string& markdown) {
  std::istringstream in(markdown);
  std::ostringstream out;
  std::string line;
  bool fenced = false;
  while (std::getline(in, line)) {
    if (line.rfind("```", 0) == 0) fenced = !fenced;
    if (!fenced && !line.empty() && line[0] == '#') out << '#';
    out << line << "\n";
  }
  return out.str();
}

}  // namespace planecell::services::report
