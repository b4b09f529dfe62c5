// Tiles and frames (farm/job_layout.h, coordinator/core/tile_film.h, docs/farm.md "Tiles and passes"):
// a tiled job gives the same bits as the same job in passes, whatever order tiles arrive in;
// an animation's frames survive a restart; bad layouts are refused with one clear error.
#include <gtest/gtest.h>

#include <fstream>
#include <functional>

#include <tbb/task_arena.h>
#include <algorithm>
#include <cstring>
#include <filesystem>

#include "common/farm/job_layout.h"
#include "common/farm/memory_estimate.h"
#include "common/film/sensor.h"
#include "common/render/render_scene.h"
#include "common/render/unit_renderer.h"
#include "common/scene/render_overrides.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "coordinator/core/coordinator.h"
#include "tests/coordinator/coordinator_fixtures.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;
using test::workerInfo;
namespace fs = std::filesystem;

bool sameBits(const Image& a, const Image& b) {
  return a.width == b.width && a.height == b.height && a.rgb.size() == b.rgb.size() &&
         std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)) == 0;
}

// A lit quad seen by a pinhole: odd sizes, so that edge tiles are partial; 3 passes of 2 samples.
JobSpec cornell(int tileSize) {
  json scene = test::minimalSceneJson();
  scene["lights"][0]["visible_to_camera"] = true;
  scene["render"]["resolution"] = {37, 23};
  scene["render"]["samples_per_pixel"] = 6;
  scene["render"]["samples_per_unit"] = 2;
  scene["render"]["max_bounces"] = 2;
  JobSpec spec{"cornell.json", scene.dump(), {}, {}, std::nullopt};
  spec.overrides.tileSize = tileSize;
  return spec;
}

// Leases every unit first, then renders and uploads them in reverse order (the film must not
// depend on arrival order), like workers that finish out of order.
Image renderThrough(const JobSpec& spec, JobInfo* info = nullptr) {
  Coordinator c;
  const std::string job = c.submit(spec, 0).id;
  const std::string w = c.registerWorker(workerInfo("w"));
  Scene scene = parseScene(spec.sceneJson, spec.sceneName);
  applyOverrides(spec.overrides, scene.render, spec.sceneName);
  const RenderScene rs(scene);
  std::vector<LeaseGrant> grants;
  while (auto g = c.lease(w, 0)) grants.push_back(*g);
  std::reverse(grants.begin(), grants.end());
  tbb::task_arena arena(2);
  for (const LeaseGrant& g : grants) {
    UnitResult r = resultForLease(w, g);
    arena.execute([&] { EXPECT_TRUE(renderUnit(rs, g.unit, r.buffer, r.stats)); });
    EXPECT_TRUE(c.acceptResult(std::move(r)));
  }
  while (auto g = c.lease(w, 0)) {  // units an audit (or a pass that waited) still needs
    UnitResult r = resultForLease(w, *g);
    arena.execute([&] { EXPECT_TRUE(renderUnit(rs, g->unit, r.buffer, r.stats)); });
    c.acceptResult(std::move(r));
  }
  if (info) *info = c.job(job);
  EXPECT_EQ(c.job(job).state, JobState::kDone);
  return c.image(job).image;
}

TEST(TiledJob, SameBitsAsPassesWhateverTheTilesAndTheirOrder) {
  JobInfo passes, tiles8, whole;
  const Image reference = renderThrough(cornell(RenderSettings::kTilesOff), &passes);
  EXPECT_EQ(passes.tileSize, 0);
  EXPECT_EQ(passes.unitsTotal, 3u);  // three passes over the frame
  const Image tiled = renderThrough(cornell(8), &tiles8);
  EXPECT_EQ(tiles8.tileSize, 8);
  EXPECT_EQ(tiles8.unitsTotal, 5u * 3u);  // 37 x 23 in tiles of 8: 5 x 3, each with every sample
  EXPECT_EQ(tiles8.stats.paths, passes.stats.paths);
  EXPECT_EQ(tiles8.stats.rays, passes.stats.rays);
  EXPECT_TRUE(sameBits(reference, tiled));
  EXPECT_TRUE(sameBits(reference, renderThrough(cornell(1))));   // every cell its own tile
  EXPECT_TRUE(sameBits(reference, renderThrough(cornell(23))));  // taller than wide tiles cut at the edge
  const Image one = renderThrough(cornell(37), &whole);          // one tile: the whole frame at once
  EXPECT_EQ(whole.unitsTotal, 1u);
  EXPECT_TRUE(sameBits(reference, one));
  // And the image is not trivially equal: it has light in it.
  double sum = 0;
  for (float v : reference.rgb) sum += v;
  EXPECT_GT(sum, 0.0);
}

// The doubles themselves: a tile unit's sums, divided by its samples, are the means the sensor
// holding the same passes develops, in every cell (the float image could hide a last-bit
// difference; this would not). (A few floats of similar size sum exactly in double whatever the
// grouping, so this scene cannot tell a tile summed in one pass from one folded pass by pass.)
TEST(TiledJob, ATileSumsItsPassesAsTheSensorDoes) {
  const JobSpec spec = cornell(RenderSettings::kTilesOff);
  Scene scene = parseScene(spec.sceneJson, spec.sceneName);
  const RenderScene rs(scene);
  const int w = scene.render.width, h = scene.render.height;
  tbb::task_arena arena(2);
  Sensor sensor(w, h);
  for (uint64_t p = 0; p < 3; ++p) {
    SensorBuffer pass;
    PathStats stats;
    arena.execute([&] { ASSERT_TRUE(renderUnit(rs, unitAt(p, 6, 2), pass, stats)); });
    sensor.add(pass, 2);
  }
  WorkUnit tile(0, 0, 6);
  tile.passSamples = 2;
  tile.region = PixelRegion{5, 3, 17, 11};
  SensorBuffer out;
  PathStats stats;
  arena.execute([&] { ASSERT_TRUE(renderUnit(rs, tile, out, stats)); });
  ASSERT_EQ(out.width, 17);
  ASSERT_EQ(out.height, 11);
  int differing = 0;
  for (int j = 0; j < 11; ++j)
    for (int i = 0; i < 17; ++i) {
      const DVec3 mean = sensor.mean(5 + i, 3 + j);
      const size_t c = 3 * (size_t(j) * 17 + size_t(i));
      differing += out.sums[c] * (1.0 / 6.0) != mean.x || out.sums[c + 1] * (1.0 / 6.0) != mean.y ||
                   out.sums[c + 2] * (1.0 / 6.0) != mean.z;
    }
  EXPECT_EQ(differing, 0);
  EXPECT_EQ(out.samples[0], 6u);
}

TEST(TiledJob, LayoutCutsTheFrameIntoTilesWithEveryCellOnce) {
  RenderSettings s;
  s.width = 1000;
  s.height = 300;
  s.samplesPerPixel = 9;
  s.samplesPerUnit = 4;
  s.tileSize = 256;
  const JobLayout l = JobLayout::of(s, FrameRange{10, 20, 5});
  EXPECT_EQ(l.tilesX(), 4);
  EXPECT_EQ(l.tilesY(), 2);
  EXPECT_EQ(l.frameCount(), 3u);
  EXPECT_EQ(l.unitCount(), 24u);
  std::vector<int> covered(size_t(s.width) * s.height, 0);
  for (uint64_t u = 0; u < l.unitsPerFrame(); ++u) {
    const WorkUnit w = l.unit(u);
    EXPECT_EQ(w.sampleCount, 9u);
    EXPECT_EQ(w.passSamples, 4u);
    for (int y = w.region.y; y < w.region.y + w.region.height; ++y)
      for (int x = w.region.x; x < w.region.x + w.region.width; ++x) ++covered[size_t(y) * s.width + x];
  }
  EXPECT_TRUE(std::all_of(covered.begin(), covered.end(), [](int n) { return n == 1; }));
  EXPECT_EQ(l.unit(8).frame, 15);  // frame index 1 of 10, 15, 20
  EXPECT_EQ(l.unit(23).frame, 20);
  EXPECT_EQ(l.regionOf(7).width, 1000 - 3 * 256);
  EXPECT_EQ(l.regionOf(7).height, 300 - 256);
}

TEST(TiledJob, AutomaticLayoutFollowsFrameSizeAnimationAndWorkers) {
  RenderSettings s;
  s.width = 800;
  s.height = 800;
  s.samplesPerPixel = 64;
  EXPECT_EQ(resolveTileSize(s, std::nullopt, 8), RenderSettings::kTilesOff);  // a small still: passes
  s.width = 3840;
  s.height = 2160;
  EXPECT_EQ(resolveTileSize(s, std::nullopt, 8), kTileEdge);        // 4K: tiles
  EXPECT_EQ(resolveTileSize(s, std::nullopt, 1000), kMinTileEdge);  // many workers: smaller tiles
  s.targetError = 0.01;
  EXPECT_EQ(resolveTileSize(s, std::nullopt, 8), RenderSettings::kTilesOff);  // stops need passes
  s.targetError = 0;
  s.width = 1920;
  s.height = 1080;
  EXPECT_EQ(resolveTileSize(s, FrameRange{1, 240, 1}, 100), 1920);   // a big farm: whole frames
  const int small = resolveTileSize(s, FrameRange{1, 24, 1}, 1000);  // a small farm for its frames: tiles
  EXPECT_LT(small, kTileEdge);
  EXPECT_GE(small, kMinTileEdge);
  // A tiled 4K job's coordinator holds its frame's float image and nothing frame-sized besides,
  // but for a download while it is served; in passes it holds a sensor and a tracker.
  s.width = 3840;
  s.height = 2160;
  s.tileSize = kTileEdge;
  const uint64_t frame = uint64_t(s.width) * s.height * 3 * sizeof(float);
  const MemoryEstimate tiled = coordinatorJobMemory(s, uint64_t(2) << 30, true, 2);
  ASSERT_EQ(tiled.items.size(), 2u);
  EXPECT_EQ(tiled.items[0].bytes, frame);
  s.tileSize = RenderSettings::kTilesOff;
  EXPECT_GT(coordinatorJobMemory(s, uint64_t(2) << 30, true, 2).total(), 10 * frame);
}

// An animation of constant tiles: frame f's pixels are (unit + 1) / spp exactly.
JobSpec animation() {
  json scene = test::minimalSceneJson();
  scene["render"]["resolution"] = {5, 3};
  scene["render"]["samples_per_pixel"] = 4;
  JobSpec spec{"anim.json", scene.dump(), {}, {}, FrameRange{7, 11, 2}};
  spec.overrides.tileSize = 2;  // 3 x 2 tiles a frame, edge tiles 1 wide or high
  return spec;
}

UnitResult tileResult(const std::string& w, const LeaseGrant& g) {
  return test::resultFor(w, g, double(g.unit.index + 1) * 4.0, 0.0, g.unit.region.width, g.unit.region.height);
}

// A coordinator with `options` (a state dir) that renders the first `tiles` tiles of animation()
// as one worker, lets `inspect` look at it, and goes; returns the job's id.
std::string renderTilesThenStop(const Coordinator::Options& options, uint64_t tiles,
                                const std::function<void(Coordinator&, const std::string&)>& inspect = {}) {
  Coordinator first(options);
  const std::string job = first.submit(animation(), 0).id;
  const std::string w = first.registerWorker(workerInfo("w"));
  for (uint64_t k = 0; k < tiles; ++k) EXPECT_TRUE(first.acceptResult(tileResult(w, *first.lease(w, 0))));
  if (inspect) inspect(first, job);
  return job;
}

TEST(TiledJob, AnimationFramesSurviveARestartBitForBit) {
  test::TempDir dir;
  Coordinator::Options options;
  options.stateDir = dir / "state";
  options.auditFraction = 0;
  // Frame 7 whole and half of frame 9, then the coordinator goes.
  const std::string job = renderTilesThenStop(options, 9, [&](Coordinator& first, const std::string& id) {
    const JobInfo info = first.job(id);
    ASSERT_EQ(info.frames.size(), 3u);
    EXPECT_TRUE(info.frames[0].complete());
    EXPECT_EQ(info.frames[1].tilesDone, 3u);
    EXPECT_TRUE(fs::exists(dir / "state" / "jobs" / id / "frame-0.exr"));
    EXPECT_FALSE(fs::exists(dir / "state" / "jobs" / id / "unit-0.bin"));  // stored: its tiles' sums dropped
  });
  Coordinator second(options);
  EXPECT_EQ(second.job(job).unitsDone, 9u);
  const std::string w = second.registerWorker(workerInfo("w2"));
  while (auto g = second.lease(w, 0)) ASSERT_TRUE(second.acceptResult(tileResult(w, *g)));
  const JobInfo info = second.job(job);
  EXPECT_EQ(info.state, JobState::kDone);
  for (int64_t frame : {7, 9, 11}) {
    const Image image = second.image(job, frame).image;
    const uint64_t f = uint64_t(frame - 7) / 2;
    // Image pixel (x, y) is cell (4 - x, 2 - y); the cell's tile is (cx / 2, cy / 2) of 3 x 2.
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 5; ++x) {
        const int cx = 4 - x, cy = 2 - y;
        const uint64_t unit = f * 6 + uint64_t(cy / 2) * 3 + uint64_t(cx / 2);
        ASSERT_EQ(image.rgb[3 * (size_t(y) * 5 + x)], float(double(unit + 1) * 4.0 * (1.0 / 4.0)))
            << "frame " << frame << " pixel " << x << "," << y;
      }
  }
  EXPECT_THROW(second.image(job, 8), FarmError);  // not a frame of 7-11x2
  EXPECT_THROW(second.image(job, 13), FarmError);
}

// A stored frame's file is checked against the SHA-256 kept beside it: bytes flipped by a bad disk
// make the restarted coordinator keep the file aside, say so, and render the frame's tiles again
// (their sums went when it was stored), so every frame comes out exact.
TEST(TiledJob, ADamagedFrameFileIsKeptAsideAndItsTilesRenderedAgain) {
  test::TempDir dir;
  Coordinator::Options options;
  options.stateDir = dir / "state";
  options.auditFraction = 0;
  const std::string job = renderTilesThenStop(options, 6);  // frame 7 whole
  const fs::path frame = dir / "state" / "jobs" / job / "frame-0.exr";
  ASSERT_TRUE(fs::exists(frame));
  ASSERT_TRUE(fs::exists(frame.string() + ".sha256"));
  {
    std::fstream f(frame, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(std::streamoff(fs::file_size(frame) - 40));
    f.write("\x5a\x5a\x5a\x5a", 4);  // in the pixels: the EXR still opens
  }
  Coordinator second(options);
  std::string events;
  for (const auto& e : second.job(job).events) events += e.text + "\n";
  EXPECT_NE(events.find("frame file frame-0.exr was checksum mismatch"), std::string::npos) << events;
  EXPECT_TRUE(fs::exists(dir / "state" / "lost+found" / (job + "-frame-0.exr"))) << "kept, not deleted";
  EXPECT_EQ(second.job(job).unitsDone, 0u) << "frame 7's tiles count no more";
  const std::string w = second.registerWorker(workerInfo("w2"));
  std::vector<uint64_t> leased;
  while (auto g = second.lease(w, 0)) {
    leased.push_back(g->unit.index);
    ASSERT_TRUE(second.acceptResult(tileResult(w, *g)));
  }
  EXPECT_EQ(leased.size(), 18u);
  EXPECT_EQ(second.job(job).state, JobState::kDone);
  const Image image = second.image(job, 7).image;
  EXPECT_EQ(image.rgb[0], float(double(6) * 4.0 * (1.0 / 4.0))) << "pixel (0, 0) is cell (4, 2): tile 5";
}

TEST(TiledJob, RefusesUploadsOfTheWrongRegion) {
  Coordinator c;
  const std::string job = c.submit(animation(), 0).id;
  const std::string w = c.registerWorker(workerInfo("w"));
  const LeaseGrant g = *c.lease(w, 0);
  EXPECT_EQ(g.unit.region.width, 2);
  try {
    c.acceptResult(test::resultFor(w, g, 1.0, 0.0, 5, 3));  // the whole frame, not its tile
    FAIL() << "accepted a frame-sized upload for a tile";
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("the unit covers 2x2 cells at (0, 0)"), std::string::npos) << e.what();
  }
  EXPECT_THROW(c.admitUpload(w, g.leaseId, job, g.unit.index, 5, 3), FarmError);
  EXPECT_TRUE(c.acceptResult(tileResult(w, g)));
}

TEST(TiledJob, BadLayoutsGetOneClearError) {
  const auto message = [](const std::function<void()>& f) {
    try {
      f();
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  Coordinator c;
  JobSpec spec = animation();
  spec.frames = FrameRange{10, 1, 1};
  EXPECT_NE(message([&] { c.submit(spec, 0); }).find("frames: the last frame 1 is before the first 10"),
            std::string::npos);
  spec.frames = FrameRange{1, 10, 0};
  EXPECT_NE(message([&] { c.submit(spec, 0); }).find("frames.step: must be at least 1"), std::string::npos);
  spec = animation();
  spec.overrides.tileSize = 6;  // the frame is 5 x 3
  EXPECT_NE(message([&] { c.submit(spec, 0); }).find("tile_size: 6 is larger than the 5x3 frame"), std::string::npos);
  spec = animation();
  spec.overrides.tileSize.reset();
  spec.overrides.targetError = 0.05;
  EXPECT_NE(message([&] { c.submit(spec, 0); }).find("an animation renders every frame"), std::string::npos);
  RenderOverrides o;
  EXPECT_NE(message([&] { parseTileSize("0", o); }).find("--tile-size"), std::string::npos);
  EXPECT_NO_THROW(parseTileSize("auto", o));
  json scene = test::minimalSceneJson();
  scene["render"]["tile_size"] = 0;
  EXPECT_NE(message([&] { parseScene(scene.dump(), "zero.json"); }).find("render.tile_size"), std::string::npos);
  EXPECT_EQ(c.jobs().size(), 0u);  // nothing was queued
}

}  // namespace
}  // namespace lensfarm

namespace lensfarm {
namespace {

// The audit in a tiled job (docs/farm.md "Audit"): a worker whose tiles are wrong is found and
// quarantined, its tiles are rendered again by the others and overwritten, and the image is the
// honest one, bit for bit.
TEST(TiledJob, AWrongWorkersTilesAreRenderedAgainAndTheImageIsTheHonestOne) {
  Coordinator::Options options;
  options.auditFraction = 1.0;  // every tile is rendered twice
  Coordinator c(options);
  JobSpec spec = animation();
  spec.frames.reset();  // a still of 3 x 2 tiles
  const std::string job = c.submit(spec, 0).id;
  const std::vector<std::string> workers = {c.registerWorker(workerInfo("a")), c.registerWorker(workerInfo("wrong")),
                                            c.registerWorker(workerInfo("b"))};
  for (int round = 0; round < 200 && c.job(job).state != JobState::kDone; ++round)
    for (const std::string& w : workers)
      if (auto g = c.lease(w, 0)) {
        UnitResult r = tileResult(w, *g);
        if (w == workers[1])
          for (double& v : r.buffer.sums) v += 1.0;  // plausible, but wrong
        try {
          c.acceptResult(std::move(r));
        } catch (const FarmError& e) {
          ADD_FAILURE() << e.what();
        }
      }
  const JobInfo done = c.job(job);
  ASSERT_EQ(done.state, JobState::kDone) << done.unitsDone << " units, " << done.auditsPending << " audits pending, "
                                         << done.stalledReason;
  bool quarantined = false;
  for (const WorkerView& v : c.workers()) quarantined |= v.id == workers[1] && v.quarantined;
  EXPECT_TRUE(quarantined);
  const Image image = c.image(job).image;
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x) {
      const int cx = 4 - x, cy = 2 - y;
      const uint64_t unit = uint64_t(cy / 2) * 3 + uint64_t(cx / 2);
      ASSERT_EQ(image.rgb[3 * (size_t(y) * 5 + x)], float(double(unit + 1) * 4.0 * (1.0 / 4.0))) << x << "," << y;
    }
}

}  // namespace
}  // namespace lensfarm
