// The ray-casting limit: how close the integrator comes to what Embree alone allows
// for the very rays it casts, cast the same way, on the same scene and threads.
//
//   (a) the integrator traces units (1 spp over the frame) on all threads: paths/s, rays/s;
//   (b) the same units are traced once more with a RayRecorder on the caster, keeping every
//       call per thread in the order that thread made it; each thread's log is then replayed
//       through the same RayCaster calls (16-wide packets, as the integrator casts them, with
//       the same active lanes): Embree's rays/s for those rays, and again one kind at a time.
// It prints (a)/(b), the share of render time spent inside Embree, and medians of --repeat runs.
//
// Scaling with scene size: --triangles N adds a generated mesh of about N triangles (a bumpy
// sphere on the floor of the box, made here, nothing downloaded) and reports the Embree build
// time and the resident memory the scene added; compare paths/s and Embree's rays/s across N.
//
//   build/bench/lensfarm-ray-limit [--scene cornell-classic.json] [--resolution 512] [--bounces 3]
//                                  [--integrator nee_mis] [--repeat 5] [--threads N]
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for_each.h>
#include <tbb/task_arena.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <thread>

#include "common/render/render_scene.h"
#include "common/render/unit_renderer.h"
#include "common/scene/scene_loader.h"

namespace lensfarm {
namespace {

using Clock = std::chrono::steady_clock;

// One thread's calls to the caster, in order: single rays and packets (kind 0: occlusion), each
// kept in its own list so a single ray does not take a packet's room.
struct ThreadLog {
  struct Cast {
    bool packet;
    uint32_t index;  // into rays or packets
  };
  std::vector<Cast> order;
  std::vector<RayRecorder::Ray> rays;
  std::vector<RayPacket> packets;
  std::vector<unsigned> packetKinds;
};

class ThreadLogs : public RayRecorder {
 public:
  void record(const Ray& ray) override {
    ThreadLog& log = logs_.local();
    log.order.push_back({false, uint32_t(log.rays.size())});
    log.rays.push_back(ray);
  }
  void recordPacket(const RayPacket& rays, unsigned kind) override {
    ThreadLog& log = logs_.local();
    log.order.push_back({true, uint32_t(log.packets.size())});
    log.packets.push_back(rays);
    log.packetKinds.push_back(kind);
  }
  tbb::enumerable_thread_specific<ThreadLog>& logs() { return logs_; }

 private:
  tbb::enumerable_thread_specific<ThreadLog> logs_;
};

int activeLanes(const RayPacket& rays) {
  int n = 0;
  for (int k = 0; k < kPacketWidth; ++k) n += rays.active(k);
  return n;
}

// A UV sphere of about `triangles` triangles with a radial ripple (so neighbouring triangles are not
// coplanar), resting on the floor of the Cornell box, in the scene's white material.
TriangleMesh bumpySphere(uint64_t triangles, uint32_t material) {
  const int rings = std::max(3, int(std::sqrt(double(triangles) / 2.0)));
  const int segments = std::max(3, int(double(triangles) / (2.0 * rings)));
  TriangleMesh mesh;
  mesh.name = "generated";
  const Vec3 centre(0.3f, -0.7f, -0.3f);
  for (int i = 0; i <= rings; ++i)
    for (int j = 0; j <= segments; ++j) {
      const double theta = std::numbers::pi * i / rings, phi = 2.0 * std::numbers::pi * j / segments;
      const double r = 0.28 * (1.0 + 0.04 * std::sin(9.0 * theta) * std::cos(7.0 * phi));
      mesh.positions.push_back(centre + Vec3(float(r * std::sin(theta) * std::cos(phi)), float(r * std::cos(theta)),
                                             float(r * std::sin(theta) * std::sin(phi))));
    }
  auto at = [&](int i, int j) { return uint32_t(i * (segments + 1) + j); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      for (uint32_t v : {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i, j + 1)})
        mesh.indices.push_back(v);
      mesh.materialIds.push_back(material);
      mesh.materialIds.push_back(material);
    }
  return mesh;
}

double residentMegabytes() {
  std::ifstream statm("/proc/self/statm");
  double size = 0, resident = 0;
  statm >> size >> resident;
  return resident * 4096.0 / 1e6;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

struct Replay {
  double seconds = 0, intersectSeconds = 0, occludedSeconds = 0;
  uint64_t intersects = 0, occlusions = 0;
};

// Each thread's log on one task, in its order: `which` selects all rays (as cast), or only the
// intersection or only the occlusion rays (for the per-kind rates). One clock read per log, so the
// timing costs nothing per ray.
enum class Which { kAll, kIntersect, kOccluded };

Replay replay(const RayCaster& caster, ThreadLogs& logs, tbb::task_arena& arena, Which which) {
  std::vector<ThreadLog*> all;
  for (auto& log : logs.logs()) all.push_back(&log);
  tbb::enumerable_thread_specific<Replay> parts;
  const auto start = Clock::now();
  arena.execute([&] {
    tbb::parallel_for_each(all.begin(), all.end(), [&](ThreadLog* log) {
      Replay& r = parts.local();
      size_t hits = 0;
      RayCaster::PacketHits packetHits;
      bool blocked[kPacketWidth];
      const auto t0 = Clock::now();
      for (const ThreadLog::Cast& cast : log->order) {
        const unsigned kind = cast.packet ? log->packetKinds[cast.index] : log->rays[cast.index].kind;
        const bool occlusion = kind == 0;
        if (occlusion && which != Which::kIntersect) {
          if (cast.packet) {
            const RayPacket& rays = log->packets[cast.index];
            caster.occluded(rays, blocked);
            hits += blocked[0];
            r.occlusions += uint64_t(activeLanes(rays));
          } else {
            const RayRecorder::Ray& ray = log->rays[cast.index];
            hits += caster.occluded(ray.origin, ray.direction, ray.tFar);
            ++r.occlusions;
          }
        } else if (!occlusion && which != Which::kOccluded) {
          if (cast.packet) {
            const RayPacket& rays = log->packets[cast.index];
            caster.intersect(rays, RayKind(kind), packetHits);
            hits += packetHits.found[0];
            r.intersects += uint64_t(activeLanes(rays));
          } else {
            const RayRecorder::Ray& ray = log->rays[cast.index];
            hits += caster.intersect(ray.origin, ray.direction, RayKind(kind)).has_value();
            ++r.intersects;
          }
        }
      }
      const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
      (which == Which::kOccluded ? r.occludedSeconds : r.intersectSeconds) += dt;
      if (hits == size_t(-1)) std::puts("");  // keep the calls
    });
  });
  Replay total;
  total.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  for (const Replay& r : parts) {
    total.intersectSeconds += r.intersectSeconds;
    total.occludedSeconds += r.occludedSeconds;
    total.intersects += r.intersects;
    total.occlusions += r.occlusions;
  }
  return total;
}

int run(int argc, char** argv) {
  CLI::App app{"lensfarm ray-casting limit: integrator vs Embree alone on the same rays"};
  std::string sceneName = "cornell-classic.json", integrator = "nee_mis", sampler = "sobol", roulette = "scene";
  int resolution = 512, bounces = 3, repeat = 5;
  uint32_t unitSamples = 16;
  bool renderOnly = false, singleRays = false;
  unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  uint64_t generated = 0;
  app.add_option("--scene", sceneName, "Scene file (absolute, or in the source tree's scenes/)")->capture_default_str();
  app.add_option("--resolution", resolution)->capture_default_str();
  app.add_option("--bounces", bounces)->capture_default_str();
  app.add_option("--integrator", integrator)->check(CLI::IsMember({"nee_mis", "nee", "naive"}))->capture_default_str();
  app.add_option("--sampler", sampler)
      ->check(CLI::IsMember({"sobol", "stratified", "independent"}))
      ->capture_default_str();
  app.add_option("--roulette", roulette, "Russian roulette: the scene's, off, max or throughput")
      ->check(CLI::IsMember({"scene", "off", "max", "throughput"}))
      ->capture_default_str();
  app.add_option("--repeat", repeat, "Runs; medians are reported")->capture_default_str();
  app.add_option("--threads", threads)->capture_default_str();
  app.add_option("--unit-spp", unitSamples, "Samples per pixel in each timed unit")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  app.add_flag("--single-rays", singleRays, "Cast one ray at a time (the reference tracer) instead of 16-wide packets");
  app.add_flag("--render-only", renderOnly, "Only (a), once per run: for profilers (perf, callgrind)");
  app.add_option("--triangles", generated, "Add a generated mesh of about this many triangles (scaling)");
  CLI11_PARSE(app, argc, argv);

  const std::string path =
      sceneName.find('/') == std::string::npos ? std::string(LENSFARM_SOURCE_DIR "/scenes/") + sceneName : sceneName;
  Scene scene = loadScene(path);
  scene.render.width = scene.render.height = resolution;
  scene.render.maxBounces = bounces;
  parseIntegratorName(integrator, scene.render.integrator);
  parseSamplerName(sampler, scene.render.sampler);
  if (roulette != "scene") parseRouletteName(roulette, scene.render.roulette);
  if (generated > 0) {
    uint32_t white = 0;
    for (uint32_t m = 0; m < scene.materials.size(); ++m)
      if (scene.materials[m].name == "white") white = m;
    scene.meshes.push_back(bumpySphere(generated, white));
  }
  size_t triangles = 0;
  for (const auto& m : scene.meshes) triangles += m.triangleCount();
  const double memoryBefore = residentMegabytes();
  const auto buildStart = Clock::now();
  RenderScene rs(scene);
  const double buildSeconds = std::chrono::duration<double>(Clock::now() - buildStart).count();
  const double sceneMegabytes = residentMegabytes() - memoryBefore;
  tbb::task_arena arena{int(threads)};
  const RayGrouping grouping = singleRays ? RayGrouping::kSingleRays : RayGrouping::kPackets;
  const double pixels = double(resolution) * resolution * unitSamples;

  std::vector<double> raysPerPath, pathRate, rayRate, embreeRate, intersectRate, occludedRate, ratio;
  for (int r = 0; r < repeat; ++r) {
    // (a) the integrator, timed, no recorder.
    PathStats stats;
    SensorBuffer buffer;
    const WorkUnit unit{uint64_t(r), uint64_t(r) * unitSamples, unitSamples};
    const auto t0 = Clock::now();
    arena.execute([&] { renderUnit(rs, unit, buffer, stats, nullptr, grouping); });
    const double renderSeconds = std::chrono::duration<double>(Clock::now() - t0).count();
    pathRate.push_back(pixels / renderSeconds);
    rayRate.push_back(double(stats.rays) / renderSeconds);
    raysPerPath.push_back(double(stats.rays) / double(stats.paths));
    if (renderOnly) continue;
    // (b) the same unit recorded, then replayed.
    ThreadLogs logs;
    rs.caster().setRecorder(&logs);
    PathStats recorded;
    arena.execute([&] { renderUnit(rs, unit, buffer, recorded, nullptr, grouping); });
    rs.caster().setRecorder(nullptr);
    const Replay rep = replay(rs.caster(), logs, arena, Which::kAll);
    const Replay intersects = replay(rs.caster(), logs, arena, Which::kIntersect);
    const Replay occlusions = replay(rs.caster(), logs, arena, Which::kOccluded);
    const double rays = double(rep.intersects + rep.occlusions);
    embreeRate.push_back(rays / rep.seconds);
    intersectRate.push_back(double(intersects.intersects) / intersects.seconds);
    occludedRate.push_back(occlusions.occlusions ? double(occlusions.occlusions) / occlusions.seconds : 0.0);
    ratio.push_back(rep.seconds / renderSeconds);
  }
  std::printf(
      "scene %s, %zu triangles, %dx%d, B = %d, %s, %s sampler, roulette %s, units of %u spp, %u threads, medians of "
      "%d runs\n",
      sceneName.c_str(), triangles, resolution, resolution, bounces, integrator.c_str(), sampler.c_str(),
      rouletteName(scene.render.roulette), unitSamples, threads, repeat);
  std::printf("scene build:           %.3f s, %.1f MB resident added (Embree BVH, triangles, lights)\n", buildSeconds,
              sceneMegabytes);
  std::printf("(a) integrator:        %.3f M pixel-samples/s, %.2f M rays/s\n", median(pathRate) / 1e6,
              median(rayRate) / 1e6);
  if (renderOnly) return 0;
  std::printf("(b) Embree alone:      %.2f M rays/s on the same rays, %s as the integrator casts them\n",
              median(embreeRate) / 1e6, singleRays ? "single rays" : "16-wide packets");
  std::printf("    ceiling:           %.3f M pixel-samples/s if nothing but Embree took time (%.2f rays per path)\n",
              median(embreeRate) / median(raysPerPath) / 1e6, median(raysPerPath));
  std::printf("    by kind:           %.2f M rays/s intersect (camera + scattered), %.2f M rays/s occluded (shadow)\n",
              median(intersectRate) / 1e6, median(occludedRate) / 1e6);
  std::printf("(a)/(b):               %.3f  (1 = the integrator costs nothing beyond its rays)\n", median(ratio));
  std::printf("time inside Embree:    %.1f %% of render time (the same ratio, read as time)\n", 100.0 * median(ratio));
  return 0;
}

}  // namespace
}  // namespace lensfarm

int main(int argc, char** argv) { return lensfarm::run(argc, argv); }
