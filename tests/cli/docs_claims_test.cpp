// What the docs say about the program is what the program does: every command of `lensfarm help`
// has its section in docs/cli.md and its synopsis line, and every section names a command that
// exists; every flag a command's help lists is in its section of cli.md, and every flag a
// section's tables list is one the command takes; every scene file the docs and the README name
// ships; docs/other-renderers.md's example scene loads.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "common/scene/scene_loader.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

std::string cliDoc() { return test::readFile(test::sourceDir() / "docs/cli.md"); }

std::string help(const std::vector<std::string>& args) {
  std::vector<std::string> argv = {test::cliPath().string()};
  argv.insert(argv.end(), args.begin(), args.end());
  const auto r = test::runProcess(argv, 30);
  EXPECT_EQ(r.exitCode, 0) << r.err;
  return r.out;
}

// The commands `lensfarm help` lists (the first word of each line under "SUBCOMMANDS:").
std::set<std::string> helpCommands() {
  const std::string out = help({"help"});
  std::set<std::string> commands;
  bool in = false;
  for (const std::string& line : test::lines(out)) {
    if (line.find("SUBCOMMANDS") != std::string::npos || line.find("Subcommands") != std::string::npos) {
      in = true;
      continue;
    }
    std::smatch m;
    if (in && std::regex_search(line, m, std::regex(R"(^\s+([a-z]+)\b)"))) commands.insert(m[1]);
  }
  return commands;
}

// The long flags a text mentions (--spp, --allow-path).
std::set<std::string> flagsIn(const std::string& text) {
  std::set<std::string> flags;
  const std::regex flag(R"((^|[^a-z-])(--[a-z][a-z-]*[a-z]))");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), flag); it != std::sregex_iterator(); ++it)
    flags.insert((*it)[2]);
  return flags;
}

// The text of cli.md's section on `command` (from its heading to the next heading of its level or
// above), "" if there is none.
std::string section(const std::string& doc, const std::string& command) {
  const std::regex heading("(^|\n)(#+) `lensfarm " + command + "[ `]");
  std::smatch m;
  if (!std::regex_search(doc, m, heading)) return "";
  const size_t start = size_t(m.position(0)) + m.length(0);
  const std::string level = m[2];
  const std::regex next("\n#{1," + std::to_string(level.size()) + "} ");
  std::smatch n;
  const std::string rest = doc.substr(start);
  return std::regex_search(rest, n, next) ? rest.substr(0, size_t(n.position(0))) : rest;
}

// The flags of a section's tables (rows beginning with a flag in backquotes).
std::set<std::string> tableFlags(const std::string& text) {
  std::set<std::string> flags;
  for (const std::string& line : test::lines(text)) {
    std::smatch m;
    if (std::regex_search(line, m, std::regex(R"(^\| `(--[a-z][a-z-]*)[` ,=])"))) flags.insert(m[1]);
  }
  return flags;
}

TEST(DocsClaims, EveryCommandHasItsSectionAndSynopsisInCliMd) {
  const std::string doc = cliDoc();
  const std::set<std::string> commands = helpCommands();
  ASSERT_GE(commands.size(), 15u) << help({"help"});
  const std::string synopsis = doc.substr(0, doc.find("SCENE is a scene file"));
  for (const std::string& c : commands) {
    EXPECT_NE(synopsis.find("lensfarm " + c), std::string::npos) << c << " is missing from cli.md's synopsis";
    if (c == "help" || c == "jobs") continue;  // described in the synopsis and beside `status`
    EXPECT_FALSE(section(doc, c).empty()) << c << " has no section in cli.md";
  }
  // And no section describes a command the program does not have.
  const std::regex heading(R"(\n#+ `lensfarm ([a-z]+))");
  for (auto it = std::sregex_iterator(doc.begin(), doc.end(), heading); it != std::sregex_iterator(); ++it)
    EXPECT_TRUE(commands.count((*it)[1])) << "cli.md describes `lensfarm " << (*it)[1] << "`, which does not exist";
}

TEST(DocsClaims, EveryFlagOfACommandIsInItsSectionAndEveryTabledFlagExists) {
  const std::string doc = cliDoc();
  // The farm commands share --coordinator, --token-file and the --tls-* flags, documented once.
  const size_t farm = doc.find("## Farm commands"), submit = doc.find("### `lensfarm submit");
  ASSERT_TRUE(farm != std::string::npos && submit != std::string::npos && farm < submit);
  const std::set<std::string> shared = flagsIn(doc.substr(farm, submit - farm));
  for (const std::string& c : helpCommands()) {
    if (c == "help" || c == "jobs") continue;
    const std::set<std::string> taken = flagsIn(help({c, "--help"}));
    const std::string text = section(doc, c);
    const std::set<std::string> documented = flagsIn(text);
    for (const std::string& f : taken) {
      if (f == "--help") continue;
      EXPECT_TRUE(documented.count(f) || shared.count(f)) << "`lensfarm " << c << " " << f << "` is not in cli.md";
    }
    for (const std::string& f : tableFlags(text)) {
      // render's table lists the overrides it shares with submit; both take them.
      EXPECT_TRUE(taken.count(f)) << "cli.md's table for `lensfarm " << c << "` lists " << f
                                  << ", which it does not take";
    }
  }
}

TEST(DocsClaims, EveryShippedSceneTheDocsNameExistsAndLoads) {
  std::set<std::string> named;
  for (const fs::path& doc : {fs::path("README.md"), fs::path("scenes/README.md"), fs::path("docs/scene-format.md"),
                              fs::path("docs/cli.md"), fs::path("docs/farm.md"), fs::path("docs/other-renderers.md"),
                              fs::path("docs/performance.md"), fs::path("docs/accuracy.md")}) {
    const std::string text = test::readFile(test::sourceDir() / doc);
    ASSERT_FALSE(text.empty()) << doc;
    const std::regex scene(R"(scenes/([a-z0-9-]+\.json))");
    for (auto it = std::sregex_iterator(text.begin(), text.end(), scene); it != std::sregex_iterator(); ++it)
      named.insert((*it)[1]);
  }
  ASSERT_GE(named.size(), 5u);
  for (const std::string& name : named) {
    const fs::path file = test::scenesDir() / name;
    ASSERT_TRUE(fs::exists(file)) << "the docs name scenes/" << name << ", which does not ship";
    EXPECT_NO_THROW((void)loadScene(file)) << name;
  }
  // The shipped-scenes list of scenes/README.md names every scene that ships.
  const std::string readme = test::readFile(test::scenesDir() / "README.md");
  for (const auto& entry : fs::directory_iterator(test::scenesDir())) {
    if (entry.path().extension() != ".json") continue;
    EXPECT_NE(readme.find(entry.path().filename().string()), std::string::npos)
        << entry.path().filename() << " ships but scenes/README.md does not describe it";
  }
}

}  // namespace
}  // namespace lensfarm
