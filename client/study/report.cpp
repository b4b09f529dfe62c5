#include "client/study/report.h"

#include <sys/wait.h>

#include <cstdio>
#include <stdexcept>

#include "common/film/image_io.h"

namespace lensfarm::study {

void Table::add(std::vector<std::string> row) {
  if (row.size() != columns_.size()) throw std::logic_error("study table: a row has the wrong number of cells");
  rows_.push_back(std::move(row));
}

void Table::writeCsv(const std::filesystem::path& file) const {
  auto line = [](const std::vector<std::string>& cells) {
    std::string out;
    for (size_t k = 0; k < cells.size(); ++k) {
      const bool quote = cells[k].find_first_of(",\"") != std::string::npos;
      std::string cell = cells[k];
      if (quote) {
        std::string escaped;
        for (char c : cell) escaped += c == '"' ? std::string("\"\"") : std::string(1, c);
        cell = "\"" + escaped + "\"";
      }
      out += (k ? "," : "") + cell;
    }
    return out + "\n";
  };
  std::string text = line(columns_);
  for (const auto& r : rows_) text += line(r);
  writeBytesAtomically(file, text);
}

std::string Table::markdown() const {
  std::string out = "|";
  for (const auto& c : columns_) out += " " + c + " |";
  out += "\n|";
  for (size_t k = 0; k < columns_.size(); ++k) out += "---|";
  out += "\n";
  for (const auto& r : rows_) {
    out += "|";
    for (const auto& cell : r) out += " " + cell + " |";
    out += "\n";
  }
  return out;
}

std::string number(double value, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, value);
  return buf;
}

std::string gnuplotPath(const std::filesystem::path& path) {
  std::string out = "'";
  for (char c : path.string()) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

void runGnuplot(const std::string& script) {
  FILE* pipe = ::popen("gnuplot 2>&1", "w");
  if (!pipe) throw std::runtime_error("cannot start gnuplot (scripts/setup.sh installs gnuplot-nox)");
  std::fwrite(script.data(), 1, script.size(), pipe);
  const int status = ::pclose(pipe);
  if (status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error(WIFEXITED(status) && WEXITSTATUS(status) == 127
                                 ? "gnuplot is not installed (scripts/setup.sh installs gnuplot-nox)"
                                 : "gnuplot failed on a study plot (its messages are above)");
}

}  // namespace lensfarm::study
