// What can be checked of the container set-up without a container engine: the Dockerfile's build
// stage installs a Debian package for every dependency CMake looks for (the same names as
// scripts/setup.sh), its runtime stage installs exactly the packages of the libraries the built
// binaries link to, and docker-compose.yml runs the binaries with flags they accept on the ports
// it publishes.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <fstream>
#include <functional>
#include <regex>
#include <sstream>

#include "common/render/build_identity.h"
#include "tests/deploy_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

// One stage of a Dockerfile: its FROM line and its instructions, continuation lines joined.
struct Stage {
  std::string from;
  std::vector<std::string> instructions;
  std::set<std::string> aptPackages;  // what its `apt-get install` lines install
};

std::vector<Stage> stagesOf(const fs::path& dockerfile) {
  std::vector<Stage> stages;
  std::ifstream in(dockerfile);
  std::string instruction;
  for (std::string line; std::getline(in, line);) {
    if (instruction.empty() && (line.empty() || line[0] == '#')) continue;
    if (!line.empty() && line.back() == '\\') {
      instruction += line.substr(0, line.size() - 1) + " ";
      continue;
    }
    instruction += line;
    if (instruction.rfind("FROM ", 0) == 0) stages.push_back(Stage{instruction, {}, {}});
    if (!stages.empty()) stages.back().instructions.push_back(instruction);
    // `apt-get install [-options] packages` up to the next `&&`.
    if (const size_t at = instruction.find("apt-get install"); at != std::string::npos && !stages.empty()) {
      const size_t end = instruction.find("&&", at);
      const std::string command = instruction.substr(at + 15, end == std::string::npos ? end : end - at - 15);
      for (const std::string& w : test::words(command))
        if (w[0] != '-') stages.back().aptPackages.insert(w);
    }
    instruction.clear();
  }
  return stages;
}

// The packages of one list of scripts/setup.sh ("BUILD_PACKAGES", "TEST_PACKAGES", ...).
std::set<std::string> setupPackages(const std::string& list) {
  const std::string script = test::readFile(test::sourceDir() / "scripts/setup.sh");
  const size_t begin = script.find("\n" + list + "=(");
  EXPECT_NE(begin, std::string::npos) << list << " not in scripts/setup.sh";
  if (begin == std::string::npos) return {};
  const size_t start = begin + list.size() + 3, end = script.find("\n)", start);  // a comment may hold ')'
  std::set<std::string> out;
  std::istringstream in(script.substr(start, end - start));
  for (std::string line; std::getline(in, line);)
    for (const std::string& w : test::words(line.substr(0, line.find('#')))) out.insert(w);
  return out;
}

// Every dependency the CMakeLists.txt files look for: find_package(NAME ...),
// find_library(VAR NAME) and pkg_check_modules(VAR ... MODULE), each with whether only the tests and benchmarks need it
// (looked for in a CMakeLists.txt under tests/ or bench/, which LENSFARM_BUILD_TESTS=OFF skips).
std::map<std::string, bool> cmakeDependencies() {
  std::map<std::string, bool> out;  // name -> test-only
  const auto add = [&](const std::string& name, bool testOnly) {
    const auto [it, inserted] = out.emplace(name, testOnly);
    if (!inserted) it->second = it->second && testOnly;
  };
  const std::regex findPackage(R"(find_package\(\s*([A-Za-z0-9_-]+))");
  const std::regex pkgConfig(R"(pkg_check_modules\(\s*\w+((?:\s+[A-Za-z0-9_.-]+)+)\s*\))");
  const std::regex findLibrary(R"(find_library\(\s*\w+\s+([A-Za-z0-9_.-]+))");
  const fs::path root = test::sourceDir();
  for (auto walk = fs::recursive_directory_iterator(root); walk != fs::recursive_directory_iterator(); ++walk) {
    const std::string name = walk->path().filename().string();
    if (walk->is_directory() && (name[0] == '.' || name.rfind("build", 0) == 0 || name == "out"))
      walk.disable_recursion_pending();
    const fs::directory_entry& entry = *walk;
    if (name != "CMakeLists.txt") continue;
    const std::string top = fs::relative(entry.path(), root).begin()->string();
    const bool testOnly = top == "tests" || top == "bench";
    const std::string text = test::readFile(entry.path());
    for (auto it = std::sregex_iterator(text.begin(), text.end(), findPackage); it != std::sregex_iterator(); ++it)
      add((*it)[1], testOnly);
    for (auto it = std::sregex_iterator(text.begin(), text.end(), findLibrary); it != std::sregex_iterator(); ++it)
      add((*it)[1], testOnly);
    for (auto it = std::sregex_iterator(text.begin(), text.end(), pkgConfig); it != std::sregex_iterator(); ++it)
      for (const std::string& w : test::words((*it)[1]))
        if (w != "REQUIRED" && w != "IMPORTED_TARGET" && w != "QUIET") add(w, testOnly);
  }
  return out;
}

// A value of the build's CMakeCache.txt.
std::string cacheValue(const std::string& key) {
  std::ifstream in(fs::path(LENSFARM_BINARY_DIR) / "CMakeCache.txt");
  for (std::string line; std::getline(in, line);)
    if (line.rfind(key + ":", 0) == 0) return line.substr(line.find('=') + 1);
  return "";
}

// The file find_package(NAME ... CONFIG) read: <NAME>Config.cmake or <name>-config.cmake in the
// directory CMake recorded as NAME_DIR. Only that file, never another one of the directory: the
// directory may hold files of several packages (GTest's holds GMockTargets.cmake of libgmock-dev).
fs::path configFileOf(const std::string& name) {
  const fs::path dir = cacheValue(name + "_DIR");
  std::string lower = name;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  for (const fs::path& file : {dir / (name + "Config.cmake"), dir / (lower + "-config.cmake")})
    if (fs::is_regular_file(file)) return file;
  return dir / (name + "Config.cmake");  // missing: the owner check names it
}

// What each CMake dependency is called in Debian, and a file CMake used from it (which that
// package, or one it depends on, must have installed).
struct Dependency {
  std::vector<std::string> packages;  // the first is the one `evidence` belongs to
  std::function<fs::path()> evidence;
};
const std::map<std::string, Dependency>& debianNames() {
  const auto config = [](std::string name) { return [name] { return configFileOf(name); }; };
  const auto cached = [](std::string key) { return [key] { return fs::path(cacheValue(key)); }; };
  static const std::map<std::string, Dependency> table = {
      {"glm", {{"libglm-dev"}, config("glm")}},
      {"embree", {{"libembree-dev"}, config("embree")}},
      {"TBB", {{"libtbb-dev"}, config("TBB")}},
      {"OpenEXR", {{"libopenexr-dev"}, config("OpenEXR")}},
      {"PNG", {{"libpng-dev"}, cached("PNG_LIBRARY_RELEASE")}},
      {"nlohmann_json", {{"nlohmann-json3-dev"}, config("nlohmann_json")}},
      {"tinyobjloader", {{"libtinyobjloader-dev"}, config("tinyobjloader")}},
      {"TinyGLTF", {{"libtinygltf-dev"}, config("TinyGLTF")}},
      {"stb", {{"libstb-dev"}, [] { return fs::path(cacheValue("STB_LIBDIR")) / "pkgconfig/stb.pc"; }}},
      {"spdlog", {{"libspdlog-dev"}, config("spdlog")}},
      {"CLI11", {{"libcli11-dev"}, config("CLI11")}},
      {"OpenSSL", {{"libssl-dev"}, cached("OPENSSL_CRYPTO_LIBRARY")}},
      {"SQLite3", {{"libsqlite3-dev"}, cached("SQLite3_LIBRARY")}},
      {"Protobuf", {{"libprotobuf-dev", "protobuf-compiler"}, cached("Protobuf_LIBRARY_RELEASE")}},
      {"gRPC", {{"libgrpc++-dev", "protobuf-compiler-grpc"}, config("gRPC")}},
      {"GTest", {{"libgtest-dev"}, config("GTest")}},
      {"benchmark", {{"libbenchmark-dev"}, config("benchmark")}},
      {"yaml-cpp", {{"libyaml-cpp-dev"}, config("yaml-cpp")}},
      {"PkgConfig", {{"pkg-config"}, cached("PKG_CONFIG_EXECUTABLE")}},
      {"cpp-httplib",
       {{"libcpp-httplib-dev"}, [] { return fs::path(cacheValue("HTTPLIB_LIBDIR")) / "pkgconfig/cpp-httplib.pc"; }}},
      {"fftw3", {{"libfftw3-dev"}, [] { return fs::path(cacheValue("FFTW_LIBDIR")) / "pkgconfig/fftw3.pc"; }}},
      // (libzstd.pc says libdir=/usr/lib; the library pkg-config found is the evidence.)
      {"libzstd", {{"libzstd-dev"}, cached("pkgcfg_lib_ZSTD_zstd")}},
      {"openvdb", {{"libopenvdb-dev"}, cached("OPENVDB_LIBRARY")}},  // find_library (CMakeLists.txt says why)
      {"Boost", {{"libboost-dev"}, config("Boost")}},
      {"libzip", {{"libzip-dev"}, cached("pkgcfg_lib_LIBZIP_zip")}},
  };
  return table;
}

fs::path dockerfile() { return test::sourceDir() / "deploy/docker/Dockerfile"; }

// Every dependency CMake looks for is installed by the lists that need it: a product dependency by
// the Dockerfile's build stage and setup.sh's BUILD_PACKAGES (what `make demo` installs), a test
// or benchmark one by setup.sh's TEST_PACKAGES. The table is checked against dpkg's own record of
// the file CMake read, whatever else is installed and in whichever order.
TEST(Container, TheBuildStageInstallsEveryDependencyCMakeLooksFor) {
  const std::vector<Stage> stages = stagesOf(dockerfile());
  ASSERT_EQ(stages.size(), 2u) << "a build stage and a runtime stage";
  EXPECT_EQ(stages[0].from, "FROM debian:12 AS build");
  const std::set<std::string> image = stages[0].aptPackages, build = setupPackages("BUILD_PACKAGES"),
                              tests = setupPackages("TEST_PACKAGES");
  ASSERT_GE(image.size(), 10u);
  const std::map<std::string, bool> dependencies = cmakeDependencies();
  EXPECT_GE(dependencies.size(), 15u) << "the scan found the find_package calls";
  EXPECT_TRUE(dependencies.count("GTest") && dependencies.at("GTest")) << "GoogleTest is looked for by tests/ only";
  EXPECT_TRUE(dependencies.count("gRPC") && !dependencies.at("gRPC"));
  std::vector<fs::path> evidence;
  for (const auto& [name, dependency] : debianNames()) evidence.push_back(dependency.evidence());
  const auto owners = test::debianOwnersOf(evidence);
  for (const auto& [name, testOnly] : dependencies) {
    SCOPED_TRACE(name);
    const auto it = debianNames().find(name);
    if (it == debianNames().end()) {
      ADD_FAILURE() << "CMake looks for " << name << ": add its Debian package to this test's table, "
                    << (testOnly ? "and to TEST_PACKAGES of scripts/setup.sh"
                                 : "the Dockerfile and BUILD_PACKAGES of scripts/setup.sh");
      continue;
    }
    for (const std::string& package : it->second.packages) {
      if (testOnly) {
        EXPECT_TRUE(tests.count(package) || build.count(package))
            << package << " missing from TEST_PACKAGES of scripts/setup.sh";
      } else {
        EXPECT_TRUE(image.count(package)) << package << " missing from the Dockerfile's build stage";
        EXPECT_TRUE(build.count(package)) << package << " missing from BUILD_PACKAGES of scripts/setup.sh";
      }
    }
    // The table is right: the file CMake found belongs to that package (or to one it pulls in).
    const fs::path found = it->second.evidence();
    const std::string& package = it->second.packages[0];
    const std::set<std::string>& listed = owners.at(found);
    ASSERT_FALSE(listed.empty()) << found << " belongs to no Debian package";
    const std::set<std::string> depends = test::debianDependsOf(package);
    bool belongs = false;
    for (const std::string& owner : listed) belongs |= owner == package || depends.count(owner) > 0;
    EXPECT_TRUE(belongs) << "CMake found " << name << " in " << found << ", installed by " << *listed.begin()
                         << ", not by " << package;
  }
  for (const std::string& package : image)
    EXPECT_TRUE(build.count(package)) << package << ": the image and setup.sh agree";

  bool builds = false, installs = false, withoutTests = false;
  for (const std::string& i : stages[0].instructions) {
    builds |= i.find("cmake --build") != std::string::npos;
    installs |= i.find("cmake --install") != std::string::npos;
    withoutTests |= i.find("-DLENSFARM_BUILD_TESTS=OFF") != std::string::npos;
  }
  EXPECT_TRUE(builds && installs) << "the build stage builds and installs with CMake";
  EXPECT_TRUE(withoutTests) << "the image has no test packages, so it configures without the tests";
}

TEST(Container, TheRuntimeStageInstallsExactlyThePackagesOfTheLibrariesTheBinariesNeed) {
  const std::vector<Stage> stages = stagesOf(dockerfile());
  ASSERT_EQ(stages.size(), 2u);
  EXPECT_EQ(stages[1].from, "FROM debian:12-slim");
  // The libraries each binary itself names (DT_NEEDED), found where the loader finds them.
  std::map<fs::path, std::string> libraries;  // path -> soname
  // (and the OpenVDB module the image installs beside them, medium/vdb_grid.h)
  for (const fs::path& binary :
       {test::cliPath(), test::coordinatorPath(), test::workerPath(), fs::path(LENSFARM_OPENVDB_MODULE)}) {
    const auto dynamic = test::runProcess({"/usr/bin/readelf", "-d", binary.string()}, 30);
    const auto loader = test::runProcess({"/usr/bin/ldd", binary.string()}, 30);
    ASSERT_EQ(dynamic.exitCode, 0) << dynamic.err;
    ASSERT_EQ(loader.exitCode, 0) << loader.err;
    std::map<std::string, std::string> resolved;  // soname -> path, as ldd prints "\tSONAME => PATH (0x...)"
    std::istringstream lines(loader.out);
    for (std::string line; std::getline(lines, line);)
      if (const std::vector<std::string> w = test::words(line); w.size() >= 3 && w[1] == "=>") resolved[w[0]] = w[2];
    const std::regex needs(R"(\(NEEDED\)\s+Shared library: \[([^\]]+)\])");
    size_t count = 0;
    for (auto it = std::sregex_iterator(dynamic.out.begin(), dynamic.out.end(), needs); it != std::sregex_iterator();
         ++it) {
      const std::string soname = (*it)[1];
      if (soname.rfind("ld-linux", 0) == 0) continue;  // the loader itself (libc6), which a .so may name
      ASSERT_TRUE(resolved.count(soname)) << soname << " of " << binary << " not found by ldd";
      libraries[resolved[soname]] = soname;
      ++count;
    }
    EXPECT_GE(count, binary.extension() == ".so" ? 3u : 10u) << binary;
  }
  std::vector<fs::path> paths;
  for (const auto& [path, soname] : libraries) paths.push_back(path);
  std::map<std::string, std::string> needed;  // package -> a library that calls for it
  for (const auto& [path, package] : test::debianPackagesOf(paths)) {
    ASSERT_TRUE(package) << path << " belongs to no package";
    needed.emplace(*package, libraries[path]);
  }
  // libc, libgcc and libstdc++ are in every Debian image (apt itself needs them).
  for (const char* base : {"libc6", "libgcc-s1", "libstdc++6"}) EXPECT_TRUE(needed.erase(base)) << base;
  const std::set<std::string>& runtime = stages[1].aptPackages;
  for (const auto& [package, soname] : needed)
    EXPECT_TRUE(runtime.count(package)) << package << " (for " << soname << ") missing from the runtime stage";
  for (const std::string& package : runtime)
    EXPECT_TRUE(needed.count(package)) << package << " is in the runtime stage, but no binary links to it";
  for (const std::string& package : runtime)
    EXPECT_EQ(package.find("-dev"), std::string::npos) << "no -dev packages at run time: " << package;

  // A non-root user runs the binaries the build stage installed.
  std::string user;
  bool copies = false, copiesModule = false;
  for (const std::string& i : stages[1].instructions) {
    if (i.rfind("USER ", 0) == 0) user = i.substr(5);
    copies |= i.rfind("COPY --from=build ", 0) == 0 && i.find("/usr/bin/") != std::string::npos;
    copiesModule |= i.rfind("COPY --from=build /stage/usr/lib/ ", 0) == 0;  // <libdir>/lensfarm/
  }
  EXPECT_TRUE(copies);
  EXPECT_TRUE(copiesModule) << "the OpenVDB module is installed under /usr/lib";
  EXPECT_FALSE(user.empty());
  EXPECT_NE(user, "root");
  EXPECT_NE(user, "0");
}

std::vector<std::string> commandOf(const YAML::Node& node) {
  std::vector<std::string> argv;
  for (const auto& word : node) argv.push_back(word.as<std::string>());
  return argv;
}

TEST(Container, ComposeRunsTheBinariesWithTheirFlagsOnThePortsItPublishes) {
  const fs::path dir = test::sourceDir() / "deploy/docker";
  const YAML::Node compose = YAML::LoadFile((dir / "docker-compose.yml").string());
  const YAML::Node coordinator = compose["services"]["coordinator"], worker = compose["services"]["worker"];
  ASSERT_TRUE(coordinator && worker);
  EXPECT_TRUE(fs::exists(dir / compose["services"]["coordinator"]["build"]["context"].as<std::string>() /
                         coordinator["build"]["dockerfile"].as<std::string>()));
  EXPECT_EQ(worker["image"].as<std::string>(), coordinator["image"].as<std::string>()) << "one image";

  const std::vector<std::string> c = commandOf(coordinator["command"]), w = commandOf(worker["command"]);
  EXPECT_TRUE(test::runsWithItsFlags(c, test::coordinatorPath()));
  EXPECT_TRUE(test::runsWithItsFlags(w, test::workerPath()));

  // The ports the coordinator listens on (gRPC, metrics and the dashboard) are the ones
  // published, and the ones the image exposes.
  std::set<int> published;
  for (const auto& p : coordinator["ports"]) published.insert(test::portOf(p.as<std::string>()));
  const int grpcPort = test::portOf(test::optionOf(c, "--listen")),
            metricsPort = test::portOf(test::optionOf(c, "--metrics-listen")),
            dashboardPort = test::portOf(test::optionOf(c, "--dashboard-listen"));
  EXPECT_GT(dashboardPort, 0) << "the coordinator serves its dashboard (--dashboard-listen)";
  EXPECT_EQ(published, (std::set<int>{grpcPort, metricsPort, dashboardPort}));
  std::string expose;
  const std::vector<Stage> stages = stagesOf(dockerfile());
  for (const std::string& i : stages.back().instructions)
    if (i.rfind("EXPOSE ", 0) == 0) expose = i;
  EXPECT_EQ(expose, "EXPOSE " + std::to_string(grpcPort) + " " + std::to_string(metricsPort) + " " +
                        std::to_string(dashboardPort));

  // Workers dial the coordinator's service name on its port.
  EXPECT_EQ(test::optionOf(w, "--coordinator"), "coordinator:" + std::to_string(grpcPort));
  EXPECT_GE(worker["deploy"]["replicas"].as<int>(), 2);

  // The state directory is a named volume.
  const std::string stateDir = test::optionOf(c, "--state-dir");
  bool onVolume = false;
  for (const auto& v : coordinator["volumes"]) {
    const std::string mount = v.as<std::string>();
    const std::string name = mount.substr(0, mount.find(':'));
    onVolume |= mount.substr(mount.find(':') + 1) == stateDir && compose["volumes"][name].IsDefined();
  }
  EXPECT_TRUE(onVolume) << stateDir;

  // Tokens come from Docker secrets, one per service; the coordinator serves the network with both.
  const auto secretFile = [&](const YAML::Node& service, const std::vector<std::string>& argv,
                              const std::string& flag) {
    const std::string path = test::optionOf(argv, flag);
    const std::string name = fs::path(path).filename().string();
    EXPECT_EQ(path, "/run/secrets/" + name) << flag;
    bool listed = false;
    for (const auto& s : service["secrets"]) listed |= s.as<std::string>() == name;
    EXPECT_TRUE(listed) << name << " is not given to the service";
    EXPECT_TRUE(compose["secrets"][name]["file"].IsDefined()) << name;
    return name;
  };
  const std::string clientSecret = secretFile(coordinator, c, "--client-token-file");
  const std::string workerSecret = secretFile(coordinator, c, "--worker-token-file");
  EXPECT_NE(clientSecret, workerSecret);
  EXPECT_EQ(secretFile(worker, w, "--token-file"), workerSecret);
}

// The image's worker is the same build as `make build` on Debian 12, so a farm mixing the two
// gives the same bits and the same build identity (docs/farm.md "Mixed machines"): the same base
// (Debian 12's compiler, Embree and glibc), the same build type as the Makefile's default, and no
// flags of its own that could change the code generated.
TEST(Container, TheImageBuildsTheRendererAsMakeBuildDoes) {
  const std::vector<Stage> stages = stagesOf(dockerfile());
  ASSERT_EQ(stages.size(), 2u);
  std::string configure;
  for (const std::string& i : stages[0].instructions)
    if (i.find("cmake -S") != std::string::npos) configure = i;
  ASSERT_FALSE(configure.empty()) << "the build stage configures with cmake -S";
  EXPECT_NE(configure.find("-DCMAKE_BUILD_TYPE=Release"), std::string::npos) << configure;
  for (const char* flag : {"CMAKE_CXX_FLAGS", "CMAKE_C_FLAGS", "-march", "-mtune", "-O", "CMAKE_CXX_COMPILER"})
    EXPECT_EQ(configure.find(flag), std::string::npos) << flag << " would make another build: " << configure;
  const std::string makefile = test::readFile(test::sourceDir() / "Makefile");
  EXPECT_NE(makefile.find("CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release\n"), std::string::npos)
      << "make build's default build type is the image's";
  // A build's identity names what the image's shares with `make build`'s: compiler, build type,
  // Embree and glibc.
  EXPECT_TRUE(
      std::regex_search(buildIdentity(), std::regex(R"(^(gcc|clang) \S+.* \S+, Embree [0-9.]+, glibc [0-9.]+, )")))
      << buildIdentity();
}

}  // namespace
}  // namespace lensfarm
