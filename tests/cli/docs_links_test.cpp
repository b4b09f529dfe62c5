// The docs a newcomer enters by hold together: docs/README.md lists every page, every relative
// link in the README and docs/ names a file that exists (and, for a Markdown page, a heading that
// exists), and neither the docs nor the code speak of the project's own ticket numbers.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// GitHub's anchor for a heading: lower case, punctuation dropped (but hyphens and underscores),
// spaces as hyphens.
std::string slug(const std::string& heading) {
  std::string out;
  for (unsigned char c : heading) {
    if (std::isalnum(c) || c == '-' || c == '_')
      out += char(std::tolower(c));
    else if (c == ' ')
      out += '-';
    else if (c >= 0x80)
      out += char(c);  // (letters beyond ASCII are kept)
  }
  return out;
}

std::set<std::string> anchorsOf(const fs::path& page) {
  std::set<std::string> anchors;
  std::istringstream in(read(page));
  bool fence = false;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("```", 0) == 0) fence = !fence;
    if (fence || line.empty() || line[0] != '#') continue;
    const size_t text = line.find_first_not_of('#');
    if (text == std::string::npos) continue;
    std::string h = line.substr(text);
    h.erase(0, h.find_first_not_of(' '));
    std::string s = slug(h);
    for (int n = 0; anchors.count(s); ++n) s = slug(h) + "-" + std::to_string(n + 1);  // repeated headings
    anchors.insert(s);
  }
  return anchors;
}

std::vector<fs::path> pages() {
  std::vector<fs::path> out{test::sourceDir() / "README.md"};
  for (const auto& e : fs::directory_iterator(test::sourceDir() / "docs"))
    if (e.path().extension() == ".md") out.push_back(e.path());
  return out;
}

TEST(DocsLinks, TheIndexListsEveryPage) {
  const std::string index = read(test::sourceDir() / "docs/README.md");
  for (const fs::path& page : pages()) {
    if (page.parent_path().filename() != "docs" || page.filename() == "README.md") continue;
    EXPECT_NE(index.find("](" + page.filename().string() + ")"), std::string::npos)
        << "docs/README.md does not list " << page.filename();
  }
}

TEST(DocsLinks, EveryRelativeLinkNamesAFileAndHeadingThatExist) {
  const std::regex link(R"(\]\(([^)\s]+)\))");
  size_t checked = 0;
  for (const fs::path& page : pages()) {
    const std::string text = read(page);
    for (auto it = std::sregex_iterator(text.begin(), text.end(), link); it != std::sregex_iterator(); ++it) {
      const std::string target = (*it)[1];
      if (target.find("://") != std::string::npos || target.rfind("mailto:", 0) == 0) continue;
      const size_t hash = target.find('#');
      const std::string file = target.substr(0, hash),
                        anchor = hash == std::string::npos ? "" : target.substr(hash + 1);
      const fs::path resolved = file.empty() ? page : page.parent_path() / file;
      ++checked;
      ASSERT_TRUE(fs::exists(resolved)) << page.filename() << " links to " << target << ": no such file";
      if (!anchor.empty() && resolved.extension() == ".md") {
        EXPECT_TRUE(anchorsOf(resolved).count(anchor))
            << page.filename() << " links to " << target << ": no such heading";
      }
    }
  }
  EXPECT_GT(checked, 100u) << "the scan found the links";
}

TEST(DocsLinks, NoDocOrSourceSpeaksOfTheProjectsTicketNumbers) {
  // Our own numbered issues ("issue 23", "issue 26 goal 4"); other projects' trackers
  // (KhronosGroup/glTF issue 1563, embree#174) are citations and stay.
  const std::regex ticket(R"((^|[^/A-Za-z])[Ii]ssues? #?[0-9]+)");
  const std::set<std::string> extensions{".md", ".h", ".cpp", ".py", ".sh", ".proto", ".txt", ".js", ".html"};
  for (const char* folder : {"docs", "common", "coordinator", "worker", "client", "proto", "tests", "bench", "scenes",
                             "deploy", "scripts"}) {
    if (!fs::exists(test::sourceDir() / folder)) continue;
    for (auto it = fs::recursive_directory_iterator(test::sourceDir() / folder);
         it != fs::recursive_directory_iterator(); ++it) {
      if (it->is_directory() && it->path().filename() == "node_modules") {
        it.disable_recursion_pending();
        continue;
      }
      if (!it->is_regular_file() || !extensions.count(it->path().extension().string())) continue;
      if (it->path().filename() == "docs_links_test.cpp") continue;  // (this file names the pattern)
      std::istringstream in(read(it->path()));
      int n = 0;
      for (std::string line; std::getline(in, line);) {
        ++n;
        std::smatch m;
        if (std::regex_search(line, m, ticket) && line.find("KhronosGroup") == std::string::npos)
          ADD_FAILURE() << it->path().lexically_relative(test::sourceDir()).string() << ":" << n << ": " << line;
      }
    }
  }
  std::istringstream readme(read(test::sourceDir() / "README.md"));
  for (std::string line; std::getline(readme, line);) {
    std::smatch m;
    EXPECT_FALSE(std::regex_search(line, m, ticket)) << "README.md: " << line;
  }
}

}  // namespace
}  // namespace lensfarm
