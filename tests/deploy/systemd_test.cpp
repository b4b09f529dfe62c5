// `cmake --install` into a temporary prefix: the binaries, the systemd units and the example
// settings land where they belong; the units run the installed binaries with flags they accept,
// load the tokens as credentials, restart on failure and drain on stop; systemd-analyze verifies
// them when it is there; the installed binary finds its OpenVDB module.
#include <gtest/gtest.h>
#include <openvdb/openvdb.h>
#include <sys/stat.h>

#include <fstream>
#include <regex>

#include "common/util/version.h"
#include "tests/deploy_support.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

// A unit file's settings, key -> values in order (sections are not needed to tell them apart).
std::multimap<std::string, std::string> settingsOf(const fs::path& unit) {
  std::multimap<std::string, std::string> out;
  std::ifstream in(unit);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#' || line[0] == '[') continue;
    const size_t eq = line.find('=');
    if (eq != std::string::npos) out.emplace(line.substr(0, eq), line.substr(eq + 1));
  }
  return out;
}

std::string only(const std::multimap<std::string, std::string>& settings, const std::string& key) {
  EXPECT_EQ(settings.count(key), 1u) << key;
  const auto it = settings.find(key);
  return it == settings.end() ? "" : it->second;
}

// The LENSFARM_* variables an environment file sets, or shows commented out as an example.
std::set<std::string> variablesOf(const fs::path& file) {
  std::set<std::string> out;
  const std::regex assignment(R"(^#?(LENSFARM_[A-Z_]+)=)");
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_search(line, m, assignment)) out.insert(m[1]);
  }
  return out;
}

class Install : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto r = test::runProcess(
        {LENSFARM_CMAKE_COMMAND, "--install", LENSFARM_BINARY_DIR, "--prefix", prefix_.path().string()}, 120);
    ASSERT_EQ(r.exitCode, 0) << r.out << r.err;
  }
  fs::path unitDir() const { return prefix_ / "lib/systemd/system"; }

  test::TempDir prefix_;
};

TEST_F(Install, PutsBinariesUnitsAndSettingsInTheirPlaces) {
  for (const char* binary : {"lensfarm", "lensfarm-coordinator", "lensfarm-worker"}) {
    const fs::path path = prefix_ / "bin" / binary;
    ASSERT_TRUE(fs::exists(path)) << path;
    EXPECT_NE(fs::status(path).permissions() & fs::perms::owner_exec, fs::perms::none) << path;
    const auto version = test::runProcess({path.string(), "--version"}, 30);
    EXPECT_EQ(version.exitCode, 0) << path;
    EXPECT_NE(version.out.find(kRendererVersion), std::string::npos) << path << ": " << version.out;
  }
  for (const char* file :
       {"lib/systemd/system/lensfarm-coordinator.service", "lib/systemd/system/lensfarm-worker@.service",
        "etc/lensfarm/coordinator.env", "etc/lensfarm/worker.env", "share/doc/lensfarm/deploy.md",
        "share/doc/lensfarm/farm.md", "share/doc/lensfarm/examples/coordinator.env",
        "share/doc/lensfarm/scene-format.md", "share/doc/lensfarm/cli.md", "share/doc/lensfarm/README.md",
        "share/lensfarm/scenes/README.md", "share/lensfarm/scenes/meshes/cornell-box.obj"})
    EXPECT_TRUE(fs::is_regular_file(prefix_ / file)) << file;
  // Every shipped scene is installed, and renders from there with the installed binary.
  size_t scenes = 0;
  for (const auto& e : fs::directory_iterator(test::scenesDir()))
    if (e.path().extension() == ".json") {
      ++scenes;
      const fs::path installed = prefix_ / "share/lensfarm/scenes" / e.path().filename();
      ASSERT_TRUE(fs::is_regular_file(installed)) << installed;
      const auto r =
          test::runProcess({(prefix_ / "bin/lensfarm").string(), "render", installed.string(), "--resolution", "8x8",
                            "--spp", "1", "-q", "-o", (prefix_ / "check.exr").string()},
                           120);
      EXPECT_EQ(r.exitCode, 0) << installed << ": " << r.err;
    }
  EXPECT_GE(scenes, 2u);

  // An edited setting survives a second install.
  prefix_.write("etc/lensfarm/coordinator.env", "LENSFARM_LISTEN=10.0.0.1:7878\n");
  const auto again = test::runProcess(
      {LENSFARM_CMAKE_COMMAND, "--install", LENSFARM_BINARY_DIR, "--prefix", prefix_.path().string()}, 120);
  ASSERT_EQ(again.exitCode, 0) << again.err;
  EXPECT_EQ(test::readFile(prefix_ / "etc/lensfarm/coordinator.env"), "LENSFARM_LISTEN=10.0.0.1:7878\n");
}

// The Python library lands in the site directory of Debian's Python under the prefix, with its
// generated lensfarm.v1 stubs, and imports from there at the renderer's version; the Blender
// add-on's zip and the Python and Blender pages are installed; the USD example renders from there.
TEST_F(Install, PutsThePythonLibraryTheBlenderAddonAndTheUsdExampleInTheirPlaces) {
  const fs::path site = prefix_ / "lib/python3.11/dist-packages";
  for (const char* file : {"lensfarm/__init__.py", "lensfarm/client.py", "lensfarm/_version.py",
                           "lensfarm/v1/client_service_pb2.py", "lensfarm/v1/client_service_pb2_grpc.py"})
    EXPECT_TRUE(fs::is_regular_file(site / file)) << file;
  const auto imported = test::runProcess({"/usr/bin/env", "PYTHONPATH=" + site.string(), "/usr/bin/python3", "-c",
                                          "import lensfarm; print(lensfarm.__file__, lensfarm.RENDERER_VERSION)"},
                                         60);
  EXPECT_EQ(imported.exitCode, 0) << imported.err;
  EXPECT_TRUE(test::contains(imported.out, (site / "lensfarm/__init__.py").string() + " " + kRendererVersion));
  for (const char* file :
       {"share/lensfarm/blender/render_lensfarm.zip", "share/doc/lensfarm/python.md", "share/doc/lensfarm/blender.md",
        "share/lensfarm/scenes/usd/props/crate.usda", "share/lensfarm/scenes/usd/textures/checker.png"})
    EXPECT_TRUE(fs::is_regular_file(prefix_ / file)) << file;
  const auto r = test::runProcess(
      {(prefix_ / "bin/lensfarm").string(), "render", (prefix_ / "share/lensfarm/scenes/usd/studio.usda").string(),
       "--resolution", "8x8", "--spp", "1", "-q", "-o", (prefix_ / "usd.exr").string()},
      120);
  EXPECT_EQ(r.exitCode, 0) << r.err;
}

// The installed `lensfarm` reads an OpenVDB file through the module installed beside it
// (medium/vdb_grid.h), not the build tree's: the dynamic linker names the file it loads.
TEST_F(Install, TheInstalledBinaryReadsOpenVdbThroughItsInstalledModule) {
  const fs::path module = prefix_ / "lib/lensfarm/liblensfarm_openvdb.so";
  ASSERT_TRUE(fs::is_regular_file(module)) << module;
  openvdb::initialize();
  openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
  grid->setName("density");
  grid->tree().setValue(openvdb::Coord(0, 0, 0), 1.0f);
  openvdb::io::File((prefix_ / "fog.vdb").string()).write({grid});
  nlohmann::json scene = test::minimalSceneJson();
  scene["medium"] = "fog";
  scene["media"] = {{"fog", {{"type", "grid"}, {"file", "fog.vdb"}, {"sigma_s", 0.5}, {"sigma_a", 0.1}}}};
  prefix_.write("fog.json", scene.dump());
  const auto r = test::runProcess({"/usr/bin/env", "LD_DEBUG=files", (prefix_ / "bin/lensfarm").string(), "render",
                                   (prefix_ / "fog.json").string(), "-q", "-o", (prefix_ / "fog.exr").string()},
                                  120);
  ASSERT_EQ(r.exitCode, 0) << r.err.substr(r.err.size() > 4000 ? r.err.size() - 4000 : 0);
  std::string loaded;  // the loader's lines about the module, for the message
  for (const std::string& line : test::lines(r.err))
    if (line.find("openvdb") != std::string::npos) loaded += line + "\n";
  EXPECT_NE(r.err.find("file=" + module.string()), std::string::npos)
      << "the installed module was not the one loaded:\n"
      << loaded;
}

// The installed `lensfarm slurm` submits the installed worker script and names the installed
// worker beside it (a recording stand-in for sbatch here; tests/deploy/slurm_test.cpp runs a real Slurm).
TEST_F(Install, TheSlurmScriptsAreInstalledWhereLensfarmSlurmFindsThem) {
  for (const char* script : {"lensfarm-worker.sbatch", "lensfarm-coordinator.sbatch"}) {
    const fs::path path = prefix_ / "share/lensfarm/slurm" / script;
    ASSERT_TRUE(fs::is_regular_file(path)) << path;
    EXPECT_NE(fs::status(path).permissions() & fs::perms::owner_exec, fs::perms::none) << path;
  }
  EXPECT_TRUE(fs::is_regular_file(prefix_ / "share/lensfarm/slurm/README.md"));
  const fs::path bin = prefix_ / "fake-bin", record = prefix_ / "sbatch.txt";
  prefix_.write("fake-bin/sbatch",
                "#!/bin/sh\n{ printf '%s\\n' \"$@\"; echo \"LENSFARM_WORKER=$LENSFARM_WORKER\"; } > " +
                    record.string() + "\necho 4242\n");
  fs::permissions(bin / "sbatch", fs::perms::owner_all);
  const auto r = test::runProcess(
      {"/usr/bin/env", "PATH=" + bin.string() + ":/usr/bin:/bin", (prefix_ / "bin/lensfarm").string(), "slurm",
       "--workers", "3", "--coordinator", "farm-host:7878", "--log-dir", (prefix_ / "logs").string()},
      30);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.out, "4242\n");
  const std::string args = test::readFile(record);
  EXPECT_TRUE(test::contains(args, "--array=0-2\n"));
  EXPECT_TRUE(test::contains(
      args, (fs::canonical(prefix_.path()) / "share/lensfarm/slurm/lensfarm-worker.sbatch").string() + "\n"));
  EXPECT_TRUE(
      test::contains(args, "LENSFARM_WORKER=" + (fs::canonical(prefix_.path()) / "bin/lensfarm-worker").string()));
}

TEST_F(Install, UnitsRunTheInstalledBinariesWithFlagsTheyAccept) {
  struct Case {
    const char* unit;
    const char* binary;
    const char* envFile;
    std::vector<std::string> tokens;  // credentials the unit loads and passes as files
  };
  for (const Case& c : {Case{"lensfarm-coordinator.service",
                             "lensfarm-coordinator",
                             "coordinator.env",
                             {"client.token", "worker.token"}},
                        Case{"lensfarm-worker@.service", "lensfarm-worker", "worker.env", {"worker.token"}}}) {
    SCOPED_TRACE(c.unit);
    const auto settings = settingsOf(unitDir() / c.unit);
    const std::vector<std::string> exec = test::words(only(settings, "ExecStart"));
    ASSERT_FALSE(exec.empty());
    EXPECT_TRUE(test::runsWithItsFlags(exec, prefix_ / "bin" / c.binary))
        << "the installed binary, by its installed path";
    const test::Help help = test::helpOf(exec[0]);

    // Tokens: loaded as credentials from the settings directory, passed as %d/NAME.
    std::set<std::string> loaded;
    for (auto [it, end] = settings.equal_range("LoadCredential"); it != end; ++it) {
      const std::string name = it->second.substr(0, it->second.find(':'));
      EXPECT_EQ(fs::path(it->second.substr(it->second.find(':') + 1)), prefix_ / "etc/lensfarm" / name);
      loaded.insert(name);
    }
    for (const std::string& token : c.tokens) {
      EXPECT_TRUE(loaded.count(token)) << token;
      EXPECT_NE(only(settings, "ExecStart").find("-token-file %d/" + token), std::string::npos) << token;
    }
    EXPECT_EQ(only(settings, "Restart"), "on-failure");
    EXPECT_EQ(only(settings, "KillSignal"), "SIGTERM");
    EXPECT_TRUE(std::regex_match(only(settings, "TimeoutStopSec"), std::regex("[0-9]+(s|min)"))) << "room to drain";
    EXPECT_EQ(only(settings, "DynamicUser"), "yes") << "never root";

    // Every LENSFARM_* setting of the example file is read by the binary, or used by the unit.
    const auto envFiles = settings.equal_range("EnvironmentFile");
    ASSERT_NE(envFiles.first, envFiles.second);
    EXPECT_EQ(envFiles.first->second, "-" + (prefix_ / "etc/lensfarm" / c.envFile).string());
    const std::set<std::string> variables = variablesOf(prefix_ / "etc/lensfarm" / c.envFile);
    EXPECT_GE(variables.size(), 3u);
    for (const std::string& v : variables)
      EXPECT_TRUE(help.text.find(v) != std::string::npos ||
                  only(settings, "ExecStart").find("${" + v + "}") != std::string::npos)
          << v << " is read by neither " << c.binary << " nor its unit";
  }
  // The coordinator's state and the worker's cache live in directories systemd makes for them.
  const auto coordinator = settingsOf(unitDir() / "lensfarm-coordinator.service");
  EXPECT_EQ(test::optionOf(test::words(only(coordinator, "ExecStart")), "--state-dir"),
            "%S/" + only(coordinator, "StateDirectory"));
  const auto worker = settingsOf(unitDir() / "lensfarm-worker@.service");
  EXPECT_EQ(test::optionOf(test::words(only(worker, "ExecStart")), "--cache-dir")
                .rfind("%C/" + only(worker, "CacheDirectory") + "/", 0),
            0u);
  EXPECT_EQ(test::optionOf(test::words(only(worker, "ExecStart")), "--coordinator"), "%I:${LENSFARM_COORDINATOR_PORT}");
  EXPECT_EQ(only(worker, "RestartPreventExitStatus"), "2 3") << "a refused token or version is not retried";

  // The example settings serve the dashboard beside the gRPC port, on a port of its own (the loop
  // above checked that the coordinator reads each variable).
  std::map<std::string, std::string> assigned;  // the settings not commented out
  std::ifstream in(prefix_ / "etc/lensfarm/coordinator.env");
  for (std::string line; std::getline(in, line);)
    if (const size_t eq = line.find('='); !line.empty() && line[0] != '#' && eq != std::string::npos)
      assigned[line.substr(0, eq)] = line.substr(eq + 1);
  ASSERT_TRUE(assigned.count("LENSFARM_LISTEN"));
  ASSERT_TRUE(assigned.count("LENSFARM_DASHBOARD_LISTEN")) << "the gRPC port is served, so is the dashboard's";
  const int dashboardPort = test::portOf(assigned["LENSFARM_DASHBOARD_LISTEN"]);
  EXPECT_GT(dashboardPort, 0);
  EXPECT_NE(dashboardPort, test::portOf(assigned["LENSFARM_LISTEN"]));
  EXPECT_NE(dashboardPort, test::portOf(assigned["LENSFARM_METRICS_LISTEN"]));
}

TEST_F(Install, SystemdAnalyzeVerifiesTheUnits) {
  const fs::path analyze = "/usr/bin/systemd-analyze";
  ASSERT_TRUE(fs::exists(analyze)) << "systemd-analyze is missing (scripts/setup.sh installs the systemd package)";
  // A template is verified through an instance of it.
  const fs::path instance = prefix_ / "lensfarm-worker@farm-host.service";
  fs::copy_file(unitDir() / "lensfarm-worker@.service", instance);
  for (const fs::path& unit : {unitDir() / "lensfarm-coordinator.service", instance}) {
    const auto r = test::runProcess({analyze.string(), "verify", unit.string()}, 60);
    EXPECT_EQ(r.exitCode, 0) << unit << ":\n" << r.out << r.err;
    // Unknown keys and bad values are only warnings to systemd-analyze: none may appear.
    EXPECT_EQ(r.out + r.err, "") << unit;
  }
  // ... and it does object to a broken unit, so silence above means something.
  const fs::path broken = prefix_ / "broken.service";
  prefix_.write("broken.service",
                test::readFile(unitDir() / "lensfarm-coordinator.service") + "[Service]\nRestartt=always\n");
  const auto r = test::runProcess({analyze.string(), "verify", broken.string()}, 60);
  EXPECT_NE(r.out + r.err, "");
}

}  // namespace
}  // namespace lensfarm
