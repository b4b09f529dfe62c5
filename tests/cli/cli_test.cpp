// The real `lensfarm` binary, run as a child process: bad input exits 2 with one line on stderr
// and writes nothing; a good render writes its images and statistics; `dof` prints the 2013
// report's Table 1; Ctrl-C writes the image so far and exits 130.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "common/film/image_io.h"
#include "common/scene/scene_loader.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using test::contains;
using test::lines;
using json = nlohmann::json;

using test::kBadInput;
using test::kInterrupted;

std::string cli() { return test::cliPath().string(); }

std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  return names;
}

std::string joined(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

std::vector<std::string> hiddenEntries(const fs::path& dir) {
  std::vector<std::string> hidden;
  for (const auto& n : entries(dir))
    if (!n.empty() && n[0] == '.') hidden.push_back(n);
  return hidden;
}

// Exactly one non-empty line, terminated by a newline.
::testing::AssertionResult isOneLine(const std::string& text) {
  const auto newline = text.find('\n');
  if (text.empty() || newline == 0 || newline != text.size() - 1)
    return ::testing::AssertionFailure() << "expected exactly one non-empty line, got \"" << text << "\"";
  return ::testing::AssertionSuccess();
}

std::vector<std::string> tokens(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> out;
  for (std::string t; in >> t;) out.push_back(t);
  return out;
}

// ---- bad input ------------------------------------------------------------------------------

struct BadRender {
  std::string name;
  std::string sceneFile;  // written into the scene directory unless `text` is empty
  std::string text;
  std::vector<std::string> mustName;  // besides "error" and the scene file name
};

TEST(CliBadInput, BadScenesExitTwoWithOneLineAndWriteNothing) {
  json unknownField = test::minimalSceneJson();
  unknownField["camera"]["focus_distanse"] = 3.0;
  json missingObj = test::minimalSceneJson();
  missingObj["shapes"].push_back({{"type", "obj"}, {"file", "no-such-mesh.obj"}, {"material", "white"}});
  json focusInsideF = test::minimalSceneJson();  // a lens focused inside its focal length
  focusInsideF["camera"]["type"] = "thin_lens";
  focusInsideF["camera"]["f_number"] = 8;
  focusInsideF["camera"]["focus_distance"] = 0.05;

  const std::vector<BadRender> cases = {
      {"malformed JSON", "broken.json", "{\n  \"format\": \"lensfarm-scene/1\",\n  \"camera\": \n", {"line"}},
      {"unknown field", "typo.json", unknownField.dump(2), {"camera.focus_distanse"}},
      {"missing OBJ", "no-mesh.json", missingObj.dump(2), {"shapes[1].file", "no-such-mesh.obj"}},
      {"S1 <= f", "too-close.json", focusInsideF.dump(2), {"camera.focus_distance"}},
      {"no scene file", "no-such-scene.json", "", {}},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    test::TempDir scenes, out;
    const fs::path scene = c.text.empty() ? scenes / c.sceneFile : scenes.write(c.sceneFile, c.text);
    const auto r = test::runProcess({cli(), "render", scene.string(), "-o", (out / "out.exr").string()}, 30.0);
    EXPECT_FALSE(r.timedOut);
    EXPECT_EQ(r.exitCode, kBadInput) << r.err;
    EXPECT_TRUE(isOneLine(r.err));
    EXPECT_TRUE(contains(r.err, "error"));
    EXPECT_TRUE(contains(r.err, c.sceneFile));
    for (const auto& part : c.mustName) EXPECT_TRUE(contains(r.err, part));
    EXPECT_TRUE(entries(out.path()).empty()) << joined(entries(out.path()));
  }
}

TEST(CliBadInput, OverflowingNumberExitsTwoNamingTheField) {
  json j = test::minimalSceneJson();
  j["camera"]["focal_length"] = "@NUMBER@";
  std::string text = j.dump(2);
  const std::string placeholder = "\"@NUMBER@\"";
  text.replace(text.find(placeholder), placeholder.size(), "1e999");
  test::TempDir scenes, out;
  const fs::path scene = scenes.write("huge.json", text);
  const auto r = test::runProcess({cli(), "render", scene.string(), "-o", (out / "out.exr").string()}, 30.0);
  EXPECT_FALSE(r.timedOut);
  EXPECT_EQ(r.exitCode, kBadInput) << r.err;
  EXPECT_TRUE(isOneLine(r.err));
  EXPECT_TRUE(contains(r.err, "error"));
  EXPECT_TRUE(contains(r.err, "huge.json"));
  EXPECT_TRUE(contains(r.err, "camera.focal_length"));
  EXPECT_TRUE(entries(out.path()).empty()) << joined(entries(out.path()));
}

TEST(CliBadInput, BadFlagsExitTwoNamingTheFlagAndWriteNothing) {
  test::TempDir scenes;
  const fs::path scene = scenes.write("minimal.json", test::minimalSceneJson().dump(2));
  struct BadFlag {
    std::vector<std::string> args;
    std::string flag;
  };
  const std::vector<BadFlag> cases = {
      {{"--resolution", "12by5"}, "--resolution"},
      {{"--spp", "0"}, "--spp"},
      {{"-o", "@OUT@/out.tiff"}, "out.tiff"},
      {{"-o", "@OUT@/first.exr", "-o", "@OUT@/second.tiff"}, "second.tiff"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.flag);
    test::TempDir out;
    std::vector<std::string> argv = {cli(), "render", scene.string()};
    bool hasOutput = false;
    for (std::string a : c.args) {
      if (a.rfind("@OUT@", 0) == 0) {
        a = (out.path() / a.substr(6)).string();
        hasOutput = true;
      }
      argv.push_back(a);
    }
    if (!hasOutput) {
      argv.push_back("-o");
      argv.push_back((out / "out.exr").string());
    }
    const auto r = test::runProcess(argv, 30.0);
    EXPECT_FALSE(r.timedOut);
    EXPECT_EQ(r.exitCode, kBadInput) << r.err;
    EXPECT_TRUE(isOneLine(r.err));
    EXPECT_TRUE(contains(r.err, "error"));
    EXPECT_TRUE(contains(r.err, c.flag));
    if (c.flag.find(".tiff") != std::string::npos) {
      EXPECT_TRUE(contains(r.err, "-o"));
    }
    EXPECT_TRUE(entries(out.path()).empty()) << joined(entries(out.path()));
  }
}

// ---- a good render --------------------------------------------------------------------------

TEST(CliRender, TinyRenderWritesBothImagesAndStatistics) {
  test::TempDir scenes, out;
  const fs::path scene = scenes.write("minimal.json", test::minimalSceneJson().dump(2));
  const fs::path exr = out / "a.exr", png = out / "a.png";
  const auto r = test::runProcess({cli(), "render", scene.string(), "-o", exr.string(), "-o", png.string(), "--spp",
                                   "3", "--resolution", "8x6", "--threads", "2", "-q"},
                                  30.0);
  ASSERT_FALSE(r.timedOut);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  ASSERT_TRUE(fs::is_regular_file(exr));
  ASSERT_TRUE(fs::is_regular_file(png));

  ImageMetadata meta;
  const Image image = readExr(exr, &meta);
  EXPECT_EQ(image.width, 8);
  EXPECT_EQ(image.height, 6);
  ASSERT_EQ(image.rgb.size(), size_t(8 * 6 * 3));
  float maxValue = 0.0f;
  for (const float v : image.rgb) {
    EXPECT_TRUE(std::isfinite(v)) << v;
    EXPECT_GE(v, 0.0f);
    maxValue = std::max(maxValue, v);
  }
  EXPECT_GT(maxValue, 0.0f) << "the lit white quad fills the middle of the frame";
  EXPECT_EQ(meta.samplesPerPixel, 3u);
  EXPECT_EQ(meta.totalSamples, uint64_t(8 * 6 * 3));
  EXPECT_FALSE(meta.sceneHash.empty());
  EXPECT_EQ(meta.sceneHash, loadScene(scene).hash);

  std::ifstream pngIn(png, std::ios::binary);
  char signature[8] = {};
  pngIn.read(signature, 8);
  EXPECT_EQ(std::string(signature + 1, 3), "PNG");

  EXPECT_TRUE(contains(r.out, "light-hit fraction"));
  EXPECT_TRUE(contains(r.out, "dropped samples"));
  EXPECT_TRUE(hiddenEntries(out.path()).empty()) << joined(hiddenEntries(out.path()));
}

// ---- dof: the 2013 report's Table 1 ---------------------------------------------------------

TEST(CliDof, SeedSceneReproducesTable1AndTextbookFarLimitIsSane) {
  const auto r = test::runProcess({cli(), "dof", (test::scenesDir() / "cornell-seed.json").string()}, 30.0);
  ASSERT_FALSE(r.timedOut);
  ASSERT_EQ(r.exitCode, 0) << r.err;

  // Rows by section ("seed": the 2013 report's formulas / "textbook") and N: N H DN DF DF-DN.
  std::map<std::string, std::map<std::string, std::vector<std::string>>> rows;
  std::string section;
  for (const auto& line : lines(r.out)) {
    if (line.rfind("2013 report", 0) == 0)
      section = "seed";
    else if (line.rfind("textbook", 0) == 0)
      section = "textbook";
    const auto t = tokens(line);
    if (section.empty() || t.size() != 5 || t[0] == "N") continue;
    rows[section][t[0]] = t;
  }
  ASSERT_EQ(rows["seed"].size(), 5u) << r.out;
  ASSERT_EQ(rows["textbook"].size(), 5u) << r.out;

  const std::vector<std::string> seed16 = {"16", "6.078", "1.984", "5.717", "3.733"};
  const std::vector<std::string> seed2 = {"2", "47.957", "2.740", "3.093", "0.353"};
  EXPECT_EQ(rows["seed"]["16"], seed16) << r.out;
  EXPECT_EQ(rows["seed"]["2"], seed2) << r.out;

  const double f = 0.095, s1 = 2.9, c = std::sqrt(2.0) * 0.1 / 1500.0;
  ASSERT_EQ(rows["textbook"].count("32"), 1u) << r.out;
  for (const auto& [n, row] : rows["textbook"]) {
    SCOPED_TRACE("textbook N = " + n);
    const double h = f * f / (std::stod(n) * c) + f;
    EXPECT_NEAR(std::stod(row[1]), h, 1e-3);
    EXPECT_EQ(row[3] == "inf", s1 >= h) << "DF = " << row[3] << ", H = " << h;
  }
  for (const auto& [name, table] : rows)
    for (const auto& [n, row] : table) {
      SCOPED_TRACE(name + " N = " + n);
      if (row[3] == "inf") continue;
      EXPECT_GE(std::stod(row[3]), 0.0) << "negative DF";
      EXPECT_GE(std::stod(row[3]), std::stod(row[2])) << "DF before DN";
    }
}

// ---- Ctrl-C ---------------------------------------------------------------------------------

TEST(CliInterrupt, CtrlCWritesWholeUnitsAndExits130) {
  test::TempDir scenes, out, io;
  const fs::path scene = scenes.write("minimal.json", test::minimalSceneJson().dump(2));
  const fs::path snap = out / "snap.exr";
  const pid_t pid = test::startProcess({cli(), "render", scene.string(), "-o", snap.string(), "--spp", "1000000",
                                        "--resolution", "64x64", "--snapshot-every", "0.05", "-q"},
                                       io / "stdout", io / "stderr");
  ASSERT_GT(pid, 0);
  int status = 0;
  bool reaped = false;
  const bool snapshotWritten = test::waitFor(
      [&] {
        if (!reaped && ::waitpid(pid, &status, WNOHANG) == pid) reaped = true;
        return reaped || fs::exists(snap);
      },
      60.0);
  if (!reaped && snapshotWritten && fs::exists(snap)) {
    ASSERT_EQ(::kill(pid, SIGINT), 0);
    reaped = test::waitFor([&] { return ::waitpid(pid, &status, WNOHANG) == pid; }, 60.0);
  }
  if (!reaped) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
    FAIL() << "the render did not " << (snapshotWritten ? "stop after Ctrl-C" : "write a snapshot")
           << "; stderr: " << test::readFile(io / "stderr");
  }
  ASSERT_TRUE(snapshotWritten) << "the render ended before writing a snapshot; stderr: "
                               << test::readFile(io / "stderr");
  ASSERT_TRUE(WIFEXITED(status)) << "killed by signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  EXPECT_EQ(WEXITSTATUS(status), kInterrupted) << test::readFile(io / "stderr");

  ImageMetadata meta;
  const Image image = readExr(snap, &meta);
  EXPECT_EQ(image.width, 64);
  EXPECT_EQ(image.height, 64);
  for (const float v : image.rgb) ASSERT_TRUE(std::isfinite(v) && v >= 0.0f) << v;
  EXPECT_GE(meta.samplesPerPixel, 1u);
  EXPECT_LT(meta.samplesPerPixel, 1000000u);
  EXPECT_EQ(meta.totalSamples, meta.samplesPerPixel * 64 * 64) << "the image must hold whole units only";
  EXPECT_TRUE(contains(test::readFile(io / "stdout"), "interrupted"));
  EXPECT_TRUE(hiddenEntries(out.path()).empty()) << joined(hiddenEntries(out.path()));
  EXPECT_EQ(entries(out.path()), std::vector<std::string>{"snap.exr"});
}

}  // namespace
}  // namespace lensfarm

namespace lensfarm {
namespace {

TEST(CliDof, BeyondTheHyperfocalDistanceTheFarLimitIsInfinity) {
  // N = 64 puts H = 1.57 < S1 = 2.9, N = 1e6 nearly a pinhole: DF must print "inf" in both
  // tables, never a negative or huge number.
  const auto r = test::runProcess({test::cliPath().string(), "dof", (test::scenesDir() / "cornell-seed.json").string(),
                                   "--f-numbers", "64,1000000"},
                                  30.0);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  std::istringstream lines(r.out);
  int infRows = 0;
  for (std::string line; std::getline(lines, line);) {
    std::istringstream tokens(line);
    std::vector<std::string> t;
    for (std::string s; tokens >> s;) t.push_back(s);
    if (t.size() == 5 && (t[0] == "64" || t[0] == "1e+06")) {
      EXPECT_EQ(t[3], "inf") << line;
      EXPECT_EQ(t[4], "inf") << line;
      ++infRows;
    }
  }
  EXPECT_EQ(infRows, 4) << r.out;
}

}  // namespace
}  // namespace lensfarm
