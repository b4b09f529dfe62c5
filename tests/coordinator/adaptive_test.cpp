// Adaptive sampling on the coordinator (farm/job_layout.h, film/adaptive_allocation.h, docs/
// accuracy.md "Adaptive sampling"): rounds are leased only once the film before them is summed,
// carry their block maps, and the image is the same bits whatever order units arrive in and
// across a restart in the middle of a round. Real renders (renderUnit), no network.
#include <gtest/gtest.h>

#include <tbb/task_arena.h>
#include <algorithm>
#include <cstring>
#include <filesystem>

#include "common/farm/job_layout.h"
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

// A lit quad half in the light's glare: 37 x 23 cells (partial edge blocks of 16), 64 spp in
// passes of 4: 4 uniform passes, then rounds of 2, 4 and 6 units.
json adaptiveScene() {
  json scene = test::minimalSceneJson();
  scene["lights"][0]["visible_to_camera"] = true;
  scene["render"]["resolution"] = {37, 23};
  scene["render"]["samples_per_pixel"] = 64;
  scene["render"]["adaptive"] = true;
  return scene;
}

JobSpec spec() { return JobSpec{"adaptive.json", adaptiveScene().dump(), {}, {}, std::nullopt}; }

struct Renderer {
  Scene scene = parseScene(adaptiveScene().dump(), "adaptive.json");
  RenderScene rs{scene};
  tbb::task_arena arena{2};
  UnitResult render(const std::string& w, const LeaseGrant& g) {
    UnitResult r = resultForLease(w, g);
    arena.execute([&] { EXPECT_TRUE(renderUnit(rs, g.unit, r.buffer, r.stats)); });
    return r;
  }
};

bool sameBits(const Image& a, const Image& b) {
  return a.rgb.size() == b.rgb.size() && std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)) == 0;
}

// Leases everything it can, renders and uploads it (reversed if asked), until the job is done.
// (One worker: with two, audits would wait for the other.)
Image renderThrough(Coordinator& c, const std::string& job, bool reverse, std::string w = "") {
  Renderer r;
  if (w.empty()) w = c.registerWorker(workerInfo("w"));
  for (;;) {
    std::vector<LeaseGrant> grants;
    while (auto g = c.lease(w, 0)) grants.push_back(*g);
    if (grants.empty()) break;
    if (reverse) std::reverse(grants.begin(), grants.end());
    for (const LeaseGrant& g : grants) EXPECT_TRUE(c.acceptResult(r.render(w, g)));
  }
  EXPECT_EQ(c.job(job).state, JobState::kDone) << c.job(job).unitsDone << " units done";
  return c.image(job).image;
}

TEST(AdaptiveJob, TheLayoutIsUniformPassesThenRoundsOfPairs) {
  Scene scene = parseScene(adaptiveScene().dump(), "adaptive.json");
  const JobLayout l = JobLayout::of(scene.render, std::nullopt);
  EXPECT_EQ(l.passSamples, 4u);
  EXPECT_EQ(l.unitCount(), 16u);
  EXPECT_EQ(l.adaptiveStart, 4u);
  EXPECT_EQ(l.roundStarts, (std::vector<uint64_t>{4, 6, 10}));
  EXPECT_EQ(l.blockEdge, 16);
  EXPECT_EQ(l.roundOf(3), -1);
  EXPECT_EQ(l.roundOf(7), 1);
  EXPECT_EQ(l.roundEnd(2), 16u);
  scene.render.adaptive.enabled = false;
  EXPECT_FALSE(JobLayout::of(scene.render, std::nullopt).adaptive());
}

TEST(AdaptiveJob, ARoundIsLeasedOnlyOnceTheFilmBeforeItIsSummedAndCarriesItsMap) {
  Coordinator c;
  const std::string job = c.submit(spec(), 0).id;
  const std::string w = c.registerWorker(workerInfo("w"));
  Renderer r;
  std::vector<LeaseGrant> uniform;
  while (auto g = c.lease(w, 0)) uniform.push_back(*g);
  ASSERT_EQ(uniform.size(), 4u) << "only the uniform passes before the first round is allocated";
  for (const LeaseGrant& g : uniform) EXPECT_EQ(g.unit.samples, nullptr);
  for (size_t k = 0; k < 3; ++k) ASSERT_TRUE(c.acceptResult(r.render(w, uniform[3 - k])));
  EXPECT_FALSE(c.lease(w, 0)) << "unit 0 is not in yet: the film before the round is not summed";
  ASSERT_TRUE(c.acceptResult(r.render(w, uniform[0])));
  std::vector<LeaseGrant> round;
  while (auto g = c.lease(w, 0)) round.push_back(*g);
  ASSERT_EQ(round.size(), 2u);
  uint64_t traced = 0;
  bool uneven = false;
  for (const LeaseGrant& g : round) {
    ASSERT_NE(g.unit.samples, nullptr);
    EXPECT_EQ(g.unit.samples->half, uint32_t(g.unit.index & 1));
    EXPECT_EQ(g.unit.samples->whyNotFor(37, 23), "");
    traced += g.unit.samples->totalSamples(37, 23);
    uneven |= g.unit.samples->maxCount() != g.unit.samples->count[0];
  }
  EXPECT_TRUE(uneven) << "the glare and the dark quad are not equally noisy: blocks get different counts";
  EXPECT_LE(traced, 2u * 4u * 37u * 23u) << "a round spends at most its budget";
  EXPECT_GT(traced, 2u * 4u * 37u * 23u - 2u * 256u);
  // A result must count the paths its map traces.
  UnitResult wrong = r.render(w, round[0]);
  wrong.stats.paths += 1;
  try {
    c.acceptResult(wrong);
    ADD_FAILURE() << "accepted a result with a path too many";
  } catch (const FarmError& e) {
    EXPECT_NE(std::string(e.what()).find("paths; the unit traces"), std::string::npos) << e.what();
  }
  for (const LeaseGrant& g : round) ASSERT_TRUE(c.acceptResult(r.render(w, g)));
  const JobInfo info = c.job(job);
  EXPECT_EQ(info.unitsDone, 6u);
  EXPECT_EQ(info.samplesPerPixelDone, 24u) << "the mean samples per pixel";
}

TEST(AdaptiveJob, TheImageIsTheSameBitsWhateverOrderUnitsArriveIn) {
  Coordinator inOrder, reversed;
  const Image a = renderThrough(inOrder, inOrder.submit(spec(), 0).id, false);
  const Image b = renderThrough(reversed, reversed.submit(spec(), 0).id, true);
  EXPECT_TRUE(sameBits(a, b));
  // And it is not the uniform image: the samples went elsewhere.
  JobSpec uniform = spec();
  json scene = adaptiveScene();
  scene["render"]["adaptive"] = false;
  uniform.sceneJson = scene.dump();
  Coordinator plain;
  const std::string job = plain.submit(uniform, 0).id;
  Renderer r;
  const std::string w = plain.registerWorker(workerInfo("w"));
  while (auto g = plain.lease(w, 0)) plain.acceptResult(r.render(w, *g));
  EXPECT_FALSE(sameBits(a, plain.image(job).image));
}

TEST(AdaptiveJob, ARestartInTheMiddleOfARoundGivesTheUninterruptedBits) {
  Coordinator reference;
  const Image expected = renderThrough(reference, reference.submit(spec(), 0).id, false);

  test::TempDir dir;
  Coordinator::Options options;
  options.stateDir = dir / "state";
  options.checkpointEverySeconds = 3600;  // only the explicit checkpoint below
  std::string job;
  SampleMap lostMap;
  {
    Coordinator first(options);
    job = first.submit(spec(), 0).id;
    const std::string w = first.registerWorker(workerInfo("a"));
    Renderer r;
    // The uniform passes and round 0; then 2 of round 1's 4 units, checkpointed in the middle
    // of the round (its allocation is in the checkpoint); then units 8 and 9 leased and only 9
    // acknowledged (the ledger's): 8 is leased again after the restart, with the same map.
    for (int k = 0; k < 8; ++k) {
      const auto g = first.lease(w, 0);
      ASSERT_TRUE(g) << "unit " << k;
      ASSERT_TRUE(first.acceptResult(r.render(w, *g)));
      if (k == 7) {
        EXPECT_GT(first.checkpoint(), 0u);
      }
    }
    const auto eight = first.lease(w, 0), nine = first.lease(w, 0);
    ASSERT_TRUE(eight && nine);
    ASSERT_EQ(nine->unit.index, 9u);
    ASSERT_TRUE(first.acceptResult(r.render(w, *nine)));
    lostMap = *eight->unit.samples;
  }
  Coordinator second(options);
  EXPECT_EQ(second.job(job).unitsDone, 8u) << "unit 9 waits for 8";
  const std::string b = second.registerWorker(workerInfo("b"));
  {
    const std::string& w = b;
    const auto again = second.lease(w, 0);
    ASSERT_TRUE(again);
    ASSERT_EQ(again->unit.index, 8u);
    ASSERT_NE(again->unit.samples, nullptr);
    EXPECT_EQ(again->unit.samples->first, lostMap.first);
    EXPECT_EQ(again->unit.samples->count, lostMap.count);
    Renderer r;
    ASSERT_TRUE(second.acceptResult(r.render(w, *again)));
  }
  const Image image = renderThrough(second, job, false, b);
  EXPECT_TRUE(sameBits(image, expected)) << "a restart must not change a single bit";
}

TEST(AdaptiveJob, AWrongWorkerIsCaughtAndTheRewoundRoundsGiveTheCleanBits) {
  // A worker whose sums go 50 % high (plausible, so only an audit sees it): the audit rewinds
  // the film to before its units, which may undo whole rounds; their allocations are made again
  // from the clean film, and the image is a single honest worker's, bit for bit.
  Coordinator::Options quiet;
  quiet.auditFraction = 0.0;
  Coordinator one(quiet);
  const Image clean = renderThrough(one, one.submit(spec(), 0).id, false);
  Renderer r;
  for (int rotation = 0; rotation < 4; ++rotation) {
    Coordinator::Options options;
    options.auditFraction = 1.0;  // every unit: its wrong units are certainly caught (the choice is random)
    Coordinator c(options);
    const std::string job = c.submit(spec(), 0).id;
    std::vector<std::string> workers;
    for (const char* name : {"a", "b", "c", "bad"}) workers.push_back(c.registerWorker(workerInfo(name)));
    const std::string bad = workers[3];
    std::rotate(workers.begin(), workers.begin() + rotation, workers.end());
    uint64_t badResults = 0;
    for (int turn = 0; turn < 2000 && !isTerminal(c.job(job).state); ++turn)
      for (const std::string& w : workers)
        if (auto g = c.lease(w, 0.0)) {
          UnitResult result = r.render(w, *g);
          if (w == bad && ++badResults > 2)  // it goes wrong after two good units (its first is audited)
            for (double& v : result.buffer.sums) v *= 1.5;
          c.acceptResult(std::move(result));
        }
    const JobInfo info = c.job(job);
    ASSERT_EQ(info.state, JobState::kDone) << info.error;
    EXPECT_GE(info.auditsFailed, 1u) << "rotation " << rotation;
    EXPECT_TRUE(sameBits(c.image(job).image, clean)) << "rotation " << rotation;
  }
}

TEST(AdaptiveJob, SettingsItCannotWorkWithAreRefusedNamingTheField) {
  const auto errorOf = [](const json& scene) {
    try {
      Scene s = parseScene(scene.dump(), "bad.json");
      validateRenderSettings(s.render, "bad.json");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  json tiles = adaptiveScene();
  tiles["render"]["tile_size"] = 8;
  EXPECT_NE(errorOf(tiles).find("tile_size \"off\" or \"auto\""), std::string::npos) << errorOf(tiles);
  json light = adaptiveScene();
  light["render"]["light_tracing"] = "on";
  EXPECT_NE(errorOf(light).find("light_tracing \"auto\" or \"off\""), std::string::npos) << errorOf(light);
  json word = adaptiveScene();
  word["render"]["adaptive"] = "yes";
  EXPECT_NE(errorOf(word).find("render.adaptive"), std::string::npos) << errorOf(word);
  json floor = adaptiveScene();
  floor["render"]["adaptive"] = {{"floor", 2}};
  EXPECT_NE(errorOf(floor).find("render.adaptive.floor"), std::string::npos) << errorOf(floor);
  json unknown = adaptiveScene();
  unknown["render"]["adaptive"] = {{"blocks", 8}};
  EXPECT_NE(errorOf(unknown).find("blocks"), std::string::npos) << errorOf(unknown);
}

TEST(AdaptiveUnit, AMapOfOnePassIsThatPassBitForBitAndABlockOfNoSamplesStaysEmpty) {
  Renderer r;
  tbb::task_arena& arena = r.arena;
  for (uint32_t half = 0; half < 2; ++half) {
    // Half h's first P positions are pass h's samples.
    SensorBuffer pass, mapped;
    PathStats s1, s2;
    arena.execute([&] { ASSERT_TRUE(renderUnit(r.rs, unitAt(half, 64, 4), pass, s1)); });
    WorkUnit unit(half, 0, 0);
    auto map = std::make_shared<SampleMap>();
    map->passSamples = 4;
    map->half = half;
    map->blockEdge = 16;
    map->blocksX = 3;
    map->blocksY = 2;
    map->first.assign(6, 0);
    map->count.assign(6, 4);
    map->count[4] = 0;  // block (1, 1): cells [16, 32) x [16, 23)
    unit.samples = map;
    arena.execute([&] { ASSERT_TRUE(renderUnit(r.rs, unit, mapped, s2)); });
    for (int j = 0; j < 23; ++j)
      for (int i = 0; i < 37; ++i) {  // (braced for the ASSERT below)
        const size_t c = size_t(j) * 37 + size_t(i);
        const bool empty = i >= 16 && i < 32 && j >= 16;
        EXPECT_EQ(mapped.samples[c], empty ? 0u : 4u);
        for (int k = 0; k < 3; ++k) {
          ASSERT_EQ(mapped.sums[3 * c + size_t(k)], empty ? 0.0 : pass.sums[3 * c + size_t(k)]) << i << "," << j;
        }
      }
    EXPECT_EQ(s2.paths, s1.paths - 16u * 7u * 4u);
  }
  // A map that does not fit the frame is refused before anything is traced.
  WorkUnit bad(0, 0, 0);
  auto map = std::make_shared<SampleMap>();
  map->blockEdge = 16;
  map->blocksX = 2;
  map->blocksY = 2;
  map->first.assign(4, 0);
  map->count.assign(4, 1);
  bad.samples = map;
  SensorBuffer out;
  PathStats stats;
  EXPECT_THROW(renderUnit(r.rs, bad, out, stats), std::invalid_argument);
}

}  // namespace
}  // namespace lensfarm
