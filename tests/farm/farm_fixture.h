#pragma once
// A real coordinator and real worker processes on loopback (free ports), driven through the
// real `lensfarm` CLI: the fixture of the end-to-end farm tests.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <utility>
#include <vector>

#include "common/film/image_io.h"
#include "tests/test_support.h"

namespace lensfarm::test {

class FarmFixture : public ::testing::Test {
 protected:
  // cornell-seed (the 2013 report's scene), small, with its OBJ beside it in a temp dir (the client uploads it).
  std::filesystem::path writeScene(int size, uint64_t spp, uint32_t perUnit) {
    nlohmann::json scene = nlohmann::json::parse(std::ifstream(scenesDir() / "cornell-seed.json"));
    scene["render"]["resolution"] = {size, size};
    scene["render"]["samples_per_pixel"] = spp;
    scene["render"]["samples_per_unit"] = perUnit;
    dir_.write("meshes/cornell-box.obj", readFile(scenesDir() / "meshes/cornell-box.obj"));
    return dir_.write("scene.json", scene.dump(2));
  }

  std::string startCoordinator(const std::string& listen = "127.0.0.1:0", std::vector<std::string> extra = {}) {
    const std::filesystem::path portFile = dir_ / ("port-" + std::to_string(++started_));
    std::vector<std::string> argv = {coordinatorPath(),      "--listen", listen, "--port-file", portFile.string(),
                                     "--heartbeat-interval", "0.2"};
    if (std::find(extra.begin(), extra.end(), "--lease-timeout") == extra.end())
      extra.insert(extra.end(), {"--lease-timeout", "5"});
    argv.insert(argv.end(), extra.begin(), extra.end());
    coordinator_ = std::make_unique<ChildProcess>(argv, dir_ / ("coordinator-" + std::to_string(started_)));
    EXPECT_TRUE(waitFor([&] { return std::filesystem::exists(portFile) || !coordinator_->running(); }, 30))
        << coordinator_->log();
    std::string address = readFile(portFile);
    address.erase(address.find_last_not_of("\n") + 1);
    if (address.empty()) throw std::runtime_error("the coordinator did not start: " + coordinator_->log());
    return address;
  }

  ChildProcess& startWorker(const std::string& address, const std::string& name) {
    workers_.push_back(std::make_unique<ChildProcess>(
        std::vector<std::string>{workerPath(), "--coordinator", address, "--threads", "1", "--name", name,
                                 "--cache-dir", (dir_ / ("cache-" + name)).string(), "--max-backoff", "0.3"},
        dir_ / ("worker-" + name)));
    return *workers_.back();
  }

  ProcessResult cli(std::vector<std::string> args) {
    args.insert(args.begin(), cliPath().string());
    return runProcess(args, 120);
  }

  std::string submit(const std::string& address, const std::filesystem::path& scene,
                     std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"submit", scene.string(), "--coordinator", address};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = cli(args);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    std::string id = r.out;
    id.erase(id.find_last_not_of("\n") + 1);
    EXPECT_TRUE(std::regex_match(id, std::regex("job-[0-9]+"))) << "stdout must be the job id alone: " << r.out;
    return id;
  }

  Image download(const std::string& address, const std::string& job, ImageMetadata* metadata) {
    const std::filesystem::path out = dir_ / (job + ".exr");
    const auto r = cli({"download", job, "-o", out.string(), "--coordinator", address});
    EXPECT_EQ(r.exitCode, 0) << r.err;
    return readExr(out, metadata);
  }

  // A coordinator and two workers (w1, w2) render `scene` to the end; returns its address and the
  // job's id.
  std::pair<std::string, std::string> renderOnTwoWorkers(const std::filesystem::path& scene) {
    const std::string address = startCoordinator();
    startWorker(address, "w1");
    startWorker(address, "w2");
    const std::string job = submit(address, scene);
    const auto watched = cli({"watch", job, "--coordinator", address});
    EXPECT_EQ(watched.exitCode, 0) << watched.err;
    return {address, job};
  }

  // The farm's promise: job `job`'s downloaded image is `lensfarm render`'s of `scene`, bit for
  // bit. Returns the farm's image.
  Image expectFarmImageIsTheLocalRender(const std::string& address, const std::string& job,
                                        const std::filesystem::path& scene, const std::string& why) {
    ImageMetadata farmMeta, localMeta;
    const Image farm = download(address, job, &farmMeta);
    const Image local = renderInProcess(scene, &localMeta);
    EXPECT_EQ(farm.rgb.size(), local.rgb.size());
    EXPECT_TRUE(farm.rgb == local.rgb) << why;
    return farm;
  }

  Image renderInProcess(const std::filesystem::path& scene, ImageMetadata* metadata) {
    const std::filesystem::path out = dir_ / "in-process.exr";
    const auto r = cli({"render", scene.string(), "-o", out.string(), "--threads", "2", "-q"});
    EXPECT_EQ(r.exitCode, 0) << r.err;
    return readExr(out, metadata);
  }

  uint64_t unitsDone(const std::string& address, const std::string& job) {
    const auto r = cli({"status", job, "--coordinator", address});
    std::smatch m;
    if (!std::regex_search(r.out, m, std::regex(R"(\(([0-9]+)( / [0-9]+)? units)"))) return 0;
    return std::stoull(m[1]);
  }

  TempDir dir_;
  std::unique_ptr<ChildProcess> coordinator_;
  std::vector<std::unique_ptr<ChildProcess>> workers_;
  int started_ = 0;
};

}  // namespace lensfarm::test
