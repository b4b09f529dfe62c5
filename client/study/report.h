#pragma once
// The study's outputs: tables written as CSV and as Markdown, and plots drawn by gnuplot (from
// Debian's gnuplot-nox, installed by scripts/setup.sh) into PNG files.
#include <filesystem>
#include <string>
#include <vector>

namespace lensfarm::study {

class Table {
 public:
  explicit Table(std::vector<std::string> columns) : columns_(std::move(columns)) {}
  void add(std::vector<std::string> row);  // one cell per column
  const std::vector<std::vector<std::string>>& rows() const { return rows_; }

  void writeCsv(const std::filesystem::path& file) const;  // atomically
  std::string markdown() const;

 private:
  std::vector<std::string> columns_;
  std::vector<std::vector<std::string>> rows_;
};

// "1.23e-02" style numbers for tables: `digits` significant digits.
std::string number(double value, int digits = 3);

// Runs gnuplot on `script`, which must `set output` to a PNG file. Throws std::runtime_error
// naming gnuplot if it is missing or fails.
void runGnuplot(const std::string& script);

// gnuplot string literal of a path (single-quoted).
std::string gnuplotPath(const std::filesystem::path& path);

}  // namespace lensfarm::study
