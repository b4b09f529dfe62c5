#pragma once
// Helpers shared by the tests: temporary directories, small scene files, running the CLI.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/film/image.h"
#include "common/render/integrator.h"
#include "common/scene/scene.h"

namespace lensfarm::test {

// Sets the environment variable `name` to `value` (null: unsets it) for the guard's lifetime,
// then restores what was there.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value)
      ::setenv(name, value, 1);
    else
      ::unsetenv(name);
  }
  ~ScopedEnv() {
    if (old_)
      ::setenv(name_.c_str(), old_->c_str(), 1);
    else
      ::unsetenv(name_.c_str());
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  std::string name_;
  std::optional<std::string> old_;
};

// A fresh directory under the system temp dir, removed with everything in it on destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }
  // Writes `text` to `name` inside the directory and returns its path.
  std::filesystem::path write(const std::string& name, const std::string& text) const;

 private:
  std::filesystem::path path_;
};

std::filesystem::path sourceDir();  // the repository root
std::filesystem::path scenesDir();  // <root>/scenes
std::filesystem::path cliPath();    // the built `lensfarm` binary

// A minimal valid scene: a pinhole camera looking along +z at a white quad lit by a quad light.
nlohmann::json minimalSceneJson();
// The minimal scene with `camera`'s fields merged into its camera (a null removes that field).
nlohmann::json minimalSceneWithCamera(const nlohmann::json& camera);

// A scene from scenes/ (e.g. "cornell-seed.json") with its shapes' file paths made absolute, so it loads
// from any directory.
nlohmann::json bundledSceneJson(const std::string& name);

// A UV sphere of radius 1 as an indexed OBJ (shared vertices, so every edge is shared exactly),
// its faces facing outwards.
std::string sphereObj(int rings, int segments);

// Axis-aligned closed box [-1,1]^3 seen from inside by a pinhole camera at the centre looking
// along +z. Every wall uses material "wall" (inward-facing). Used for furnace-type tests.
nlohmann::json closedBoxSceneJson(const nlohmann::json& wallMaterial, int resolution, uint64_t spp, int maxBounces);

// Every unit of a scene rendered and added in order (what the coordinator does, without it).
struct Rendered {
  double mean[3] = {0, 0, 0};  // over all pixels
  PathStats stats;
  Image image;
};
Rendered renderScene(const Scene& scene, int threads = 2);

// Per-pixel statistics over `renders` independent renders of a scene (seeds 1..renders), for
// judging images statistically instead of by eye.
struct ImageStatistics {
  int renders = 0;
  std::vector<double> mean;      // per pixel-channel
  std::vector<double> variance;  // of one render's value, per pixel-channel
  double imageMean = 0.0;        // over all pixel-channels and renders
  double imageMeanError = 0.0;   // standard error of imageMean (from the renders' own means)
};
ImageStatistics renderStatistics(Scene scene, int renders);

// The share of pixel-channels whose means agree within `z` standard errors (two-sample test);
// the project accepts two estimates of an image when this is at least 0.995. The default z suits
// 16 or more renders per side (Student's t with 15 degrees of freedom at 99.95 %); estimators
// with very heavy tails (the naive one with tiny lights) need image means instead.
double agreementFraction(const ImageStatistics& a, const ImageStatistics& b, double z = 4.5);

// The project's test that two estimates are of one image: per-pixel agreement of at least 0.995
// (agreementFraction) and image means within 4 standard errors of each other.
void expectSameImage(const ImageStatistics& a, const ImageStatistics& b);

// Writes `scene` into `dir` and loads it.
Scene loadSceneJson(const TempDir& dir, const nlohmann::json& scene, const std::string& name = "scene.json");

// Starts a command (argv[0] is the program) in the background with stdout and stderr redirected
// to files; returns the child's pid. The caller reaps it (waitpid).
int startProcess(const std::vector<std::string>& argv, const std::filesystem::path& outFile,
                 const std::filesystem::path& errFile);

// The whole content of a file ("" if it cannot be read).
std::string readFile(const std::filesystem::path& path);

// Runs a command (argv[0] is the program) with stdout and stderr captured; waits at most
// `timeoutSeconds` and kills it after that (the test then fails on the exit code).
struct ProcessResult {
  int exitCode = -1;  // -1 if killed by a signal or timed out
  std::string out, err;
  bool timedOut = false;
};
ProcessResult runProcess(const std::vector<std::string>& argv, double timeoutSeconds = 120.0);

// A child process that is killed (SIGKILL) and reaped when the object goes away, so a failing
// test never leaves servers behind. Its stdout and stderr go to files for post-mortems.
class ChildProcess {
 public:
  ChildProcess(const std::vector<std::string>& argv, const std::filesystem::path& logPrefix);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;
  int pid() const { return pid_; }
  void signal(int sig) const;
  // Waits for the process to exit; its exit code, or -1 (killed by a signal or timed out).
  int wait(double timeoutSeconds);
  bool running();
  std::string log() const;  // stderr so far

 private:
  int pid_ = -1;
  bool reaped_ = false;
  int status_ = 0;
  std::filesystem::path err_;
};

// A loopback TCP port nothing listens on now (bound to port 0, read back, closed).
int freePort();

std::filesystem::path coordinatorPath();  // the built lensfarm-coordinator
std::filesystem::path workerPath();       // the built lensfarm-worker

// Waits until `condition` holds or `timeoutSeconds` pass; returns whether it held.
bool waitFor(const std::function<bool()>& condition, double timeoutSeconds);

// ---- exit codes the docs promise (docs/cli.md), written here, not read from client/exit_codes.h ----
inline constexpr int kBadInput = 2;
inline constexpr int kInterrupted = 130;

// ---- text of a process's output ----

// Succeeds when `text` contains `part`; the failure shows both.
::testing::AssertionResult contains(const std::string& text, const std::string& part);
// The lines of `text`, without their newlines.
std::vector<std::string> lines(const std::string& text);

}  // namespace lensfarm::test
