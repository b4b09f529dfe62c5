#include "tests/test_support.h"
#include "common/util/file_contents.h"

#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>

#include "common/film/sensor.h"
#include "common/render/unit_renderer.h"
#include "common/scene/scene_loader.h"

#include <tbb/task_arena.h>

namespace lensfarm::test {

namespace fs = std::filesystem;
using json = nlohmann::json;

TempDir::TempDir() {
  std::random_device rd;
  for (int attempt = 0; attempt < 100; ++attempt) {
    const fs::path candidate = fs::temp_directory_path() / ("lensfarm-test-" + std::to_string(rd()));
    if (fs::create_directory(candidate)) {
      path_ = candidate;
      return;
    }
  }
  throw std::runtime_error("cannot create a temporary directory");
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

fs::path TempDir::write(const std::string& name, const std::string& text) const {
  const fs::path p = path_ / name;
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
  // Its owner's alone, as a token file must be (the services refuse one others can read).
  fs::permissions(p, fs::perms::owner_read | fs::perms::owner_write);
  return p;
}

fs::path sourceDir() { return LENSFARM_SOURCE_DIR; }
fs::path scenesDir() { return sourceDir() / "scenes"; }

namespace {
// Tests load the shipped scenes' meshes from temporary folders by absolute paths
// (bundledSceneJson): the scenes folder is allowed for them, as a user allows an asset library
// (scene/asset_path.h), and for every process they start. A value already set is kept.
const bool kScenesAllowed = [] {
  setenv("LENSFARM_ALLOW_PATH", (sourceDir() / "scenes").c_str(), 0);
  return true;
}();
}  // namespace
fs::path cliPath() { return LENSFARM_CLI; }
fs::path coordinatorPath() { return LENSFARM_COORDINATOR_BIN; }
fs::path workerPath() { return LENSFARM_WORKER_BIN; }

json bundledSceneJson(const std::string& name) {
  json scene = json::parse(std::ifstream(scenesDir() / name));
  for (json& shape : scene["shapes"])
    if (shape.contains("file")) shape["file"] = (scenesDir() / shape["file"].get<std::string>()).string();
  if (scene.contains("camera") && scene["camera"].contains("lens"))
    scene["camera"]["lens"] = (scenesDir() / scene["camera"]["lens"].get<std::string>()).string();
  return scene;
}

json minimalSceneJson() {
  return json::parse(R"({
    "format": "lensfarm-scene/1",
    "camera": { "type": "pinhole", "position": [0, 0, -3], "look_at": [0, 0, 0], "up": [0, 1, 0],
                "sensor_width": 0.1, "focal_length": 0.1 },
    "materials": { "white": { "type": "lambertian", "albedo": 0.5 } },
    "shapes": [ { "type": "quad", "corner": [-1, -1, 0], "edge1": [0, 2, 0], "edge2": [2, 0, 0],
                  "material": "white" } ],
    "lights": [ { "type": "quad", "corner": [-0.5, -0.5, -1], "edge1": [1, 0, 0], "edge2": [0, 1, 0],
                  "radiance": 5, "visible_to_camera": false } ],
    "render": { "resolution": [16, 16], "samples_per_pixel": 2, "max_bounces": 2, "seed": 7 }
  })");
}

json minimalSceneWithCamera(const json& camera) {
  json j = minimalSceneJson();
  for (auto it = camera.begin(); it != camera.end(); ++it) {
    if (it.value().is_null())
      j["camera"].erase(it.key());
    else
      j["camera"][it.key()] = it.value();
  }
  return j;
}

std::string sphereObj(int rings, int segments) {
  std::ostringstream obj;
  obj << "v 0 1 0\n";
  for (int r = 1; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const double theta = M_PI * r / rings, phi = 2 * M_PI * s / segments;
      obj << "v " << std::sin(theta) * std::cos(phi) << " " << std::cos(theta) << " " << std::sin(theta) * std::sin(phi)
          << "\n";
    }
  obj << "v 0 -1 0\n";
  const auto idx = [&](int r, int s) { return 2 + (r - 1) * segments + (s % segments); };  // 1-based
  const int south = 2 + (rings - 1) * segments;
  for (int s = 0; s < segments; ++s) obj << "f 1 " << idx(1, s + 1) << " " << idx(1, s) << "\n";
  for (int r = 1; r < rings - 1; ++r)
    for (int s = 0; s < segments; ++s)
      obj << "f " << idx(r, s) << " " << idx(r, s + 1) << " " << idx(r + 1, s + 1) << " " << idx(r + 1, s) << "\n";
  for (int s = 0; s < segments; ++s)
    obj << "f " << south << " " << idx(rings - 1, s) << " " << idx(rings - 1, s + 1) << "\n";
  return obj.str();
}

json closedBoxSceneJson(const json& wallMaterial, int resolution, uint64_t spp, int maxBounces) {
  json scene = {
      {"format", "lensfarm-scene/1"},
      {"camera",
       {{"type", "pinhole"},
        {"position", {0, 0, 0}},
        {"look_at", {0, 0, 1}},
        {"up", {0, 1, 0}},
        {"sensor_width", 0.1},
        {"angle_of_view", 87.06}}},  // 2 atan(0.95): the walls' edges out of view
      {"materials", {{"wall", wallMaterial}}},
      {"render",
       {{"resolution", {resolution, resolution}},
        {"samples_per_pixel", spp},
        {"max_bounces", maxBounces},
        {"seed", 3}}},
  };
  // Six inward-facing quads: the normal cross(edge1, edge2) points into the box.
  const json walls = json::array({
      json{{"corner", {-1, -1, 1}}, {"edge1", {0, 2, 0}}, {"edge2", {2, 0, 0}}},   // z = +1, n = -z
      json{{"corner", {-1, -1, -1}}, {"edge1", {2, 0, 0}}, {"edge2", {0, 2, 0}}},  // z = -1, n = +z
      json{{"corner", {1, -1, -1}}, {"edge1", {0, 0, 2}}, {"edge2", {0, 2, 0}}},   // x = +1, n = -x
      json{{"corner", {-1, -1, -1}}, {"edge1", {0, 2, 0}}, {"edge2", {0, 0, 2}}},  // x = -1, n = +x
      json{{"corner", {-1, 1, -1}}, {"edge1", {2, 0, 0}}, {"edge2", {0, 0, 2}}},   // y = +1, n = -y
      json{{"corner", {-1, -1, -1}}, {"edge1", {0, 0, 2}}, {"edge2", {2, 0, 0}}},  // y = -1, n = +y
  });
  json shapes = json::array();
  for (json w : walls) {
    w["type"] = "quad";
    w["material"] = "wall";
    shapes.push_back(w);
  }
  scene["shapes"] = shapes;
  return scene;
}

Rendered renderScene(const Scene& scene, int threads) {
  const RenderScene rs(scene);
  Sensor sensor(scene.render.width, scene.render.height, rs.aovLayout().channels);
  Rendered out;
  tbb::task_arena arena{threads};
  const uint32_t perUnit = unitSize(scene.render);
  for (uint64_t k = 0; k < unitCount(scene.render.samplesPerPixel, perUnit); ++k) {
    SensorBuffer buffer;
    arena.execute([&] { renderUnit(rs, unitAt(k, scene.render.samplesPerPixel, perUnit), buffer, out.stats); });
    sensor.add(buffer);
  }
  out.image = sensor.developImage(rs.aovLayout());
  const size_t pixels = size_t(out.image.width) * out.image.height;
  for (size_t k = 0; k < pixels; ++k)
    for (int c = 0; c < 3; ++c) out.mean[c] += out.image.rgb[3 * k + c] / double(pixels);
  return out;
}

ImageStatistics renderStatistics(Scene scene, int renders) {
  ImageStatistics st;
  st.renders = renders;
  std::vector<double> sum, sumSq, means;
  for (int k = 1; k <= renders; ++k) {
    scene.render.seed = uint64_t(k) * 7919u;
    const Rendered r = renderScene(scene);
    if (sum.empty()) sum.assign(r.image.rgb.size(), 0.0), sumSq.assign(r.image.rgb.size(), 0.0);
    double m = 0;
    for (size_t i = 0; i < r.image.rgb.size(); ++i) {
      sum[i] += r.image.rgb[i];
      sumSq[i] += double(r.image.rgb[i]) * r.image.rgb[i];
      m += r.image.rgb[i];
    }
    means.push_back(m / double(r.image.rgb.size()));
  }
  st.mean.resize(sum.size());
  st.variance.resize(sum.size());
  for (size_t i = 0; i < sum.size(); ++i) {
    st.mean[i] = sum[i] / renders;
    st.variance[i] = std::max(0.0, (sumSq[i] - renders * st.mean[i] * st.mean[i]) / std::max(1, renders - 1));
  }
  double mm = 0, vv = 0;
  for (double m : means) mm += m / renders;
  for (double m : means) vv += (m - mm) * (m - mm) / std::max(1, renders - 1);
  st.imageMean = mm;
  st.imageMeanError = std::sqrt(vv / renders);
  return st;
}

double agreementFraction(const ImageStatistics& a, const ImageStatistics& b, double z) {
  size_t agree = 0;
  for (size_t i = 0; i < a.mean.size(); ++i) {
    const double se = std::sqrt(a.variance[i] / a.renders + b.variance[i] / b.renders);
    const double diff = std::abs(a.mean[i] - b.mean[i]);
    if (diff <= z * se || diff <= 1e-6 * std::max(std::abs(a.mean[i]), 1e-30)) ++agree;
  }
  return a.mean.empty() ? 0.0 : double(agree) / double(a.mean.size());
}

void expectSameImage(const ImageStatistics& a, const ImageStatistics& b) {
  EXPECT_GE(agreementFraction(a, b), 0.995);
  const double se = std::hypot(a.imageMeanError, b.imageMeanError);
  EXPECT_NEAR(a.imageMean, b.imageMean, 4.0 * se) << "standard error " << se;
}

Scene loadSceneJson(const TempDir& dir, const json& scene, const std::string& name) {
  return loadScene(dir.write(name, scene.dump(2)));
}

std::string readFile(const fs::path& p) { return readWholeFile(p).value_or(""); }

int startProcess(const std::vector<std::string>& argv, const fs::path& outFile, const fs::path& errFile) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int out = ::open(outFile.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    const int err = ::open(errFile.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    ::dup2(out, 1);
    ::dup2(err, 2);
    ::signal(SIGINT, SIG_DFL);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  return pid;
}

ProcessResult runProcess(const std::vector<std::string>& argv, double timeoutSeconds) {
  TempDir io;
  const fs::path outPath = io / "stdout", errPath = io / "stderr";
  const pid_t pid = startProcess(argv, outPath, errPath);
  ProcessResult result;
  int status = 0;
  const bool exited = waitFor([&] { return ::waitpid(pid, &status, WNOHANG) == pid; }, timeoutSeconds);
  if (!exited) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
    result.timedOut = true;
  } else if (WIFEXITED(status)) {
    result.exitCode = WEXITSTATUS(status);
  }
  result.out = readFile(outPath);
  result.err = readFile(errPath);
  return result;
}

int freePort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof address;
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0)
    throw std::runtime_error("no free port");
  ::close(fd);
  return ntohs(address.sin_port);
}

ChildProcess::ChildProcess(const std::vector<std::string>& argv, const fs::path& logPrefix)
    : err_(logPrefix.string() + ".stderr") {
  pid_ = startProcess(argv, logPrefix.string() + ".stdout", err_);
}

ChildProcess::~ChildProcess() {
  if (pid_ > 0 && !reaped_) {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, &status_, 0);
  }
}

void ChildProcess::signal(int sig) const {
  if (!reaped_) ::kill(pid_, sig);
}

bool ChildProcess::running() {
  if (reaped_) return false;
  if (::waitpid(pid_, &status_, WNOHANG) == pid_) reaped_ = true;
  return !reaped_;
}

int ChildProcess::wait(double timeoutSeconds) {
  if (!waitFor([&] { return !running(); }, timeoutSeconds)) return -1;
  return WIFEXITED(status_) ? WEXITSTATUS(status_) : -1;
}

std::string ChildProcess::log() const { return readFile(err_); }

bool waitFor(const std::function<bool()>& condition, double timeoutSeconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeoutSeconds);
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

::testing::AssertionResult contains(const std::string& text, const std::string& part) {
  if (text.find(part) == std::string::npos)
    return ::testing::AssertionFailure() << "\"" << text << "\" does not contain \"" << part << "\"";
  return ::testing::AssertionSuccess();
}

std::vector<std::string> lines(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> out;
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

}  // namespace lensfarm::test
