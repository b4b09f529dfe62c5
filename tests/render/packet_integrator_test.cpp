// The packet integrator (tracePacket) against the one-ray-at-a-time reference (tracePath): every
// lane gives the reference's bits for its sample, whatever else shares its packet, for every
// estimator and compiled-in effect set, with Russian roulette too.
#include <gtest/gtest.h>

#include <cstring>
#if defined(__SSE__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#endif
#include <fstream>

#include "common/film/image_io.h"
#include "common/render/integrator.h"
#include "common/render/render_scene.h"
#include "common/render/unit_renderer.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

json sceneFile(const char* name) {
  json scene = test::bundledSceneJson(name);
  scene["render"]["resolution"] = {48, 48};
  return scene;
}

struct Lane {
  int i, j;
  uint64_t sample;
};

// Traces `lanes` as packets of `width` lanes and each lane alone; expects equal bits and counts.
template <bool kNee, bool kSpecular>
void expectPacketsEqualSinglePaths(const RenderScene& rs, const std::vector<Lane>& lanes, int width) {
  const RenderSettings& settings = rs.settings();
  const SamplerSetup sampler{settings.sampler, settings.seed, settings.samplesPerPixel, unitSize(settings)};
  const ThinLensCamera& camera = rs.camera().paraxial();
  PathStats packetStats, singleStats;
  int compared = 0, nonZero = 0;
  for (size_t first = 0; first < lanes.size(); first += size_t(width)) {
    PathPacket packet;
    packet.count = int(std::min<size_t>(size_t(width), lanes.size() - first));
    for (int k = 0; k < packet.count; ++k) {
      const Lane& lane = lanes[first + size_t(k)];
      packet.rng[k] =
          SampleStream(sampler, uint64_t(lane.j) * uint64_t(camera.width()) + uint64_t(lane.i), lane.sample);
      packet.cameraRays.set(
          k, camera.generateRay(lane.i, lane.j, packet.rng[k].get2D(dims::kSensor), packet.rng[k].get2D(dims::kLens)));
    }
    Spectrum radiance[kPacketWidth];
    tracePacket<kNee, kSpecular>(rs, packet, radiance, packetStats);
    for (int k = 0; k < packet.count; ++k) {
      const Spectrum single = tracePath<kNee, kSpecular>(rs, packet.cameraRays.ray(k), packet.rng[k], singleStats);
      EXPECT_EQ(std::memcmp(&single, &radiance[k], sizeof(Spectrum)), 0)
          << "lane " << k << " of the packet at " << first << ": " << single.r << " vs " << radiance[k].r;
      ++compared;
      nonZero += !isBlack(single);
    }
  }
  EXPECT_EQ(compared, int(lanes.size()));
  // The naive estimator finds light on a few paths in a hundred; light sampling on most.
  EXPECT_GT(nonZero, kNee ? compared / 4 : compared / 100) << "the comparison must see light";
  EXPECT_EQ(packetStats.paths, singleStats.paths);
  EXPECT_EQ(packetStats.rays, singleStats.rays);
  EXPECT_EQ(packetStats.lightHits, singleStats.lightHits);
}

// A pixel's consecutive samples (what the unit renderer packs together), then lanes scattered
// over the frame (incoherent packets: a lane's result must not depend on its neighbours).
std::vector<Lane> lanesFor(int width, int height) {
  std::vector<Lane> lanes;
  for (int p = 0; p < 6; ++p)
    for (uint64_t s = 0; s < 21; ++s) lanes.push_back({(p * 7) % width, (p * 11 + 3) % height, s});
  uint64_t x = 12345;
  for (int n = 0; n < 200; ++n) {
    x = x * 6364136223846793005ull + 1442695040888963407ull;
    lanes.push_back({int((x >> 33) % uint64_t(width)), int((x >> 45) % uint64_t(height)), (x >> 20) % 64});
  }
  return lanes;
}

TEST(PacketIntegrator, EveryLaneGivesTheSinglePathBitsForEachEstimator) {
  for (const char* integrator : {"nee_mis", "nee", "naive"})
    for (bool roulette : {false, true}) {
      SCOPED_TRACE(std::string(integrator) + (roulette ? " with roulette" : ""));
      json classic = sceneFile("cornell-classic.json");
      classic["render"]["integrator"] = integrator;
      classic["render"]["russian_roulette"] = roulette;
      classic["render"]["max_bounces"] = 5;
      test::TempDir dir;
      const Scene scene = test::loadSceneJson(dir, classic);
      const RenderScene rs(scene);
      const auto lanes = lanesFor(48, 48);
      for (int width : {16, 5, 1}) {
        if (std::string(integrator) == "naive")
          expectPacketsEqualSinglePaths<false, false>(rs, lanes, width);
        else
          expectPacketsEqualSinglePaths<true, false>(rs, lanes, width);
      }
    }
}

TEST(PacketIntegrator, EveryLaneGivesTheSinglePathBitsWithLensAndMirrors) {
  for (const char* integrator : {"nee_mis", "naive"}) {
    SCOPED_TRACE(integrator);
    json seed = sceneFile("cornell-seed.json");
    seed["render"]["integrator"] = integrator;
    test::TempDir dir;
    const Scene scene = test::loadSceneJson(dir, seed);
    const RenderScene rs(scene, /*general=*/true);
    const auto lanes = lanesFor(48, 48);
    for (int width : {16, 3}) {
      if (std::string(integrator) == "naive")
        expectPacketsEqualSinglePaths<false, true>(rs, lanes, width);
      else
        expectPacketsEqualSinglePaths<true, true>(rs, lanes, width);
    }
  }
}

TEST(PacketIntegrator, EveryLaneGivesTheSinglePathBitsWithGlossyMetalGlassAndPrincipled) {
  // Models beyond Lambertian take the one-path vertex code inside a packet; their light samples
  // join the packet's shadow rays (render/integrator.cpp). Rough metal, rough glass, principled
  // and smooth glass side by side, with light sampling on and off.
  for (const char* integrator : {"nee_mis", "nee", "naive"}) {
    SCOPED_TRACE(integrator);
    json scene = sceneFile("cornell-glass.json");
    scene["render"]["integrator"] = integrator;
    scene["render"]["max_bounces"] = 4;
    scene["shapes"][1]["file"] = (test::scenesDir() / "meshes/sphere.obj").string();
    scene["materials"]["yellow"] = {{"type", "conductor"}, {"metal", "Au"}, {"roughness", 0.4}};
    scene["materials"]["cyan"] = {{"type", "principled"},
                                  {"base_color", {0.2, 0.7, 0.7}},
                                  {"metallic", 0.3},
                                  {"roughness", 0.5},
                                  {"transmission", 0.4}};
    scene["materials"]["blue"] = {{"type", "dielectric"}, {"ior", 1.4}, {"roughness", 0.3}};
    test::TempDir dir;
    const Scene loaded = test::loadSceneJson(dir, scene);
    const RenderScene rs(loaded);
    ASSERT_TRUE(rs.effects().generalMaterials);
    const auto lanes = lanesFor(48, 48);
    for (int width : {16, 5}) {
      if (std::string(integrator) == "naive")
        expectPacketsEqualSinglePaths<false, true>(rs, lanes, width);
      else
        expectPacketsEqualSinglePaths<true, true>(rs, lanes, width);
    }
  }
}

// A UV sphere of radius 1 with vertex normals (shaded smoothly: per point, shading_point.h).
std::string writeSmoothSphere(const test::TempDir& dir) {
  const std::filesystem::path file = dir.path() / "smooth-sphere.obj";
  std::ofstream out(file);
  const int rings = 12, segments = 24;
  for (int r = 0; r <= rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const double theta = M_PI * r / rings, phi = 2.0 * M_PI * s / segments;
      const double x = std::sin(theta) * std::cos(phi), y = std::cos(theta), z = std::sin(theta) * std::sin(phi);
      out << "v " << x << " " << y << " " << z << "\nvn " << x << " " << y << " " << z << "\n";
    }
  const auto index = [&](int r, int s) { return r * segments + (s % segments) + 1; };
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const int a = index(r, s), b = index(r + 1, s), c = index(r + 1, s + 1), d = index(r, s + 1);
      out << "f " << a << "//" << a << " " << d << "//" << d << " " << c << "//" << c << "\n";
      out << "f " << a << "//" << a << " " << c << "//" << c << " " << b << "//" << b << "\n";
    }
  return file.string();
}

TEST(PacketIntegrator, EveryLaneGivesTheSinglePathBitsWithPrincipledMaterialsInTheLaneLoops) {
  // glTF's metallic-roughness model without textures is shaded in the lane loops (GlossyLanes,
  // render/integrator.cpp): dielectric and metal, rough and near-mirror, without a specular layer,
  // thin-walled rough transmission, a smooth sphere (per-point shading normals), beside
  // Lambertian walls, for each estimator, with roulette and a light tree too.
  for (const char* integrator : {"nee_mis", "nee", "naive"})
    for (bool variant : {false, true}) {
      SCOPED_TRACE(std::string(integrator) + (variant ? " with roulette and a light tree" : ""));
      json scene = sceneFile("cornell-classic.json");
      scene["render"]["integrator"] = integrator;
      // (The naive estimator finds the small lamp on few paths: longer ones let it see light.)
      scene["render"]["max_bounces"] = std::string(integrator) == "naive" ? 12 : 5;
      if (variant) scene["render"]["russian_roulette"] = true, scene["render"]["light_tree"] = "on";
      const auto principled = [](json base, double metallic, double roughness) {
        return json{{"type", "principled"}, {"base_color", base}, {"metallic", metallic}, {"roughness", roughness}};
      };
      scene["materials"]["red"] = principled({0.7, 0.1, 0.1}, 0.0, 1.0);
      scene["materials"]["green"] = principled({0.1, 0.7, 0.1}, 0.0, 0.2);
      scene["materials"]["blue"] = principled({0.9, 0.6, 0.5}, 1.0, 0.3);
      scene["materials"]["cyan"] = principled({0.9, 0.9, 0.9}, 1.0, 0.02);
      scene["materials"]["purple"] = principled({0.6, 0.2, 0.6}, 0.5, 0.6);
      scene["materials"]["purple"]["specular"] = 0.0;
      scene["materials"]["yellow"] = principled({0.7, 0.7, 0.2}, 0.0, 0.5);
      scene["materials"]["yellow"]["transmission"] = 0.5;
      scene["materials"]["copper"] = principled({0.95, 0.64, 0.54}, 1.0, 0.3);
      test::TempDir dir;
      scene["shapes"].push_back({{"type", "obj"},
                                 {"file", writeSmoothSphere(dir)},
                                 {"material", "copper"},
                                 {"transform", {{"scale", 0.25}, {"translate", {0.3, -0.7, -0.3}}}}});
      const Scene loaded = test::loadSceneJson(dir, scene);
      const RenderScene rs(loaded);
      ASSERT_TRUE(rs.effects().generalMaterials);
      int glossy = 0;
      for (const auto& record : rs.materialRecords()) glossy += record.glossy != 0;
      EXPECT_EQ(glossy, 7) << "every principled material above takes the lane loops";
      const auto lanes = lanesFor(48, 48);
      for (int width : {16, 5, 1}) {
        if (std::string(integrator) == "naive")
          expectPacketsEqualSinglePaths<false, true>(rs, lanes, width);
        else
          expectPacketsEqualSinglePaths<true, true>(rs, lanes, width);
      }
    }
}

// A Cornell scene with every kind of light added: a point and a spot inside the box, a sun with
// and one without an angular diameter and an OpenEXR sky, which reach it through its open front.
// The camera steps back, so that camera rays at the edges of the frame leave the scene too.
json withEveryKindOfLight(json scene, const test::TempDir& dir) {
  scene["camera"]["position"] = {0, 0, -4.5};
  Image sky;
  sky.width = 8, sky.height = 4;
  for (int k = 0; k < 32; ++k)
    sky.rgb.insert(sky.rgb.end(), {0.5f + 0.1f * float(k % 5), 0.7f, 1.0f + 0.2f * float(k % 3)});
  writeExr(dir / "sky.exr", sky, ImageMetadata{});
  for (const json& light : json::array(
           {{{"type", "point"}, {"position", {0.3, 0.2, 0}}, {"intensity", {1, 0.8, 0.6}}},
            {{"type", "spot"},
             {"position", {-0.5, -0.8, -0.2}},
             {"look_at", {0, 1, 0.3}},
             {"intensity", 2},
             {"cone_angle", 30},
             {"falloff_start", 20}},
            {{"type", "directional"}, {"direction", {0.2, -0.3, -1}}, {"irradiance", 0.5}},
            {{"type", "directional"}, {"direction", {-0.3, -0.1, -1}}, {"irradiance", 0.7}, {"angular_diameter", 8}}}))
    scene["lights"].push_back(light);
  scene["environment"] = {{"file", "sky.exr"}, {"strength", 0.5}, {"rotation", 20}};
  return scene;
}

TEST(PacketIntegrator, EveryLaneGivesTheSinglePathBitsWithEveryKindOfLight) {
  // With the naive estimator the delta lights are still sampled, so every estimator traces with
  // light samples compiled in (render/unit_renderer.cpp), and lanes that choose a light that is
  // not a triangle take the one-sample code.
  for (const char* integrator : {"nee_mis", "nee", "naive"})
    for (bool roulette : {false, true}) {
      SCOPED_TRACE(std::string(integrator) + (roulette ? " with roulette" : ""));
      test::TempDir dir;
      json classic = withEveryKindOfLight(sceneFile("cornell-classic.json"), dir);
      classic["render"]["integrator"] = integrator;
      classic["render"]["russian_roulette"] = roulette;
      classic["render"]["max_bounces"] = 4;
      const Scene scene = test::loadSceneJson(dir, classic);
      const RenderScene rs(scene);
      ASSERT_TRUE(rs.effects().lightSampling);
      ASSERT_TRUE(rs.hasEscapeLights());
      const auto lanes = lanesFor(48, 48);
      for (int width : {16, 5}) expectPacketsEqualSinglePaths<true, false>(rs, lanes, width);
    }
  // Mirrors and a lens (the general vertex code) too.
  for (const char* integrator : {"nee_mis", "naive"}) {
    SCOPED_TRACE(integrator);
    test::TempDir dir;
    json seed = withEveryKindOfLight(sceneFile("cornell-seed.json"), dir);
    seed["render"]["integrator"] = integrator;
    const Scene scene = test::loadSceneJson(dir, seed);
    const RenderScene rs(scene, /*general=*/true);
    expectPacketsEqualSinglePaths<true, true>(rs, lanesFor(48, 48), 16);
  }
}

TEST(PacketIntegrator, EveryLaneGivesTheSinglePathBitsWithALightTree) {
  // Each lane descends the tree from its own point; the triangles it chooses are sampled in the
  // lane loop with its own probability, the other lights one by one, the infinite ones by power.
  for (const char* integrator : {"nee_mis", "nee", "naive"}) {
    SCOPED_TRACE(integrator);
    test::TempDir dir;
    json classic = withEveryKindOfLight(sceneFile("cornell-classic.json"), dir);
    classic["render"]["integrator"] = integrator;
    classic["render"]["max_bounces"] = 4;
    classic["render"]["light_tree"] = "on";
    const Scene scene = test::loadSceneJson(dir, classic);
    const RenderScene rs(scene);
    ASSERT_TRUE(rs.lights().usesTree());
    for (int width : {16, 5}) expectPacketsEqualSinglePaths<true, false>(rs, lanesFor(48, 48), width);
  }
}

TEST(PacketIntegrator, UnitsRenderedInPacketsEqualUnitsRenderedOneRayAtATime) {
  // The whole unit renderer, packets against single rays, for unit sizes that put one pixel,
  // several pixels, or a pixel and a half in a packet.
  for (uint32_t unitSamples : {16u, 3u, 24u}) {
    SCOPED_TRACE(unitSamples);
    json seed = sceneFile("cornell-seed.json");
    seed["render"]["samples_per_pixel"] = 48;
    seed["render"]["samples_per_unit"] = unitSamples;
    test::TempDir dir;
    const Scene scene = test::loadSceneJson(dir, seed);
    const RenderScene rs(scene);
    const WorkUnit unit = unitAt(1, 48, unitSamples);
    SensorBuffer packets, singles;
    PathStats packetStats, singleStats;
    ASSERT_TRUE(renderUnit(rs, unit, packets, packetStats, nullptr, RayGrouping::kPackets));
    ASSERT_TRUE(renderUnit(rs, unit, singles, singleStats, nullptr, RayGrouping::kSingleRays));
    ASSERT_EQ(packets.sums.size(), singles.sums.size());
    EXPECT_EQ(std::memcmp(packets.sums.data(), singles.sums.data(), packets.sums.size() * sizeof(double)), 0);
    EXPECT_EQ(packets.samples, singles.samples);
    EXPECT_EQ(packetStats.rays, singleStats.rays);
    double total = 0.0;
    for (double v : packets.sums) total += v;
    EXPECT_GT(total, 0.0);
  }
}

#if defined(__SSE__)
TEST(UnitRenderer, FlushesDenormalsOnRenderThreadsButGivesTheCallerItsModeBack) {
  // Render threads flush denormals to zero (Embree's advice); the calling thread takes part in
  // the render, so it must get its own mode back, or IEEE code it runs later (std::nextafter on
  // subnormals, say) changes behaviour.
  const unsigned before = _mm_getcsr();
  _mm_setcsr(before & ~(_MM_FLUSH_ZERO_ON | _MM_DENORMALS_ZERO_ON));
  const unsigned ieee = _mm_getcsr();
  test::TempDir dir;
  const Scene scene = test::loadSceneJson(dir, sceneFile("cornell-classic.json"));
  const RenderScene rs(scene);
  SensorBuffer buffer;
  PathStats stats;
  ASSERT_TRUE(renderUnit(rs, unitAt(0, 1, 1), buffer, stats));
  EXPECT_EQ(_mm_getcsr(), ieee);
  _mm_setcsr(before);
}
#endif

}  // namespace
}  // namespace lensfarm
