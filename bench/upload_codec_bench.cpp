// Upload compression (docs/performance.md, "Upload compression"): how small farm/sums_codec.h
// makes a unit's sums, and how fast it encodes and decodes them, on real unit buffers.
//
// Renders one whole-frame unit of a scene (default cornell-seed at 400x400) for each
// --spp (few samples: noisy sums; many: smoother), then, per zstd --level, splits the unit's sums
// into blocks of kSumsBlockDoubles as the worker does and reports:
//   ratio      raw bytes / encoded bytes (higher is better);
//   encode     raw MB (1e6 bytes of doubles) encoded per second, one thread;
//   decode     raw MB decoded per second, one thread (what the coordinator spends per upload).
// Each speed is the median of --repeat passes over the whole buffer. Beside the codec it measures,
// for the record, the same zstd level without the shuffle and with an XOR of each double with the
// previous double of its channel before the shuffle (the alternatives docs/performance.md weighs).
//
//   build/bench/lensfarm-upload-codec-bench [--scene scenes/cornell-seed.json] [--size 400]
//                                           [--spp 1 --spp 16 --spp 128] [--level 1 --level 3] [--repeat 9]
#include <tbb/task_arena.h>
#include <zstd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "common/farm/sums_codec.h"
#include "common/render/render_scene.h"
#include "common/render/unit_renderer.h"
#include "common/scene/scene_loader.h"

namespace lensfarm {
namespace {

using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Bytes after encoding `sums` block by block with `encode`, and the median seconds of one pass.
template <typename Encode>
std::pair<size_t, double> measure(const std::vector<double>& sums, int repeat, Encode encode) {
  size_t bytes = 0;
  std::vector<double> seconds;
  for (int r = 0; r < repeat; ++r) {
    const auto start = Clock::now();
    bytes = 0;
    for (size_t offset = 0; offset < sums.size(); offset += kSumsBlockDoubles)
      bytes += encode(sums.data() + offset, std::min(kSumsBlockDoubles, sums.size() - offset));
    seconds.push_back(std::chrono::duration<double>(Clock::now() - start).count());
  }
  return {bytes, median(seconds)};
}

int run(int argc, char** argv) {
  CLI::App app{"Compression ratio and speed of unit uploads (farm/sums_codec.h)"};
  std::string scenePath = LENSFARM_SOURCE_DIR "/scenes/cornell-seed.json";
  int size = 400, repeat = 9;
  std::vector<uint32_t> spps = {1, 16, 128};
  std::vector<int> levels = {1, 3};
  app.add_option("--scene", scenePath);
  app.add_option("--size", size, "resolution (square)");
  app.add_option("--spp", spps, "samples of the unit");
  app.add_option("--level", levels, "zstd levels");
  app.add_option("--repeat", repeat);
  CLI11_PARSE(app, argc, argv);

  std::printf("%-6s %5s | %-22s %7s %10s %10s\n", "spp", "level", "variant", "ratio", "enc MB/s", "dec MB/s");
  for (uint32_t spp : spps) {
    Scene scene = loadScene(scenePath);
    scene.render.width = scene.render.height = size;
    const RenderScene rs(scene);
    SensorBuffer buffer;
    PathStats stats;
    tbb::task_arena(2).execute([&] { renderUnit(rs, WorkUnit{0, 0, spp}, buffer, stats); });
    const std::vector<double>& sums = buffer.sums;
    const double mb = double(sums.size() * sizeof(double)) / 1e6;

    for (int level : levels) {
      const auto row = [&](const char* variant, std::pair<size_t, double> enc, double decodeSeconds) {
        std::printf("%-6u %5d | %-22s %7.3f %10.0f %10s\n", spp, level, variant,
                    double(sums.size() * sizeof(double)) / double(enc.first), mb / enc.second,
                    decodeSeconds > 0 ? std::to_string(int(mb / decodeSeconds)).c_str() : "-");
      };
      // The codec, and its decoder (checked to give the bits back).
      std::vector<std::string> blocks;
      const auto codec =
          measure(sums, repeat, [&](const double* v, size_t n) { return encodeSumsBlock(v, n, level).size(); });
      for (size_t offset = 0; offset < sums.size(); offset += kSumsBlockDoubles)
        blocks.push_back(
            encodeSumsBlock(sums.data() + offset, std::min(kSumsBlockDoubles, sums.size() - offset), level));
      std::vector<double> back(sums.size());
      std::vector<double> decodeSeconds;
      for (int r = 0; r < repeat; ++r) {
        const auto start = Clock::now();
        size_t at = 0;
        for (const std::string& b : blocks) at += decodeSumsBlock(b, back.data() + at, back.size() - at, "bench");
        decodeSeconds.push_back(std::chrono::duration<double>(Clock::now() - start).count());
      }
      if (std::memcmp(back.data(), sums.data(), sums.size() * sizeof(double)) != 0) {
        std::fprintf(stderr, "decoding did not give the bits back\n");
        return 1;
      }
      row("shuffle+zstd (codec)", codec, median(decodeSeconds));

      // zstd alone on the doubles' bytes, no shuffle.
      std::string out;
      row("zstd, no shuffle",
          measure(sums, repeat,
                  [&](const double* v, size_t n) {
                    out.resize(ZSTD_compressBound(n * sizeof(double)));
                    return ZSTD_compress(out.data(), out.size(), v, n * sizeof(double), level);
                  }),
          0.0);

      // XOR with the previous double of the same channel (3 back), then the codec.
      std::vector<uint64_t> delta;
      row("xor-delta+shuffle+zstd",
          measure(sums, repeat,
                  [&](const double* v, size_t n) {
                    delta.resize(n);
                    std::memcpy(delta.data(), v, n * sizeof(double));
                    for (size_t i = n; i-- > 3;) delta[i] ^= delta[i - 3];
                    return encodeSumsBlock(reinterpret_cast<const double*>(delta.data()), n, level).size();
                  }),
          0.0);
    }
  }
  return 0;
}

}  // namespace
}  // namespace lensfarm

int main(int argc, char** argv) { return lensfarm::run(argc, argv); }
