// Shading normals, normal maps, textures and cut-outs (render/shading_point.h), each against an
// analytic value: a Lambertian surface of albedo a under a directional light of irradiance E
// from direction l has radiance a E max(0, n.l) / pi for its shading normal n (and 0 where the
// light is below the geometric surface), and under a uniform environment of radiance 1 with
// nothing around it, radiance a.
#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "common/material/material.h"
#include "common/material/principled.h"
#include "common/math/sampling.h"
#include "common/render/render_scene.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

constexpr int kSide = 96;  // the quad [-1, 1]^2 at distance 3 covers pixels [16, 80) on each axis

// A pinhole camera at z = -3 looking along +z at a quad [-1, 1]^2 in the plane z = 0, facing
// the camera, lit as `lighting` says (extra top-level fields: "lights", "environment").
json quadScene(const json& lighting, uint64_t spp = 16) {
  json scene = {
      {"format", "lensfarm-scene/1"},
      {"camera",
       {{"type", "pinhole"},
        {"position", {0, 0, -3}},
        {"look_at", {0, 0, 0}},
        {"sensor_width", 0.1},
        {"focal_length", 0.1}}},
      {"materials", {{"white", {{"type", "lambertian"}, {"albedo", 0.5}}}}},
      {"shapes",
       {{{"type", "quad"},
         {"corner", {-1, -1, 0}},
         {"edge1", {0, 2, 0}},
         {"edge2", {2, 0, 0}},
         {"material", "white"}}}},
      {"render", {{"resolution", {kSide, kSide}}, {"samples_per_pixel", spp}, {"max_bounces", 1}, {"seed", 3}}}};
  for (auto it = lighting.begin(); it != lighting.end(); ++it) scene[it.key()] = it.value();
  return scene;
}

// The quad's vertices are corner, corner + edge1, corner + edge1 + edge2, corner + edge2: world
// (-1,-1), (-1,1), (1,1), (1,-1). The camera's image has +y up and -x to the right, so the image's
// top-left is world (1, 1). Texture coordinates that put the texture upright in the image:
// (0, 0) at the top-left (texture/texture.h).
void setUprightUv(TriangleMesh& mesh) { mesh.uv[0] = {Vec2(1, 1), Vec2(1, 0), Vec2(0, 0), Vec2(0, 1)}; }

// The mean radiance over image pixels [x0, x1) x [y0, y1).
Spectrum meanOver(const Image& image, int x0, int y0, int x1, int y1) {
  Spectrum sum(0.0f);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) sum += image.at(x, y);
  return sum / float((x1 - x0) * (y1 - y0));
}

std::shared_ptr<Texture> uniformTexture(const Vec4& value, const std::string& name = "uniform") {
  RgbaImage image;
  image.width = image.height = 1;
  image.texels = {value.r, value.g, value.b, value.a};
  return std::make_shared<Texture>(name, image);
}

// A diffuse (specular 0, metallic 0) textured material of base colour `base`.
MaterialTextures diffuseTextures(const Spectrum& base) {
  MaterialTextures t;
  t.factors.baseColor = base;
  t.factors.metallic = 0.0f;
  t.factors.specular = 0.0f;
  return t;
}

TEST(Shading, ATexturedQuadShowsEachTexelsColour) {
  test::TempDir dir;
  Scene scene = test::loadSceneJson(dir, quadScene({{"environment", {{"radiance", 1}}}}, 64));
  // A 4x4 texture, every texel a different colour; nearest filtering, so that every sample of a
  // pixel inside a texel reads that texel.
  RgbaImage image;
  image.width = image.height = 4;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x)
      image.texels.insert(image.texels.end(),
                          {0.1f + 0.2f * float(x), 0.1f + 0.2f * float(y), 0.05f * float(x + y), 1.0f});
  MaterialTextures t = diffuseTextures(Spectrum(1.0f));
  t.baseColor.texture =
      std::make_shared<Texture>("checker", image, Wrap::kRepeat, Wrap::kRepeat, TextureFilter::kNearest);
  scene.materials[0] = Material::textured("textured", std::make_shared<MaterialTextures>(t));
  setUprightUv(scene.meshes[0]);
  const test::Rendered r = test::renderScene(scene);
  // Texel (x, y) covers image pixels [16 + 16x, 32 + 16x) x [16 + 16y, 32 + 16y); its central
  // 8x8 pixels see only that texel. A surface of albedo a under radiance 1 from its whole
  // hemisphere reflects a.
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      const Spectrum seen = meanOver(r.image, 20 + 16 * x, 20 + 16 * y, 28 + 16 * x, 28 + 16 * y);
      const Vec4 texel = image.at(x, y);
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(seen[c], texel[c], 0.01 + 0.01 * texel[c]) << "texel (" << x << ", " << y << ") channel " << c;
    }
}

// A directional light of irradiance pi from direction `toLight`: a Lambertian surface of albedo a
// facing it has radiance a.
json sun(const Vec3& toLight) {
  return {
      {"lights", {{{"type", "directional"}, {"direction", {toLight.x, toLight.y, toLight.z}}, {"irradiance", kPi}}}}};
}

// The quad's radiance (mean over its central pixels) with vertex normals all `normal`.
float radianceWithNormals(const Vec3& toLight, const Vec3& normal) {
  test::TempDir dir;
  Scene scene = test::loadSceneJson(dir, quadScene(sun(toLight), 4));
  scene.meshes[0].normals.assign(4, glm::normalize(normal));
  return meanOver(test::renderScene(scene).image, 32, 32, 64, 64).g;
}

TEST(Shading, VertexNormalsShadeAsTheirDirectionSays) {
  // The quad faces -z (towards the camera). Normals tilted 30 degrees towards -x.
  const Vec3 tilted(-std::sin(glm::radians(30.0f)), 0.0f, -std::cos(glm::radians(30.0f)));
  // Light from along the shading normal: a E / pi * 1 = 0.5, where the geometric normal gives 0.5 cos 30.
  EXPECT_NEAR(radianceWithNormals(tilted, tilted), 0.5f, 1e-3f);
  // From the geometric normal: cos 30 of the shading normal.
  EXPECT_NEAR(radianceWithNormals(Vec3(0, 0, -1), tilted), 0.5f * std::cos(glm::radians(30.0f)), 1e-3f);
  // From 60 degrees the other way: 90 degrees from the shading normal, no light.
  const Vec3 away(std::sin(glm::radians(60.0f)), 0.0f, -std::cos(glm::radians(60.0f)));
  EXPECT_NEAR(radianceWithNormals(away, tilted), 0.0f, 1e-4f);
}

TEST(Shading, NoLightLeaksThroughTheGeometricSurface) {
  // Light from behind the quad (100 degrees from its geometric normal) but 70 degrees from a
  // shading normal tilted 30 degrees towards it: a leak would give 0.5 cos 70 = 0.17.
  const Vec3 tilted(std::sin(glm::radians(30.0f)), 0.0f, -std::cos(glm::radians(30.0f)));
  const Vec3 behind(std::sin(glm::radians(100.0f)), 0.0f, -std::cos(glm::radians(100.0f)));
  EXPECT_EQ(radianceWithNormals(behind, tilted), 0.0f);
  // A shading normal pointing into the surface is replaced by the geometric one.
  EXPECT_NEAR(radianceWithNormals(Vec3(0, 0, -1), Vec3(0, 0, 1)), 0.5f, 1e-3f);
}

// The quad's radiance under a light from `toLight` with a constant tangent-space normal map of
// normal `mapped` (upright uv: u grows to the image's right, world -x; v grows downwards, world -y).
float radianceWithNormalMap(const Vec3& toLight, const Vec3& mapped) {
  test::TempDir dir;
  Scene scene = test::loadSceneJson(dir, quadScene(sun(toLight), 4));
  MaterialTextures t = diffuseTextures(Spectrum(0.5f));
  const Vec3 encoded = 0.5f * (glm::normalize(mapped) + 1.0f);
  t.normal.texture = uniformTexture(Vec4(encoded, 1.0f), "normal map");
  scene.materials[0] = Material::textured("mapped", std::make_shared<MaterialTextures>(t));
  setUprightUv(scene.meshes[0]);
  return meanOver(test::renderScene(scene).image, 32, 32, 64, 64).g;
}

TEST(Shading, NormalMapsTiltAlongTheTangentFrame) {
  const float s = std::sin(glm::radians(30.0f)), c = std::cos(glm::radians(30.0f));
  // Tangent space (x, y, z) = (+u, up in the image, outwards). +u is world -x, the image's up is
  // world +y, outwards is world -z. A map tilted 30 degrees towards +u, lit from that direction:
  EXPECT_NEAR(radianceWithNormalMap(Vec3(-s, 0, -c), Vec3(s, 0, c)), 0.5f, 2e-3f);
  // ... and lit from 30 degrees the other way: cos 60.
  EXPECT_NEAR(radianceWithNormalMap(Vec3(s, 0, -c), Vec3(s, 0, c)), 0.25f, 2e-3f);
  // Green up: tilted towards the image's up (world +y), lit from there.
  EXPECT_NEAR(radianceWithNormalMap(Vec3(0, s, -c), Vec3(0, s, c)), 0.5f, 2e-3f);
  EXPECT_NEAR(radianceWithNormalMap(Vec3(0, -s, -c), Vec3(0, s, c)), 0.25f, 2e-3f);
}

TEST(Shading, AlphaMaskCutsTheSurfaceOutForEveryRay) {
  // Left half of the texture (u < 0.5: the image's left) transparent, right half opaque; behind
  // the quad a second, black quad... seen through the hole: the environment behind (radiance 1)
  // reaches the camera straight through.
  test::TempDir dir;
  Scene scene = test::loadSceneJson(dir, quadScene({{"environment", {{"radiance", 1}}}}, 16));
  RgbaImage image;
  image.width = 2, image.height = 1;
  image.texels = {1, 1, 1, 0, 1, 1, 1, 1};
  MaterialTextures t = diffuseTextures(Spectrum(0.25f));
  t.baseColor.texture =
      std::make_shared<Texture>("cut-out", image, Wrap::kClampToEdge, Wrap::kClampToEdge, TextureFilter::kNearest);
  t.alphaMode = AlphaMode::kMask;
  scene.materials[0] = Material::textured("leaf", std::make_shared<MaterialTextures>(t));
  setUprightUv(scene.meshes[0]);
  const test::Rendered r = test::renderScene(scene);
  // Through the hole: the environment, 1. On the opaque half: albedo 0.25 under radiance 1 from
  // its hemisphere, 0.25.
  EXPECT_NEAR(meanOver(r.image, 20, 20, 44, 76).g, 1.0f, 1e-4f);
  EXPECT_NEAR(meanOver(r.image, 52, 20, 76, 76).g, 0.25f, 5e-3f);
}

// Adds a quad lamp (material "lamp", emission 1) at corner with edges e1, e2 to a quadScene, facing
// down (-y) over the lit quad.
void addLamp(json& scene, const std::array<double, 3>& corner, const std::array<double, 3>& e1,
             const std::array<double, 3>& e2) {
  scene["materials"]["lamp"] = {{"type", "emissive"}, {"radiance", 1}};
  scene["shapes"].push_back({{"type", "quad"}, {"corner", corner}, {"edge1", e1}, {"edge2", e2}, {"material", "lamp"}});
}

// The lamp's material index in the loaded scene; its quad gets the unit square's texture coordinates.
size_t prepareLamp(Scene& s) {
  size_t lamp = 0;
  while (s.materials[lamp].name != "lamp") ++lamp;
  for (TriangleMesh& mesh : s.meshes)
    if (mesh.materialIds[0] == lamp) mesh.uv[0] = {Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(0, 1)};
  return lamp;
}

TEST(Shading, AnEmissiveTextureIsSeenAndLightsTheSceneUnbiased) {
  // An emitter textured with a uniform 0.5 and one of emission 0.5 without texture light a
  // diffuse quad alike.
  const auto render = [](bool textured) {
    test::TempDir dir;
    json scene = quadScene({}, 64);
    addLamp(scene, {-2, 1.5, -2}, {4, 0, 0}, {0, 0, 3});
    Scene s = test::loadSceneJson(dir, scene);
    const size_t lamp = prepareLamp(s);
    if (textured) {
      MaterialTextures t = diffuseTextures(Spectrum(0.0f));
      t.emissive.texture = uniformTexture(Vec4(0.5f, 0.5f, 0.5f, 1.0f));
      s.materials[lamp] = Material::textured("lamp", std::make_shared<MaterialTextures>(t), Spectrum(1.0f));
    } else {
      s.materials[lamp] = Material("lamp", nullptr, Spectrum(0.5f));
    }
    return meanOver(test::renderScene(s).image, 24, 24, 72, 72).g;
  };
  const float plain = render(false), textured = render(true);
  ASSERT_GT(plain, 0.01f);
  EXPECT_NEAR(textured, plain, 0.03f * plain);
}

// The diffuse quad lit by a 1 x 1 lamp above it whose emissive texture is a 2 x 2 checker of
// `bright` and black texels (linear filtering between them), or black everywhere; `settings`
// edits render settings. `mirror`: a mirror floor below, for caustics light tracing counts.
Scene checkerLampScene(const test::TempDir& dir, float bright, const json& settings, bool mirror = false) {
  json scene = quadScene({}, 16);
  addLamp(scene, {-0.5, 1.5, -1}, {1, 0, 0}, {0, 0, 1});
  if (mirror) {
    scene["materials"]["mirror"] = {{"type", "mirror"}};
    scene["shapes"].push_back({{"type", "quad"},
                               {"corner", {-2, -1.5, -2}},
                               {"edge1", {0, 0, 2}},
                               {"edge2", {4, 0, 0}},
                               {"material", "mirror"}});
  }
  scene["render"]["resolution"] = {24, 24};
  for (auto it = settings.begin(); it != settings.end(); ++it) scene["render"][it.key()] = it.value();
  Scene s = test::loadSceneJson(dir, scene);
  const size_t lamp = prepareLamp(s);
  RgbaImage checker;
  checker.width = checker.height = 2;
  checker.texels = {bright, bright, bright, 1, 0, 0, 0, 1, 0, 0, 0, 1, bright, bright, bright, 1};
  MaterialTextures t = diffuseTextures(Spectrum(0.0f));
  t.emissive.texture = std::make_shared<Texture>("checker", checker);
  s.materials[lamp] = Material::textured("lamp", std::make_shared<MaterialTextures>(t), Spectrum(1.0f));
  return s;
}

TEST(Shading, AnEmissiveTextureIsLightSampledByItsPowerWithoutBias) {
  // Light samples take the texture's value at their point and weigh against the rays that hit
  // it by the triangle's density: the same image mean as the naive estimator (rays alone, an
  // independent answer; heavy-tailed per pixel with a small light), with a standard error
  // several times smaller.
  test::TempDir dir;
  const Scene sampled = checkerLampScene(dir, 16.0f, json::object());
  const RenderScene rs(sampled);
  ASSERT_EQ(rs.lights().triangleLights().size(), 2u) << "both triangles of the textured lamp are light-sampled";
  const test::ImageStatistics nee = test::renderStatistics(sampled, 16);
  const test::ImageStatistics naive =
      test::renderStatistics(checkerLampScene(dir, 16.0f, {{"integrator", "naive"}}), 16);
  EXPECT_GT(nee.imageMean, 0.05);
  EXPECT_NEAR(nee.imageMean, naive.imageMean, 4.0 * std::hypot(nee.imageMeanError, naive.imageMeanError));
  // At equal samples (measured: 4.2x; before the texture was light-sampled, the rays alone).
  EXPECT_GT(naive.imageMeanError, 3.0 * nee.imageMeanError) << "light samples find the lamp";
  // The light tracer emits from it with the texture too: with a mirror floor (light -> mirror ->
  // quad -> camera, the light tracer's paths when it is on), the same image with light paths.
  const Scene traced = checkerLampScene(dir, 16.0f, {{"light_tracing", "on"}, {"tile_size", "off"}}, true);
  ASSERT_TRUE(RenderScene(traced).effects().lightTracing);
  test::expectSameImage(test::renderStatistics(checkerLampScene(dir, 16.0f, json::object(), true), 16),
                        test::renderStatistics(traced, 16));
  // A texture black at every lookup: not sampled (a ray that reaches it counts it, weight 1).
  EXPECT_TRUE(RenderScene(checkerLampScene(dir, 0.0f, json::object())).lights().empty());
}

TEST(Principled, SpecularZeroWithoutMetalIsLambertian) {
  PrincipledParams p;
  p.baseColor = Spectrum(0.2f, 0.5f, 0.7f);
  p.metallic = 0.0f;
  p.roughness = 0.3f;
  p.specular = 0.0f;
  const PrincipledBsdf bsdf(p);
  const Vec3 n(0, 0, 1), wo = glm::normalize(Vec3(0.3f, 0.1f, 0.9f));
  for (const Vec3& wi :
       {Vec3(0, 0, 1), glm::normalize(Vec3(-0.3f, -0.1f, 0.9f)), glm::normalize(Vec3(0.9f, 0, 0.2f))}) {
    const Spectrum f = bsdf.evalCos(n, wo, wi, true);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(f[c], p.baseColor[c] * wi.z / kPi, 1e-6f);
  }
}

}  // namespace
}  // namespace lensfarm
