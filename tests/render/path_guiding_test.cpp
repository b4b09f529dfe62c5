// Path guiding (render/path_guiding.h): the field's distributions are densities that sample
// what they say, learned in proportion to the radiance recorded; the guided estimator agrees
// with the path tracer within noise (through a mirror, through glass, far from the origin and at
// extreme scales), is the same bits for any thread count and unit split, lowers the variance of a
// mirror caustic at equal samples, and is chosen only where a scene calls for it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

#include "common/render/path_guiding.h"
#include "common/render/render_scene.h"
#include "common/render/sampler.h"
#include "common/render/unit_renderer.h"
#include "common/scene/effects.h"
#include "tests/support/placement.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

const GuidingField::Shape kShape;
const double kBinSolidAngle = 4.0 * std::numbers::pi / kShape.bins();

// The centre direction of bin b.
Vec3 binCentre(int b) {
  return GuidingField::direction((b / kShape.phiBins + 0.5) / kShape.zBins,
                                 (b % kShape.phiBins + 0.5) / kShape.phiBins);
}

// n records at points spread over the unit cube (moved by `offset`, times `scale`), each bin of
// `bins` taking its share of them with luminance `weights[k]` and density 1.
std::vector<GuidingField::Record> recordsInBins(size_t n, const std::vector<int>& bins,
                                                const std::vector<float>& weights, double scale = 1.0,
                                                glm::dvec3 offset = glm::dvec3(0.0)) {
  std::vector<GuidingField::Record> out;
  for (size_t k = 0; k < n; ++k) {
    const double x = double(k);
    const glm::dvec3 unit(x * 0.618034 - std::floor(x * 0.618034), x * 0.7548777 - std::floor(x * 0.7548777),
                          x * 0.5698403 - std::floor(x * 0.5698403));
    const glm::dvec3 p = offset + scale * unit;
    const size_t which = k % bins.size();
    out.push_back({Vec3(p), binCentre(bins[which]), 1.0f, weights[which]});
  }
  return out;
}

TEST(GuidingField, EveryBinsCentreMapsBackToItAndBinsHaveEqualSolidAngle) {
  for (int b = 0; b < kShape.bins(); ++b) {
    const Vec3 w = binCentre(b);
    EXPECT_NEAR(glm::length(w), 1.0f, 1e-6f);
    EXPECT_EQ(GuidingField().binOf(w), b);
  }
  // The poles and the seam of phi fall in the first or last bins, not outside.
  EXPECT_EQ(GuidingField().binOf(Vec3(0, 0, 1)) / kShape.phiBins, kShape.zBins - 1);
  EXPECT_EQ(GuidingField().binOf(Vec3(0, 0, -1)) / kShape.phiBins, 0);
  EXPECT_EQ(GuidingField().binOf(Vec3(1, -1e-9f, 0)) % kShape.phiBins, kShape.phiBins - 1);
}

// The learned probabilities are the recorded radiance's shares (sum L / p per bin), and sample()
// draws each bin as often as pdf() says: a chi-square test over the bins, and the density
// integrates to one over the sphere.
TEST(GuidingField, LearnsTheRadianceSharesAndSamplesWhatItsDensitySays) {
  const int last = kShape.bins() - 1;
  const std::vector<int> bins = {3, last / 4, last / 2, last};
  const std::vector<float> weights = {1.0f, 3.0f, 0.0f, 4.0f};
  const GuidingField field = GuidingField::learn(recordsInBins(2000, bins, weights));
  ASSERT_EQ(field.regionCount(), 1u);
  const int r = field.regionAt(Vec3(0.5f));
  ASSERT_EQ(r, 0);
  const double expected[4] = {1.0 / 8, 3.0 / 8, 0.0, 4.0 / 8};
  double integral = 0.0;
  for (int b = 0; b < kShape.bins(); ++b) integral += field.pdf(r, binCentre(b)) * kBinSolidAngle;
  EXPECT_NEAR(integral, 1.0, 1e-5);
  for (size_t k = 0; k < bins.size(); ++k)
    EXPECT_NEAR(field.pdf(r, binCentre(bins[k])) * kBinSolidAngle, expected[k], 1e-6) << "bin " << bins[k];

  // Draws by a counter-based stream; each direction's bin counted.
  const SamplerSetup setup{SamplerKind::kIndependent, 11, 1, 1};
  const int n = 200000;
  std::vector<int> count(kShape.bins(), 0);
  for (int k = 0; k < n; ++k) {
    const Vec3 w = field.sample(r, SampleStream(setup, 0, uint64_t(k)).get2D(0));
    ASSERT_NEAR(glm::length(w), 1.0f, 1e-5f);
    ASSERT_GT(field.pdf(r, w), 0.0f) << "a direction drawn where the density is zero";
    ++count[size_t(GuidingField().binOf(w))];
  }
  double chi2 = 0.0;
  for (size_t k = 0; k < bins.size(); ++k) {
    if (expected[k] == 0.0) {
      EXPECT_EQ(count[size_t(bins[k])], 0);
      continue;
    }
    const double e = expected[k] * n;
    chi2 += (count[size_t(bins[k])] - e) * (count[size_t(bins[k])] - e) / e;
  }
  EXPECT_LT(chi2, 16.3) << "chi-square with 2 degrees of freedom, p = 3e-4";
  // Within a bin, directions are uniform in solid angle: z (uniform in an equal-area bin) has the
  // mean of the bin's z range.
  double zSum = 0.0;
  int zCount = 0;
  for (int k = 0; k < n; ++k) {
    const Vec3 w = field.sample(r, SampleStream(setup, 1, uint64_t(k)).get2D(0));
    if (GuidingField().binOf(w) != last) continue;
    zSum += w.z, ++zCount;
  }
  const double zLo = -1.0 + 2.0 * (last / kShape.phiBins) / double(kShape.zBins);
  EXPECT_NEAR(zSum / zCount, zLo + 1.0 / kShape.zBins, 4.0 * (1.0 / kShape.zBins) / std::sqrt(12.0 * zCount));
}

// Space is cut where records crowd (no region holds more than kMaxRecordsPerRegion), regions with
// too few records or no radiance guide nowhere, points outside the records' bounds are not
// guided, and the same records moved to 1e6 or scaled to 1e-4 and 1e6 learn the same field.
TEST(GuidingField, SplitsSpaceByRecordsTheSameAtAnyPlaceAndScale) {
  const std::vector<int> bins = {7, kShape.bins() - 9};
  const std::vector<float> weights = {1.0f, 2.0f};
  const size_t n = 6 * kShape.maxRecordsPerRegion;
  const GuidingField base = GuidingField::learn(recordsInBins(n, bins, weights));
  EXPECT_GE(base.leafCount(), 6u);
  EXPECT_GE(base.regionCount(), 6u);
  EXPECT_EQ(base.regionAt(Vec3(2.0f, 0.5f, 0.5f)), -1);
  EXPECT_EQ(base.regionAt(Vec3(-0.01f, 0.5f, 0.5f)), -1);
  for (const auto& [scale, offset] : std::vector<std::pair<double, glm::dvec3>>{{1.0, glm::dvec3(1e6, -1e6, 1e6)},
                                                                                {1e-4, glm::dvec3(0.0)},
                                                                                {1e6, glm::dvec3(0.0)},
                                                                                {1e-4, glm::dvec3(3.0)}}) {
    SCOPED_TRACE(testing::Message() << "scale " << scale << " offset " << offset.x);
    const GuidingField moved = GuidingField::learn(recordsInBins(n, bins, weights, scale, offset));
    EXPECT_EQ(moved.leafCount(), base.leafCount());
    EXPECT_EQ(moved.regionCount(), base.regionCount());
    const Vec3 inside = Vec3(offset + scale * glm::dvec3(0.3, 0.6, 0.4));
    const int r = moved.regionAt(inside);
    ASSERT_GE(r, 0);
    EXPECT_NEAR(moved.pdf(r, binCentre(bins[1])) * kBinSolidAngle, 2.0 / 3.0, 0.02);
  }
  // Few records: no region guides.
  const GuidingField sparse = GuidingField::learn(recordsInBins(kShape.minRecordsPerRegion - 1, bins, weights));
  EXPECT_EQ(sparse.regionCount(), 0u);
  EXPECT_EQ(sparse.regionAt(Vec3(0.5f)), -1);
  // No radiance: no region guides.
  const GuidingField dark = GuidingField::learn(recordsInBins(1000, bins, {0.0f, 0.0f}));
  EXPECT_EQ(dark.regionAt(Vec3(0.5f)), -1);
}

// Records that are not numbers are left out; records all at one point end the splitting.
TEST(GuidingField, IgnoresBadRecordsAndRecordsAtOnePoint) {
  std::vector<GuidingField::Record> records = recordsInBins(500, {5}, {1.0f});
  const float nan = std::nanf("");
  records.push_back({Vec3(nan), Vec3(0, 0, 1), 1.0f, 1.0f});
  records.push_back({Vec3(1e30f), Vec3(0, 0, 1), 0.0f, 1.0f});
  records.push_back({Vec3(-1e30f), Vec3(0, 0, 1), 1.0f, nan});
  records.push_back({Vec3(1e30f), Vec3(0, 0, 1), 1.0f, std::numeric_limits<float>::infinity()});
  const GuidingField field = GuidingField::learn(records);
  ASSERT_EQ(field.regionCount(), 1u);
  EXPECT_EQ(field.regionAt(Vec3(2.0f)), -1) << "the bad records did not widen the bounds";
  std::vector<GuidingField::Record> same(3 * kShape.maxRecordsPerRegion, {Vec3(0.25f), binCentre(9), 2.0f, 1.0f});
  const GuidingField point = GuidingField::learn(same);
  EXPECT_EQ(point.regionCount(), 1u);
  EXPECT_GE(point.regionAt(Vec3(0.25f)), 0);
}

// A recorder turns a path's later radiance into the incident radiance at each guided vertex:
// what arrived after the vertex, divided by the throughput after it.
TEST(GuidingRecorder, RecordsTheRadianceThatCameBackAlongEachDirection) {
  GuidingRecorder recorder;
  std::vector<GuidingField::Record> out;
  recorder.add(Vec3(0), Vec3(0, 0, 1), 0.3f, Spectrum(0.5f));
  recorder.settle(Spectrum(0.1f));  // the first vertex's own light sample: not along its direction
  recorder.add(Vec3(1), Vec3(1, 0, 0), 0.2f, Spectrum(0.25f, 0.0f, 0.25f));
  recorder.settle(Spectrum(0.3f, 0.1f, 0.3f));
  recorder.finish(Spectrum(0.8f, 0.1f, 0.8f), out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_NEAR(out[0].luminance, luminance(Spectrum(0.7f, 0.0f, 0.7f) / 0.5f), 1e-6f);
  EXPECT_NEAR(out[1].luminance, luminance(Spectrum(2.0f, 0.0f, 2.0f)), 1e-6f);
  EXPECT_EQ(out[1].pdf, 0.2f);
  EXPECT_TRUE(recorder.pending.empty());
}

// A diffuse floor and back wall, a mirror wall at x = -1 and a light 10 cm from it facing the
// floor (render/light_tracer_test.cpp's caustic scene): most of the floor's light near the mirror
// arrives light -> mirror -> floor, which next-event estimation cannot sample.
json mirrorScene(double scale = 1.0, glm::dvec3 offset = glm::dvec3(0.0)) {
  const test::PlacedPoint at{scale, offset};
  const test::ScaledVector v{scale};
  json j = json::parse(R"({
    "format": "lensfarm-scene/1",
    "camera": { "type": "pinhole", "up": [0, 1, 0] },
    "materials": { "white": { "type": "lambertian", "albedo": 0.7 },
                   "red": { "type": "lambertian", "albedo": [0.7, 0.2, 0.2] },
                   "glass": { "type": "mirror", "reflectance": 0.9 } },
    "render": { "resolution": [20, 20], "samples_per_pixel": 32, "max_bounces": 2, "seed": 7 }
  })");
  j["camera"]["position"] = at(0, 0.2, -3);
  j["camera"]["look_at"] = at(0, -0.3, 0);
  j["camera"]["sensor_width"] = 0.1 * scale;
  j["camera"]["focal_length"] = 0.07 * scale;
  const auto quad = [&](json corner, json e1, json e2, const char* material) {
    j["shapes"].push_back({{"type", "quad"}, {"corner", corner}, {"edge1", e1}, {"edge2", e2}, {"material", material}});
  };
  quad(at(-1, -1, -1), v(0, 0, 2.5), v(2, 0, 0), "white");
  quad(at(-1, -1, 1.5), v(2, 0, 0), v(0, 2, 0), "red");
  quad(at(-1, -1, -1), v(0, 2, 0), v(0, 0, 2.5), "glass");
  j["lights"] = json::array({{{"type", "quad"},
                              {"corner", at(-0.9, 0.5, -0.2)},
                              {"edge1", v(0.6, 0, 0)},
                              {"edge2", v(0, 0, 0.8)},
                              {"radiance", 8},
                              {"visible_to_camera", false}}});
  return j;
}

// A shipped scene at side x side pixels and spp samples, rendered as whole passes.
json smallBundled(const std::string& name, int side, int spp) {
  json j = test::bundledSceneJson(name);
  j["render"]["resolution"] = {side, side};
  j["render"]["samples_per_pixel"] = spp;
  j["render"].erase("samples_per_unit");
  j["render"].erase("tile_size");
  return j;
}

Scene withGuiding(const test::TempDir& dir, json j, const std::string& mode, const std::string& name) {
  j["render"]["path_guiding"] = mode;
  return test::loadSceneJson(dir, j, name + "-" + mode + ".json");
}

// The guided estimator against the path tracer alone: the project's test that two estimates are
// of one image (per-pixel z-test and image means).
void expectAgreement(const test::TempDir& dir, const json& j, const std::string& name, int renders = 16) {
  const Scene on = withGuiding(dir, j, "on", name), off = withGuiding(dir, j, "off", name);
  const RenderScene guided(on);
  ASSERT_NE(guided.guide(), nullptr) << name;
  ASSERT_GT(guided.guide()->regionCount(), 0u) << name;
  ASSERT_EQ(RenderScene(off).guide(), nullptr) << name;
  SCOPED_TRACE(name);
  test::expectSameImage(test::renderStatistics(on, renders), test::renderStatistics(off, renders));
}

// A furnace (render/integrator_test.cpp's): every wall emits 1 and reflects a = 0.5, so the image
// is 1 + a + ... + a^B exactly, whatever the guided directions; a mixture density off by 10 %
// moves it by several percent.
TEST(PathGuiding, AFurnaceGivesItsClosedFormGuided) {
  const double a = 0.5;
  for (int b : {2, 3, 5}) {  // (at B = 1 no path scatters past its light sample: nothing to guide)
    test::TempDir dir;
    json j = test::closedBoxSceneJson({{"type", "lambertian"}, {"albedo", a}, {"emission", 1.0}}, 24, 32, b);
    const Scene scene = withGuiding(dir, j, "on", "furnace");
    ASSERT_GT(RenderScene(scene).guide()->regionCount(), 0u);
    const test::Rendered r = test::renderScene(scene);
    double expected = 0.0;
    for (int k = 0; k <= b; ++k) expected += std::pow(a, k);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.mean[c], expected, 0.01 * expected) << "B = " << b;
  }
}

TEST(PathGuiding, AgreesWithThePathTracerThroughAMirror) {
  test::TempDir dir;
  expectAgreement(dir, mirrorScene(), "mirror");
}

TEST(PathGuiding, AgreesFarFromTheOriginAndAtExtremeScales) {
  test::TempDir dir;
  for (const auto& [scale, offset] : std::vector<std::pair<double, glm::dvec3>>{
           {1.0, glm::dvec3(1e6, 1e6, -1e6)}, {1e-4, glm::dvec3(0.0)}, {1e6, glm::dvec3(0.0)}}) {
    const std::string name = "mirror-" + std::to_string(scale) + "-" + std::to_string(offset.x);
    expectAgreement(dir, mirrorScene(scale, offset), name, 12);
  }
}

TEST(PathGuiding, AgreesThroughGlassAndMetalOnTheShippedBox) {
  test::TempDir dir;
  expectAgreement(dir, smallBundled("cornell-glass-metal.json", 20, 32), "glass-metal", 12);
}

// Training is a pure function of the scene: every thread count and every construction of the
// scene gives the same bits (units split across workers: Farm.AGuidedJobOnThreeWorkers...).
TEST(PathGuiding, SameBitsForAnyThreadCount) {
  test::TempDir dir;
  json j = mirrorScene();
  j["render"]["samples_per_unit"] = 8;
  const Scene scene = withGuiding(dir, j, "on", "bits");
  std::vector<std::vector<float>> images;
  for (int threads : {1, 2, 3}) images.push_back(test::renderScene(scene, threads).image.rgb);
  EXPECT_EQ(images[0], images[1]);
  EXPECT_EQ(images[0], images[2]);
  const Scene off = withGuiding(dir, j, "off", "bits");
  EXPECT_NE(test::renderScene(off, 2).image.rgb, images[0]) << "guiding changed nothing";
}

// Guiding off is the path tracer: a scene where the analysis leaves it off (auto) gives the bits of
// the same scene with it off.
TEST(PathGuiding, OffIsThePathTracerBitForBit) {
  test::TempDir dir;
  const json j = smallBundled("cornell-classic.json", 16, 8);
  const Scene autoScene = withGuiding(dir, j, "auto", "classic"), off = withGuiding(dir, j, "off", "classic");
  ASSERT_EQ(RenderScene(autoScene).guide(), nullptr);
  EXPECT_EQ(test::renderScene(autoScene, 2).image.rgb, test::renderScene(off, 2).image.rgb);
}

// The guided vertices in the packet tracer's lane loops compute what the one-path code computes:
// every unit is the same bits in packets and one ray at a time.
TEST(PathGuiding, PacketsGiveTheOneRayBits) {
  test::TempDir dir;
  for (const auto& [j, name] :
       {std::make_pair(mirrorScene(), "mirror"), std::make_pair(test::bundledSceneJson("cornell-seed.json"), "seed")}) {
    json small = j;
    small["render"]["resolution"] = {32, 32};
    small["render"]["samples_per_pixel"] = 8;
    small["render"].erase("samples_per_unit");
    const Scene scene = withGuiding(dir, small, "on", name);
    const RenderScene rs(scene);
    ASSERT_NE(rs.guide(), nullptr);
    ASSERT_GT(rs.guide()->regionCount(), 0u) << name;
    const WorkUnit unit = unitAt(0, 8, 8);
    SensorBuffer packets, single;
    PathStats a, b;
    ASSERT_TRUE(renderUnit(rs, unit, packets, a, nullptr, RayGrouping::kPackets));
    ASSERT_TRUE(renderUnit(rs, unit, single, b, nullptr, RayGrouping::kSingleRays));
    EXPECT_EQ(packets.sums, single.sums) << name;
    EXPECT_EQ(a.rays, b.rays) << name;
  }
}

// The mirror caustic: at equal samples, guided paths find the light through the mirror more often;
// the variance over the image falls (a figure, printed).
TEST(PathGuiding, LowersTheVarianceOfAMirrorCaustic) {
  test::TempDir dir;
  json j = mirrorScene();
  // Enough pixels for the training passes to learn from (15 samples on each of 48 x 48).
  j["render"]["resolution"] = {48, 48};
  j["render"]["samples_per_pixel"] = 16;
  const auto on = test::renderStatistics(withGuiding(dir, j, "on", "variance"), 16);
  const auto off = test::renderStatistics(withGuiding(dir, j, "off", "variance"), 16);
  double vOn = 0, vOff = 0;
  for (size_t k = 0; k < off.variance.size(); ++k) vOn += on.variance[k], vOff += off.variance[k];
  std::printf("mirror caustic, 48x48, 16 spp, 16 renders: variance off / on %.2f\n", vOff / vOn);
  EXPECT_GT(vOff / vOn, 1.15);
}

TEST(PathGuiding, TheAnalysisListsItWhereMirrorsOrGlassShowALightAndTheSettingForcesIt) {
  test::TempDir dir;
  const auto decision = [&](const json& j, const std::string& name) {
    const Scene scene = test::loadSceneJson(dir, j, name + ".json");
    const EffectSet e = RenderScene(scene).effects();
    for (const EffectDecision& d : e.decisions)
      if (d.effect == "path guiding") return std::make_pair(d.simulated, d.reason);
    return std::make_pair(false, std::string("(not listed)"));
  };
  // Auto: listed, off, where a mirror shows an emitting surface (it pays by relMSE there, not by
  // relative RMSE) and where only glass or metal shows a light (it does not pay).
  for (const auto& [j, name] :
       {std::make_pair(mirrorScene(), "mirror"), std::make_pair(test::bundledSceneJson("cornell-seed.json"), "seed")}) {
    const auto [on, why] = decision(j, name);
    EXPECT_FALSE(on) << name;
    EXPECT_NE(why.find("relative RMSE"), std::string::npos) << why;
  }
  EXPECT_EQ(guidingTrainingPaths(20, 20), 400u * 15u);
  EXPECT_EQ(guidingTrainingPaths(800, 800), 160u * 160u * 15u) << "every 5th pixel each way";
  json seedOn = test::bundledSceneJson("cornell-seed.json");
  seedOn["render"]["path_guiding"] = "on";
  EXPECT_TRUE(decision(seedOn, "seed-on").first);
  const auto [glassOn, glassWhy] = decision(test::bundledSceneJson("cornell-glass-metal.json"), "glass");
  EXPECT_FALSE(glassOn);
  EXPECT_NE(glassWhy.find("not to pay"), std::string::npos) << glassWhy;
  json glassForced = test::bundledSceneJson("cornell-glass-metal.json");
  glassForced["render"]["path_guiding"] = "on";
  EXPECT_TRUE(decision(glassForced, "glass-on").first);
  EXPECT_EQ(decision(test::bundledSceneJson("cornell-classic.json"), "classic").second, "(not listed)");
  json forced = test::bundledSceneJson("cornell-classic.json");
  forced["render"]["path_guiding"] = "on";
  EXPECT_TRUE(decision(forced, "forced").first);
  json off = mirrorScene();
  off["render"]["path_guiding"] = "off";
  EXPECT_EQ(decision(off, "off"), std::make_pair(false, std::string("render.path_guiding is off")));
  json fog = mirrorScene();
  fog["medium"] = "fog";
  fog["media"]["fog"] = {{"sigma_s", 0.1}, {"sigma_a", 0.01}};
  fog["render"]["path_guiding"] = "on";
  EXPECT_EQ(decision(fog, "fog"), std::make_pair(false, std::string("the volume path tracer is not guided")));
  json bad = mirrorScene();
  bad["render"]["path_guiding"] = "sometimes";
  try {
    test::loadSceneJson(dir, bad, "bad.json");
    ADD_FAILURE() << "an unknown mode was accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("render.path_guiding"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace lensfarm
