// AOVs (docs/aovs.md, film/aov_layout.h): each has its analytic value on a scene whose answer is
// known, the variance AOV agrees with a second estimator (the spread of independent renders),
// the beauty's bits do not change when AOVs are asked for, and bad names are refused by name.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/farm/memory_estimate.h"
#include "common/render/render_scene.h"
#include "common/render/unit_renderer.h"
#include "common/util/error.h"
#include "tests/render/aov_support.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;
using test::wallScene;

float layerAt(const Image& image, const std::string& layer, int x, int y, size_t c) {
  const ImageLayer* l = image.layer(layer);
  EXPECT_NE(l, nullptr) << layer;
  return l ? l->at(x, y, image.width, c) : std::numeric_limits<float>::quiet_NaN();
}

TEST(Aov, AWallsAlbedoNormalDepthAndIdsAreTheirAnalyticValues) {
  test::TempDir dir;
  const test::Rendered r = test::renderScene(
      test::loadSceneJson(dir, wallScene({"albedo", "normal", "depth", "samples", "object_id", "material_id"})));
  const Image& image = r.image;
  ASSERT_EQ(image.layers.size(), 6u);
  for (int y = 4; y <= 11; ++y)
    for (int x = 4; x <= 11; ++x) {
      for (size_t c = 0; c < 3; ++c) EXPECT_EQ(layerAt(image, "albedo", x, y, c), 0.5f) << x << "," << y;
      // The wall's normal is +-z; the side the camera sees is -z.
      EXPECT_EQ(layerAt(image, "normal", x, y, 0), 0.0f);
      EXPECT_EQ(layerAt(image, "normal", x, y, 1), 0.0f);
      EXPECT_EQ(layerAt(image, "normal", x, y, 2), -1.0f);
      // Planar depth: the wall is perpendicular to the axis, 3 from the camera, in every pixel.
      EXPECT_NEAR(layerAt(image, "", x, y, 0), 3.0f, 3e-6f) << x << "," << y;
      EXPECT_EQ(layerAt(image, "samples", x, y, 0), 8.0f);
      EXPECT_EQ(layerAt(image, "object_id", x, y, 0), 1.0f) << "the first mesh";
      EXPECT_EQ(layerAt(image, "material_id", x, y, 0), 1.0f) << "the first material";
    }
  // The corners see nothing: no albedo, no normal, infinite depth, id 0.
  for (const auto& [x, y] : {std::pair{0, 0}, std::pair{15, 15}, std::pair{0, 15}}) {
    EXPECT_EQ(layerAt(image, "albedo", x, y, 0), 0.0f);
    EXPECT_EQ(layerAt(image, "normal", x, y, 2), 0.0f);
    EXPECT_EQ(layerAt(image, "", x, y, 0), std::numeric_limits<float>::infinity());
    EXPECT_EQ(layerAt(image, "object_id", x, y, 0), 0.0f);
    EXPECT_EQ(layerAt(image, "material_id", x, y, 0), 0.0f);
    EXPECT_EQ(layerAt(image, "samples", x, y, 0), 8.0f);
  }
}

TEST(Aov, FarFromTheOriginAndAtAnyScaleTheAovsKeepTheirValues) {
  // The class of the first test: the same wall scaled by k and moved 1e7 away along every axis.
  // Depth scales with k (scene units); albedo, normal, ids and the sample count do not change.
  for (const double k : {1e-4, 1.0, 1e6}) {
    test::TempDir dir;
    json scene = wallScene({"albedo", "normal", "depth", "object_id"});
    const double shift = 1e7;
    const auto place = [&](json& p) {
      for (int a = 0; a < 3; ++a) p[a] = p[a].get<double>() * k + shift;
    };
    const auto stretch = [&](json& v) {
      for (int a = 0; a < 3; ++a) v[a] = v[a].get<double>() * k;
    };
    place(scene["camera"]["position"]);
    place(scene["camera"]["look_at"]);
    for (const char* length : {"sensor_width", "focal_length"})  // scene units too
      scene["camera"][length] = scene["camera"][length].get<double>() * k;
    for (json* shape : {&scene["shapes"][0], &scene["lights"][0]}) {
      place((*shape)["corner"]);
      stretch((*shape)["edge1"]);
      stretch((*shape)["edge2"]);
    }
    const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
    for (int y = 5; y <= 10; ++y)
      for (int x = 5; x <= 10; ++x) {
        EXPECT_EQ(layerAt(r.image, "albedo", x, y, 0), 0.5f) << "k = " << k;
        EXPECT_EQ(layerAt(r.image, "normal", x, y, 2), -1.0f) << "k = " << k;
        EXPECT_NEAR(layerAt(r.image, "", x, y, 0), 3.0 * k, 3.0 * k * 1e-5) << "k = " << k;
        EXPECT_EQ(layerAt(r.image, "object_id", x, y, 0), 1.0f) << "k = " << k;
      }
  }
}

TEST(Aov, ATiltedWallsDepthIsPlanarAndItsNormalIsItsOwn) {
  // A wall at z = 2 + 0.5 x: planar depth 5 + 0.5 x at each pixel centre's ray, normal
  // (-0.5, 0, 1)/|.| turned to the camera; the quad's other side must give the same.
  test::TempDir dir;
  json scene = wallScene({"normal", "depth"});
  scene["shapes"][0] = {
      {"type", "quad"}, {"corner", {-4, -4, 0}}, {"edge1", {0, 8, 0}}, {"edge2", {8, 0, 4}}, {"material", "white"}};
  scene["render"]["samples_per_pixel"] = 64;
  const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
  const float k = 1.0f / std::sqrt(1.25f);
  // The sensor's half-width over its distance behind the pinhole, which is f = 0.1.
  const double halfWidth = 0.05 / 0.1;
  // Which way image x runs along world X is the camera's business: take it from the first pixel.
  const double sign = layerAt(r.image, "", 2, 8, 0) < 5.0f ? 1.0 : -1.0;
  for (int x = 2; x < 14; ++x) {
    EXPECT_NEAR(layerAt(r.image, "normal", x, 8, 0), 0.5f * k, 1e-5f) << x;
    EXPECT_NEAR(layerAt(r.image, "normal", x, 8, 2), -k, 1e-5f) << x;
    // A ray of slope t = X / d meets z = 2 + 0.5 X (d = z + 3) at d = 5 / (1 - 0.5 t); the pixel
    // averages d over its width of slopes.
    const double t0 = (double(x) - 8.0) / 8.0 * halfWidth, t1 = (double(x) + 1.0 - 8.0) / 8.0 * halfWidth;
    double expected = 0.0;
    for (int i = 0; i < 1000; ++i)
      expected += 5.0 / (1.0 - 0.5 * sign * (t0 + (t1 - t0) * (i + 0.5) / 1000.0)) / 1000.0;
    EXPECT_NEAR(layerAt(r.image, "", x, 8, 0), expected, 0.002 * expected) << x;
  }
}

TEST(Aov, TheVarianceLayerAgreesWithTheSpreadOfIndependentRenders) {
  // Second estimator: the variance across 24 renders with independent seeds of each pixel's value.
  test::TempDir dir;
  json scene = wallScene({"variance"});
  scene["render"]["sampler"] = "independent";  // samples within a pixel independent, as the formula assumes
  Scene s = test::loadSceneJson(dir, scene);
  const int renders = 24;
  std::vector<double> sum, sumSq, aov;
  for (int k = 0; k < renders; ++k) {
    s.render.seed = 1000 + uint64_t(k);
    const test::Rendered r = test::renderScene(s);
    const ImageLayer* v = r.image.layer("variance");
    ASSERT_NE(v, nullptr);
    if (sum.empty())
      sum.assign(r.image.rgb.size(), 0.0), sumSq.assign(r.image.rgb.size(), 0.0), aov.assign(r.image.rgb.size(), 0.0);
    for (size_t i = 0; i < r.image.rgb.size(); ++i) {
      sum[i] += r.image.rgb[i];
      sumSq[i] += double(r.image.rgb[i]) * r.image.rgb[i];
      aov[i] += v->values[i] / renders;
    }
  }
  double spread = 0.0, estimated = 0.0;
  for (size_t i = 0; i < sum.size(); ++i) {
    const double m = sum[i] / renders;
    spread += (sumSq[i] - renders * m * m) / (renders - 1);
    estimated += aov[i];
  }
  ASSERT_GT(spread, 0.0);
  EXPECT_NEAR(estimated / spread, 1.0, 0.1) << "mean variance AOV " << estimated << " vs spread " << spread;
}

TEST(Aov, TheBeautyKeepsItsBitsWithAovs) {
  test::TempDir dir;
  json plain = test::bundledSceneJson("cornell-glass-metal.json");
  plain["render"]["resolution"] = {24, 24};
  plain["render"]["samples_per_pixel"] = 4;
  json withAovs = plain;
  withAovs["render"]["aovs"] = {"albedo", "normal", "depth", "variance", "samples", "object_id", "material_id"};
  const test::Rendered a = test::renderScene(test::loadSceneJson(dir, plain));
  const test::Rendered b = test::renderScene(test::loadSceneJson(dir, withAovs));
  EXPECT_TRUE(a.image.rgb == b.image.rgb);
  EXPECT_EQ(a.stats.rays, b.stats.rays) << "the AOV pass is not counted among the path tracer's rays";
  EXPECT_TRUE(a.image.layers.empty());
  EXPECT_EQ(b.image.layers.size(), 7u);
}

TEST(Aov, SameBitsForAnyThreadCount) {
  test::TempDir dir;
  json scene = test::bundledSceneJson("cornell-glass-metal.json");
  scene["render"]["resolution"] = {24, 24};
  scene["render"]["samples_per_pixel"] = 4;
  scene["render"]["aovs"] = {"albedo", "normal", "depth", "variance"};
  const Scene s = test::loadSceneJson(dir, scene);
  const test::Rendered one = test::renderScene(s, 1), two = test::renderScene(s, 2);
  ASSERT_EQ(one.image.layers.size(), two.image.layers.size());
  for (size_t l = 0; l < one.image.layers.size(); ++l)
    EXPECT_TRUE(one.image.layers[l].values == two.image.layers[l].values);
}

TEST(Aov, PacketsAndSingleRaysGiveTheSameSums) {
  // The pass casts its camera rays as 16-wide packets; the reference casts them one at a time.
  test::TempDir dir;
  json scene = test::bundledSceneJson("cornell-glass-metal.json");
  scene["render"]["resolution"] = {20, 20};
  scene["render"]["samples_per_pixel"] = 4;
  scene["render"]["aovs"] = {"albedo", "normal", "depth", "object_id", "material_id"};
  const Scene s = test::loadSceneJson(dir, scene);
  const RenderScene rs(s);
  SensorBuffer packets, single;
  PathStats stats;
  const WorkUnit unit = unitAt(0, 4, 4);
  ASSERT_TRUE(renderUnit(rs, unit, packets, stats, nullptr, RayGrouping::kPackets));
  ASSERT_TRUE(renderUnit(rs, unit, single, stats, nullptr, RayGrouping::kSingleRays));
  ASSERT_EQ(packets.channels, rs.aovLayout().channels);
  EXPECT_TRUE(packets.sums == single.sums);
  double albedo = 0.0;
  for (size_t c = 0; c < packets.cells(); ++c) albedo += packets.sums[c * size_t(packets.channels) + 3];
  EXPECT_GT(albedo, 0.0) << "the AOVs were summed";
}

TEST(Aov, AMirrorShowsTheAlbedoAndNormalOfWhatItReflects) {
  // A mirror facing the camera in front of... the camera sees the mirror; behind the camera a wall
  // of albedo 0.3 faces it: the mirror's pixels show albedo 0.3 (times the mirror's reflectance 1)
  // and the wall's normal, and the depth of the mirror.
  test::TempDir dir;
  json scene = wallScene({"albedo", "normal", "depth"});
  scene["materials"]["mirror"] = {{"type", "mirror"}};
  scene["materials"]["grey"] = {{"type", "lambertian"}, {"albedo", 0.3}};
  scene["shapes"][0]["material"] = "mirror";
  scene["lights"][0]["corner"] = {-0.5, 3, -1};  // out of the mirror's view of the middle row
  scene["shapes"].push_back({{"type", "quad"},
                             {"corner", {-10, -10, -6}},
                             {"edge1", {20, 0, 0}},
                             {"edge2", {0, 20, 0}},
                             {"material", "grey"}});
  const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
  for (int x = 5; x <= 10; ++x) {
    EXPECT_NEAR(layerAt(r.image, "albedo", x, 8, 1), 0.3f, 1e-6f) << x;
    EXPECT_NEAR(layerAt(r.image, "normal", x, 8, 2), 1.0f, 1e-6f) << "the far wall faces +z, towards the mirror";
    EXPECT_NEAR(layerAt(r.image, "", x, 8, 0), 3.0f, 3e-6f) << "depth is the mirror's";
  }
}

TEST(Aov, TheSampleCountAloneIsALayerToo) {
  test::TempDir dir;
  const test::Rendered r = test::renderScene(test::loadSceneJson(dir, wallScene({"samples"})));
  ASSERT_EQ(r.image.layers.size(), 1u);
  EXPECT_EQ(layerAt(r.image, "samples", 3, 3, 0), 8.0f);
}

TEST(Aov, MemoryEstimatesCountTheAovs) {
  // A job's admission (farm/memory_estimate.h) must see the AOVs' sums and layers: every AOV
  // takes 13 more sums and 13 more floats a cell.
  test::TempDir dir;
  Scene plain = test::loadSceneJson(dir, wallScene({}));
  plain.render.width = plain.render.height = 1000;
  Scene all = plain;
  for (int k = 0; k < kAovCount; ++k) all.render.aovs.add(Aov(k));
  const uint64_t cells = 1000 * 1000;
  EXPECT_GE(localRenderMemory(all.render, 2, 0).total(),
            localRenderMemory(plain.render, 2, 0).total() + cells * 13 * 16);
  EXPECT_GE(workerJobMemory(all.render, 2, 0).total(), workerJobMemory(plain.render, 2, 0).total() + cells * 13 * 8);
  EXPECT_GE(coordinatorJobMemory(all.render, uint64_t(1) << 30, true, 0).total(),
            coordinatorJobMemory(plain.render, uint64_t(1) << 30, true, 0).total() + cells * 13 * 16);
}

TEST(Aov, UnknownNamesAreRefusedNamingTheFieldAndTheName) {
  test::TempDir dir;
  json scene = wallScene({"albedo", "normals"});
  try {
    test::loadSceneJson(dir, scene);
    FAIL() << "an unknown AOV loaded";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("render.aovs"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("\"normals\""), std::string::npos) << e.what();
  }
  scene["render"]["aovs"] = 3;
  EXPECT_THROW(test::loadSceneJson(dir, scene), InputError);
  scene["render"]["aovs"] = "albedo, depth";
  EXPECT_EQ(test::loadSceneJson(dir, scene).render.aovs, ([] {
              AovSet s;
              s.add(Aov::kAlbedo);
              s.add(Aov::kDepth);
              return s;
            })());
}

}  // namespace
}  // namespace lensfarm
