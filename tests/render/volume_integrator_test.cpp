// The volume path tracer (render/volume_integrator.h) against analytic answers: Beer-Lambert
// through an absorbing slab (also far from the origin and in a grid), the white furnace of an
// albedo-1 medium behind an index-matched boundary, the single-scattering integral of a thin slab
// under a sun (homogeneous and grid), the reflectance of a thick subsurface slab (the albedo
// inversion), determinism over thread counts, and the effect analysis that keeps media away from
// scenes without them.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <utility>

#include "common/medium/medium.h"
#include "common/render/render_scene.h"
#include "common/util/error.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// The 12 triangles of the box [lo, hi], facing outward.
json boxShape(const std::array<double, 3>& lo, const std::array<double, 3>& hi, const std::string& material) {
  json vertices = json::array(), indices = json::array();
  for (int c = 0; c < 8; ++c) vertices.push_back({c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1], c & 4 ? hi[2] : lo[2]});
  // Per face: four corners in counter-clockwise order seen from outside.
  const int faces[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (const auto& f : faces) {
    indices.push_back({f[0], f[1], f[2]});
    indices.push_back({f[0], f[2], f[3]});
  }
  return {{"type", "triangles"}, {"material", material}, {"vertices", vertices}, {"indices", indices}};
}

// A pinhole camera at `position` looking at `target` with a field of view of about 1 degree, so
// every pixel's ray makes nearly the same angle with the scene.
json narrowCamera(const std::array<double, 3>& position, const std::array<double, 3>& target) {
  return {{"type", "pinhole"}, {"position", position},  {"look_at", target},
          {"up", {0, 0, 1}},   {"sensor_width", 0.002}, {"focal_length", 0.1}};
}

json sceneWith(json camera, json media, json materials, json shapes, int resolution, uint64_t spp) {
  return {{"format", "lensfarm-scene/1"},
          {"camera", std::move(camera)},
          {"media", std::move(media)},
          {"materials", std::move(materials)},
          {"shapes", std::move(shapes)},
          {"render",
           {{"resolution", {resolution, resolution}},
            {"samples_per_pixel", spp},
            {"max_bounces", 1},
            {"seed", 3},
            {"russian_roulette", false}}}};
}

// An emitting quad of radiance 1 at y = -1 facing +y, seen from above through the box
// y in [0, thickness] of `medium` (x, z in [-50, 50]), `shift` added to every position.
json slabOverLight(const json& medium, double thickness, double shift) {
  const auto at = [&](double x, double y, double z) { return std::array<double, 3>{x + shift, y + shift, z + shift}; };
  json shapes = json::array({boxShape(at(-50, 0, -50), at(50, thickness, 50), "boundary"),
                             {{"type", "quad"},
                              {"material", "lamp"},
                              {"corner", at(-50, -1, -50)},
                              {"edge1", {0, 0, 100}},
                              {"edge2", {100, 0, 0}}}});
  json materials = {{"boundary", {{"type", "interface"}, {"interior_medium", "slab"}}},
                    {"lamp", {{"type", "emissive"}, {"radiance", 1.0}}}};
  return sceneWith(narrowCamera(at(0, 10, 0.001), at(0, 0, 0)), {{"slab", medium}}, materials, shapes, 8, 4);
}

TEST(VolumeTransmittance, AnAbsorbingSlabPassesExpMinusSigmaTDInEveryChannelAnywhereInTheWorld) {
  const double d = 0.7;
  const double sigma[3] = {0.5, 1.0, 2.0};
  for (double shift : {0.0, 1e6}) {
    test::TempDir dir;
    const json scene = slabOverLight({{"sigma_a", {sigma[0], sigma[1], sigma[2]}}}, d, shift);
    const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(r.mean[c], std::exp(-sigma[c] * d), 1e-3 * std::exp(-sigma[c] * d)) << shift;
  }
}

TEST(VolumeTransmittance, ASlabInsideASlabReturnsToItsExteriorMedium) {
  // Medium "outer" (sigma_a 0.5) fills y in [0, 1]; inside it "inner" (sigma_a 2) fills y in
  // [0.3, 0.6], bounded by an interface whose exterior_medium is "outer". Light from below crosses
  // 0.7 of outer and 0.3 of inner; without the exterior it would cross only 0.4 of outer.
  test::TempDir dir;
  json scene = slabOverLight({{"sigma_a", 0.5}}, 1.0, 0.0);
  scene["media"]["inner"] = {{"sigma_a", 2.0}};
  scene["materials"]["inner-boundary"] = {
      {"type", "interface"}, {"interior_medium", "inner"}, {"exterior_medium", "slab"}};
  scene["shapes"].push_back(boxShape({-40, 0.3, -40}, {40, 0.6, 40}, "inner-boundary"));
  const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
  const double expected = std::exp(-0.5 * 0.7 - 2.0 * 0.3);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.mean[c], expected, 1e-3 * expected);
}

TEST(VolumeTransmittance, KhrAttenuationColourIsWhatWhiteLightTurnsIntoAtTheAttenuationDistance) {
  // attenuation_color c at attenuation_distance D: a slab of thickness D passes exactly c.
  test::TempDir dir;
  const json scene = slabOverLight({{"attenuation_color", {0.9, 0.5, 0.1}}, {"attenuation_distance", 0.4}}, 0.4, 0.0);
  const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
  const double c[3] = {0.9, 0.5, 0.1};
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(r.mean[k], c[k], 1e-3 * c[k]);
}

TEST(VolumeTransmittance, AnAbsorbingGridIsRatioTrackedWithoutBiasAnywhereInTheWorld) {
  // A grid of density 1 everywhere with sigma_a: its ratio-tracking estimate is noisy but its mean
  // is Beer-Lambert's (a 2 x 2 x 2 grid whose majorant cells are mostly empty space besides).
  for (double shift : {0.0, 1e6}) {
    test::TempDir dir;
    const double d = 0.7;
    json grid = {{"type", "grid"},
                 {"bounds", {{-60 + shift, -0.5 + shift, -60 + shift}, {60 + shift, 0.35 + shift, 60 + shift}}},
                 {"resolution", {2, 2, 2}},
                 {"density", {1, 1, 1, 1, 1, 1, 1, 1}},
                 {"sigma_a", {0.5, 1.0, 2.0}}};
    json scene = slabOverLight(grid, d, shift);
    // The grid's box reaches to y = 0.35, half the slab: the other half is clear.
    scene["render"]["samples_per_pixel"] = 64;
    const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
    const double sigma[3] = {0.5, 1.0, 2.0};
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(r.mean[c], std::exp(-sigma[c] * 0.35), 0.01 * std::exp(-sigma[c] * 0.35)) << "shift " << shift;
  }
}

// Channel c's mean over the image and its standard error, from independent renders.
std::pair<double, double> imageMean(const test::ImageStatistics& st, int c) {
  const size_t pixels = st.mean.size() / 3;
  double mean = 0.0, variance = 0.0;
  for (size_t k = 0; k < pixels; ++k) mean += st.mean[3 * k + c] / double(pixels), variance += st.variance[3 * k + c];
  return {mean, std::sqrt(variance / double(st.renders)) / double(pixels)};
}

// A sphere of radius 1 (OBJ) with material `material`, under a uniform environment of radiance 1,
// seen whole by a camera outside it.
json sphereInEnvironment(const test::TempDir& dir, const json& materials, const json& media, int resolution,
                         uint64_t spp) {
  {
    std::ofstream obj(dir.path() / "sphere.obj");
    obj << test::sphereObj(24, 48);
  }
  json scene =
      sceneWith({{"type", "pinhole"},
                 {"position", {0, 0, -4}},
                 {"look_at", {0, 0, 0}},
                 {"up", {0, 1, 0}},
                 {"sensor_width", 0.06},
                 {"focal_length", 0.1}},
                media, materials, json::array({{{"type", "obj"}, {"file", "sphere.obj"}, {"material", "skin"}}}),
                resolution, spp);
  scene["environment"] = {{"radiance", 1.0}};
  scene["render"]["max_medium_bounces"] = 65536;
  return scene;
}

TEST(VolumeFurnace, AnAlbedoOneMediumBehindAnIndexMatchedOrAGlassBoundaryReturnsAllTheLight) {
  // Nothing absorbs: every path leaves the sphere sooner or later and sees the environment, so
  // every pixel is 1. With the naive estimator and a grey medium each path's weight is exactly 1
  // (free flight sigma_s T / (sigma_t T) = 1, phase sampling p / p = 1): any loss of energy at an
  // event, a crossing or the phase function shows in every pixel.
  // The same behind smooth glass (a glass of milk: Fresnel reflection and refraction, total
  // internal reflection inside, 1/eta^2 in and eta^2 out) loses nothing either.
  for (const json& boundary : {json{{"type", "interface"}, {"interior_medium", "cloud"}},
                               json{{"type", "dielectric"}, {"ior", 1.33}, {"interior_medium", "cloud"}}}) {
    for (double g : {0.0, 0.8, -0.5}) {
      test::TempDir dir;
      json scene = sphereInEnvironment(dir, {{"skin", boundary}}, {{"cloud", {{"sigma_s", 3.0}, {"g", g}}}}, 16, 4);
      scene["render"]["integrator"] = "naive";
      const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
      for (float v : r.image.rgb) {
        ASSERT_GE(v, 0.999f) << boundary << " g " << g;
        ASSERT_LE(v, 1.001f) << boundary << " g " << g;
      }
      EXPECT_EQ(r.stats.truncated, 0u);
    }
  }
}

TEST(VolumeFurnace, AChromaticMediumWithNextEventEstimationKeepsEveryChannelsEnergy) {
  // sigma_s differs per channel (spectral MIS weights differ from 1), light samples through the
  // medium (ratio of transmittance, MIS with the phase function): unbiased, so the mean is 1 in
  // each channel within its standard error.
  test::TempDir dir;
  json scene = sphereInEnvironment(dir, {{"skin", {{"type", "interface"}, {"interior_medium", "cloud"}}}},
                                   {{"cloud", {{"sigma_s", {0.5, 2.0, 6.0}}, {"g", 0.6}}}}, 24, 32);
  Scene loaded = test::loadSceneJson(dir, scene);
  const test::ImageStatistics st = test::renderStatistics(loaded, 8);
  for (int c = 0; c < 3; ++c) {
    const auto [mean, error] = imageMean(st, c);
    EXPECT_NEAR(mean, 1.0, 4.0 * error) << "channel " << c;
    EXPECT_LT(error, 0.004) << "channel " << c << ": too noisy to judge";
  }
}

// Single scattering in a slab y in [0, d] lit by a sun straight above (irradiance E), seen from
// the direction at angle theta to the normal: L = E p(theta) sigma_s (1 - exp(-sigma_t d (1 + mu)
// / mu)) / (sigma_t (1 + mu)), mu = cos(theta), p the HG phase function at the scattering angle
// between the sun's light (going down) and the view (going up): cos = -mu.
double singleScattering(double e, double g, double sigmaS, double sigmaT, double d, double mu) {
  const double cosScatter = -mu;
  const double p = (1 - g * g) / (4 * M_PI * std::pow(1 + g * g - 2 * g * cosScatter, 1.5));
  return e * p * sigmaS * (1 - std::exp(-sigmaT * d * (1 + mu) / mu)) / (sigmaT * (1 + mu));
}

json singleScatteringScene(const json& medium, double d, double theta) {
  json shapes = json::array({boxShape({-50, 0, -50}, {50, d, 50}, "boundary")});
  json materials = {{"boundary", {{"type", "interface"}, {"interior_medium", "slab"}}}};
  const std::array<double, 3> eye{10 * std::sin(theta), 10 * std::cos(theta), 0.001};
  json scene = sceneWith(narrowCamera(eye, {0, d / 2, 0}), {{"slab", medium}}, materials, shapes, 8, 256);
  scene["lights"] = json::array({{{"type", "directional"}, {"direction", {0, 1, 0}}, {"irradiance", 2.0}}});
  scene["render"]["max_medium_bounces"] = 1;
  return scene;
}

TEST(VolumeSingleScattering, AThinSlabUnderASunMatchesTheAnalyticIntegralPerChannel) {
  // Chromatic sigma_s (spectral MIS), one scattering event allowed, the sun's light sample
  // attenuated along its way down: the image is the integral above in each channel. The camera's
  // ray hits the slab's top at mid-height (d / 2 above the slab's centre is the target; the
  // narrow field keeps every pixel's angle within 0.6 degrees of theta).
  const double d = 0.2, g = 0.5, theta = 40.0 * M_PI / 180.0;
  const double sigmaS[3] = {0.2, 0.5, 1.0}, sigmaA = 0.25;
  for (const char* type : {"homogeneous", "grid"}) {
    test::TempDir dir;
    json medium = {{"sigma_s", {sigmaS[0], sigmaS[1], sigmaS[2]}}, {"sigma_a", sigmaA}, {"g", g}};
    if (std::string(type) == "grid") {
      // The same medium as a density grid (spectral tracking instead of closed-form free flight),
      // with density 2 and half the coefficients.
      medium = {{"type", "grid"},
                {"bounds", {{-60, -1, -60}, {60, 1, 60}}},
                {"resolution", {1, 1, 1}},
                {"density", {2.0}},
                {"sigma_s", {sigmaS[0] / 2, sigmaS[1] / 2, sigmaS[2] / 2}},
                {"sigma_a", sigmaA / 2},
                {"g", g}};
    }
    Scene loaded = test::loadSceneJson(dir, singleScatteringScene(medium, d, theta));
    const test::ImageStatistics st = test::renderStatistics(loaded, 6);
    for (int c = 0; c < 3; ++c) {
      const auto [mean, error] = imageMean(st, c);
      const double expected = singleScattering(2.0, g, sigmaS[c], sigmaS[c] + sigmaA, d, std::cos(theta));
      EXPECT_NEAR(mean, expected, 4.0 * error + 2e-3 * expected) << type << " channel " << c;
      EXPECT_LT(error, 0.01 * expected) << type << ": too noisy to judge";
    }
  }
}

TEST(Subsurface, AThickSlabShowsTheAlbedoItWasGiven) {
  // Under a uniform environment, the radiance leaving a thick random-walk slab is the fraction of
  // walks entering it (cosine-weighted, as the diffuse transmitter lets them in) that come back
  // out: the albedo A, by Chiang et al.'s inversion, which holds to 0.006 up to A = 0.8
  // (docs/media.md). Per channel, with mean free paths that differ.
  test::TempDir dir;
  const double albedo[3] = {0.3, 0.55, 0.8};
  json scene = sceneWith(narrowCamera({0, 10, 0.001}, {0, 0, 0}), json::object(),
                         {{"marble",
                           {{"type", "subsurface"},
                            {"albedo", {albedo[0], albedo[1], albedo[2]}},
                            {"mean_free_path", {0.02, 0.05, 0.1}}}}},
                         json::array({boxShape({-50, -50, -50}, {50, 0, 50}, "marble")}), 8, 64);
  scene.erase("media");
  scene["environment"] = {{"radiance", 1.0}};
  scene["render"]["max_medium_bounces"] = 65536;
  scene["render"]["max_bounces"] = 4;
  const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.mean[c], albedo[c], 0.02) << "channel " << c;
}

TEST(VolumePaths, AreTheSameBitsForAnyThreadCount) {
  test::TempDir dir;
  json scene =
      sphereInEnvironment(dir, {{"skin", {{"type", "dielectric"}, {"ior", 1.33}, {"interior_medium", "milk"}}}},
                          {{"milk",
                            {{"type", "grid"},
                             {"bounds", {{-1, -1, -1}, {1, 1, 1}}},
                             {"resolution", {2, 2, 2}},
                             {"density", {0, 1, 2, 3, 4, 5, 6, 7}},
                             {"sigma_s", {1, 2, 3}},
                             {"g", 0.7}}}},
                          12, 4);
  scene["medium"] = "fog";
  scene["media"]["fog"] = {{"sigma_s", 0.02}, {"sigma_a", 0.01}};
  const Scene loaded = test::loadSceneJson(dir, scene);
  const test::Rendered one = test::renderScene(loaded, 1), two = test::renderScene(loaded, 2);
  ASSERT_EQ(one.image.rgb.size(), two.image.rgb.size());
  EXPECT_EQ(0, std::memcmp(one.image.rgb.data(), two.image.rgb.data(), one.image.rgb.size() * sizeof(float)));
  EXPECT_GT(one.mean[0], 0.01);
}

TEST(VolumeEffects, AreOnOnlyWhereAPathCanBeInAMedium) {
  test::TempDir dir;
  const Scene plain = test::loadSceneJson(dir, test::minimalSceneJson());
  EXPECT_FALSE(RenderScene(plain).effects().media);
  EXPECT_FALSE(EffectSet::all(plain).media);

  json fog = test::minimalSceneJson();
  fog["media"] = {{"haze", {{"sigma_s", 0.1}}}};
  EXPECT_FALSE(RenderScene(test::loadSceneJson(dir, fog)).effects().media) << "a medium nothing uses";
  fog["medium"] = "haze";
  const RenderScene foggy(test::loadSceneJson(dir, fog));
  EXPECT_TRUE(foggy.effects().media);
  EXPECT_NE(foggy.effects().summary().find("haze"), std::string::npos) << foggy.effects().summary();
  EXPECT_FALSE(foggy.effects().lightTracing);
}

TEST(VolumeEffects, FogDimsTheMinimalSceneByItsTransmittance) {
  // A purely absorbing fog over the whole scene: the camera sees the lit quad (3 units away)
  // dimmed by at least exp(-sigma_a 3) and the light's path to it dimmed too.
  test::TempDir dir;
  json scene = test::minimalSceneJson();
  const double clear = test::renderScene(test::loadSceneJson(dir, scene)).mean[1];
  scene["media"] = {{"haze", {{"sigma_a", 0.2}}}};
  scene["medium"] = "haze";
  const double foggy = test::renderScene(test::loadSceneJson(dir, scene)).mean[1];
  EXPECT_LT(foggy, clear * std::exp(-0.2 * 3.0));
  EXPECT_GT(foggy, clear * std::exp(-0.2 * 8.0));
}

// One InputError whose message names the field.
void expectFieldError(const json& scene, const std::string& field) {
  test::TempDir dir;
  try {
    test::loadSceneJson(dir, scene);
    ADD_FAILURE() << "no error for " << field;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("scene.json"), std::string::npos) << e.what();
  }
}

// ---- equiangular sampling (render/volume_integrator.cpp) ---------------------------------------

// Single scattering of an isotropic point light of intensity I at distance D from a ray that
// starts `delta` before the point nearest the light, in a homogeneous medium (isotropic phase)
// that fills space, the ray escaping to infinity:
//     L = int_0^inf sigma_s / (4 pi) I exp(-sigma_t (t + r(t))) / r(t)^2 dt.
// With t = delta + D tan(theta) (dt = r^2 / D dtheta) the integrand is smooth in theta:
//     L = sigma_s I / (4 pi D) int_{atan(-delta / D)}^{pi / 2} exp(-sigma_t (t + r)) dtheta,
// integrated here by Simpson's rule (an answer independent of the tracer's sampling).
double pointLightInFog(double intensity, double sigmaS, double sigmaT, double delta, double d) {
  const double a = std::atan(-delta / d), b = M_PI / 2;
  const int n = 200000;
  const double h = (b - a) / n;
  const auto f = [&](double theta) {
    const double t = delta + d * std::tan(theta), r = d / std::cos(theta);
    return std::isfinite(t) ? std::exp(-sigmaT * (t + r)) : 0.0;
  };
  double sum = f(a) + f(b);
  for (int i = 1; i < n; ++i) sum += (i % 2 ? 4.0 : 2.0) * f(a + i * h);
  return sigmaS * intensity / (4 * M_PI * d) * sum * h / 3.0;
}

// A camera at `shift` (each axis) looking along +x through fog that fills the scene, a point
// light 2 along the ray and `d` off it, one scattering event allowed; a black quad behind the
// camera gives the caster a triangle. The field of view (1e-6 rad) keeps every pixel's ray
// within 2e-6 of the light's distance `d`.
json pointLightFogScene(double d, double shift, const std::string& sampling) {
  const auto at = [&](double x, double y, double z) { return std::array<double, 3>{x + shift, y + shift, z + shift}; };
  json camera = {{"type", "pinhole"}, {"position", at(0, 0, 0)}, {"look_at", at(1, 0, 0)},
                 {"up", {0, 0, 1}},   {"sensor_width", 1e-7},    {"focal_length", 0.1}};
  json scene = sceneWith(camera, {{"fog", {{"sigma_s", 0.3}, {"sigma_a", 0.1}}}},
                         {{"black", {{"type", "lambertian"}, {"albedo", 0.0}}}},
                         json::array({{{"type", "quad"},
                                       {"material", "black"},
                                       {"corner", at(-5, -1, -1)},
                                       {"edge1", {0, 2, 0}},
                                       {"edge2", {0, 0, 2}}}}),
                         4, 64);
  scene["medium"] = "fog";
  scene["lights"] = json::array({{{"type", "point"}, {"position", at(2, d, 0)}, {"intensity", 1.0}}});
  scene["render"]["max_medium_bounces"] = 1;
  scene["render"]["medium_light_sampling"] = sampling;
  return scene;
}

TEST(VolumeEquiangular, APointLightInFogMatchesTheSingleScatteringIntegralAtAnyDistanceAndPlace) {
  // From a light half a unit off the ray to one a thousandth off it (nearly on the camera ray,
  // where the in-scattered light peaks as 1 / D), at the origin and a million units away.
  for (const double d : {0.5, 1e-3}) {
    const double expected = pointLightInFog(1.0, 0.3, 0.4, 2.0, d);
    for (const double shift : {0.0, 1e6}) {
      test::TempDir dir;
      const test::ImageStatistics st =
          test::renderStatistics(test::loadSceneJson(dir, pointLightFogScene(d, shift, "auto")), 8);
      const auto [mean, error] = imageMean(st, 1);
      EXPECT_NEAR(mean, expected, 4.0 * error + 1e-3 * expected) << "D " << d << " shift " << shift;
      EXPECT_LT(error, 0.01 * expected) << "D " << d << " shift " << shift << ": too noisy";
    }
  }
}

TEST(VolumeEquiangular, FindsTheLightNearALightWithFarLessNoiseThanFreeFlightAlone) {
  // The same samples with free-flight sampling alone: the same answer, with a standard error many
  // times larger (the samples near the light are rare and weigh much). The ratio of errors at
  // equal samples is a property of the estimators, not of the machine.
  test::TempDir dir;
  const double expected = pointLightInFog(1.0, 0.3, 0.4, 2.0, 0.05);
  const test::ImageStatistics both =
      test::renderStatistics(test::loadSceneJson(dir, pointLightFogScene(0.05, 0, "auto")), 8);
  const test::ImageStatistics alone =
      test::renderStatistics(test::loadSceneJson(dir, pointLightFogScene(0.05, 0, "distance")), 8);
  const auto [m1, e1] = imageMean(both, 1);
  const auto [m2, e2] = imageMean(alone, 1);
  EXPECT_NEAR(m1, expected, 4.0 * e1 + 1e-3 * expected);
  EXPECT_NEAR(m2, expected, 4.0 * e2 + 1e-3 * expected);
  EXPECT_GT(e2, 5.0 * e1) << "equiangular " << e1 << ", free flight " << e2;
}

// A closed grey room (4 x 4 x 3) filled with fog, lit by a small emitting quad under its ceiling
// and a spot light, seen through its open front: multiple scattering and bounces off the walls.
json foggyRoom(const std::string& sampling, const std::string& integrator) {
  json shapes = json::array();
  const auto quad = [&](std::array<double, 3> corner, std::array<double, 3> e1, std::array<double, 3> e2,
                        const std::string& material) {
    shapes.push_back({{"type", "quad"}, {"material", material}, {"corner", corner}, {"edge1", e1}, {"edge2", e2}});
  };
  quad({-2, -2, 0}, {0, 4, 0}, {4, 0, 0}, "wall");             // floor, facing +z
  quad({-2, -2, 3}, {4, 0, 0}, {0, 4, 0}, "wall");             // ceiling, facing -z
  quad({-2, 2, 0}, {0, 0, 3}, {4, 0, 0}, "wall");              // back, facing -y
  quad({-2, -2, 0}, {0, 0, 3}, {0, 4, 0}, "wall");             // left, facing +x
  quad({2, -2, 0}, {0, 4, 0}, {0, 0, 3}, "wall");              // right, facing -x
  quad({-0.6, -0.6, 2.95}, {1.2, 0, 0}, {0, 1.2, 0}, "lamp");  // facing -z
  json scene = sceneWith(
      {{"type", "pinhole"},
       {"position", {0, -6, 1.5}},
       {"look_at", {0, 0, 1.5}},
       {"up", {0, 0, 1}},
       {"sensor_width", 0.036},
       {"focal_length", 0.035}},
      {{"fog", {{"sigma_s", {0.15, 0.2, 0.25}}, {"sigma_a", 0.02}, {"g", 0.3}}}},
      {{"wall", {{"type", "lambertian"}, {"albedo", 0.6}}}, {"lamp", {{"type", "emissive"}, {"radiance", 5.0}}}},
      shapes, 12, 64);
  scene["medium"] = "fog";
  scene["lights"] = json::array({{{"type", "spot"},
                                  {"position", {1.5, 1.5, 2.5}},
                                  {"look_at", {0, 0, 0}},
                                  {"intensity", 3.0},
                                  {"cone_angle", 30}}});
  scene["render"]["max_bounces"] = 3;
  scene["render"]["max_medium_bounces"] = 8;
  scene["render"]["integrator"] = integrator;
  scene["render"]["medium_light_sampling"] = sampling;
  return scene;
}

// Fog with single scattering under a 1 x 1 lamp 0.3 above the camera's rays: near a broad light
// the phase function's samples reach it about as often as light samples do, and equiangular
// samples peak there, so all three strategies carry weight (the case the weights must get right).
json fogUnderALamp(const std::string& sampling, const std::string& integrator) {
  json scene = sceneWith({{"type", "pinhole"},
                          {"position", {0, 0, 0}},
                          {"look_at", {1, 0, 0}},
                          {"up", {0, 0, 1}},
                          {"sensor_width", 0.01},
                          {"focal_length", 0.05}},
                         {{"fog", {{"sigma_s", {0.8, 1.0, 1.2}}, {"sigma_a", 0.1}, {"g", 0.2}}}},
                         {{"lamp", {{"type", "emissive"}, {"radiance", 1.0}}}},
                         json::array({{{"type", "quad"},
                                       {"material", "lamp"},
                                       {"corner", {1.0, -0.5, 0.3}},
                                       {"edge1", {0, 1, 0}},
                                       {"edge2", {1, 0, 0}}}}),
                         8, 256);
  scene["medium"] = "fog";
  scene["render"]["max_medium_bounces"] = 2;
  scene["render"]["integrator"] = integrator;
  scene["render"]["medium_light_sampling"] = sampling;
  return scene;
}

// The same image with and without equiangular sampling (unbiased weights), with NEE + MIS and
// with NEE alone.
void expectTheSameImageWithAndWithoutEquiangular(json (*scene)(const std::string&, const std::string&)) {
  for (const char* integrator : {"nee_mis", "nee"}) {
    SCOPED_TRACE(integrator);
    test::TempDir dir;
    const Scene with = test::loadSceneJson(dir, scene("auto", integrator));
    ASSERT_TRUE(RenderScene(with).effects().equiangular);
    const test::ImageStatistics a = test::renderStatistics(with, 16);
    const test::ImageStatistics b = test::renderStatistics(test::loadSceneJson(dir, scene("distance", integrator)), 16);
    test::expectSameImage(a, b);
  }
}

TEST(VolumeEquiangular, AFoggyRoomIsTheSameImageWithAndWithoutIt) {
  // Where everything meets: area and spot lights, several scattering events, bounces off walls.
  expectTheSameImageWithAndWithoutEquiangular(foggyRoom);
}

TEST(VolumeEquiangular, FogUnderABroadLampIsTheSameImageWithAndWithoutIt) {
  expectTheSameImageWithAndWithoutEquiangular(fogUnderALamp);
}

TEST(VolumeEquiangular, IsOnOnlyWhereItCanServe) {
  test::TempDir dir;
  const auto decision = [&](const json& scene) {
    const RenderScene rs(test::loadSceneJson(dir, scene));
    for (const EffectDecision& d : rs.effects().decisions)
      if (d.effect == "equiangular sampling") return std::string(d.simulated ? "on: " : "off: ") + d.reason;
    return std::string("not listed");
  };
  EXPECT_EQ(decision(test::minimalSceneJson()), "not listed") << "a scene without media";
  const json room = foggyRoom("auto", "nee_mis");
  EXPECT_NE(decision(room).find("on: in \"fog\""), std::string::npos) << decision(room);
  EXPECT_NE(decision(foggyRoom("distance", "nee_mis")).find("off: render.medium_light_sampling"), std::string::npos);
  json naive = room;
  naive["render"]["integrator"] = "naive";
  EXPECT_EQ(decision(naive).rfind("off", 0), 0u) << decision(naive);
  json grid = room;
  grid["media"]["fog"] = {{"type", "grid"},
                          {"bounds", {{-2, -2, 0}, {2, 2, 3}}},
                          {"resolution", {1, 1, 1}},
                          {"density", {1.0}},
                          {"sigma_s", 0.2}};
  EXPECT_NE(decision(grid).find("off: no homogeneous scattering medium"), std::string::npos) << decision(grid);
  json absorbing = room;
  absorbing["media"]["fog"] = {{"sigma_a", 0.2}};
  EXPECT_EQ(decision(absorbing).rfind("off", 0), 0u) << decision(absorbing);
  json sunOnly = room;
  sunOnly["materials"]["lamp"] = {{"type", "lambertian"}, {"albedo", 0.5}};
  sunOnly["lights"] = json::array({{{"type", "directional"}, {"direction", {0, 0, -1}}, {"irradiance", 1.0}}});
  EXPECT_NE(decision(sunOnly).find("off: no light at points"), std::string::npos) << decision(sunOnly);
  json bad = room;
  bad["render"]["medium_light_sampling"] = "sometimes";
  expectFieldError(bad, "render.medium_light_sampling");
}

TEST(VolumeInput, BadMediaAreRefusedNamingTheField) {
  json base = test::minimalSceneJson();
  base["media"] = {{"haze", {{"sigma_s", 0.1}}}};
  base["medium"] = "haze";
  const auto with = [&](const std::string& key, const json& value) {
    json s = base;
    s["media"]["haze"][key] = value;
    return s;
  };
  expectFieldError(with("sigma_a", -1.0), "media.haze.sigma_a");
  expectFieldError(with("sigma_s", {0.1, -0.2, 0.1}), "media.haze.sigma_s");
  expectFieldError(with("sigma_s", "thick"), "media.haze.sigma_s");
  expectFieldError(with("sigma_s", 1e38), "media.haze.sigma_s");  // sigma_t would overflow float
  {
    json s = base;
    s["media"]["haze"] = {{"attenuation_color", 0.5}, {"attenuation_distance", 1e-35}};
    expectFieldError(s, "media.haze.attenuation_distance");
  }
  expectFieldError(with("g", 1.0), "media.haze.g");
  expectFieldError(with("g", -1.5), "media.haze.g");
  expectFieldError(with("attenuation_color", 0.5), "media.haze.attenuation_color");  // with sigma_s
  expectFieldError(with("type", "smoke"), "media.haze.type");
  expectFieldError(with("thickness", 1.0), "media.haze.thickness");

  json s = base;
  s["medium"] = "mist";
  expectFieldError(s, "medium");
  s = base;
  s["materials"]["glass"] = {{"type", "interface"}};
  expectFieldError(s, "materials.glass.interior_medium");
  s["materials"]["glass"] = {{"type", "dielectric"}, {"ior", 1.5}, {"interior_medium", "nothing"}};
  expectFieldError(s, "materials.glass.interior_medium");
  s["materials"]["glass"] = {{"type", "subsurface"}, {"albedo", 0.5}};
  expectFieldError(s, "materials.glass.mean_free_path");
  s["materials"]["glass"] = {{"type", "subsurface"}, {"albedo", 1.5}, {"mean_free_path", 0.1}};
  expectFieldError(s, "materials.glass.albedo");
  s["materials"]["glass"] = {{"type", "subsurface"}, {"albedo", 0.5}, {"mean_free_path", 0.1}, {"g", 2}};
  expectFieldError(s, "materials.glass.g");
  s["materials"]["glass"] = {{"type", "lambertian"}, {"albedo", 0.5}, {"exterior_medium", "mist"}};
  expectFieldError(s, "materials.glass.exterior_medium");

  s = base;
  s["media"]["haze"] = {
      {"type", "grid"}, {"bounds", {{0, 0, 0}, {1, 1, 1}}}, {"resolution", {2, 2, 2}}, {"density", {1, 2, 3}}};
  expectFieldError(s, "media.haze.density");
  s["media"]["haze"]["density"] = {1, 1, 1, 1, 1, 1, 1, -1};
  expectFieldError(s, "media.haze.density[7]");
  s["media"]["haze"]["density"] = {1, 1, 1, 1, 1, 1, 1, 1};
  s["media"]["haze"]["bounds"] = {{0, 0, 0}, {1, 0, 1}};
  expectFieldError(s, "media.haze");
  s["media"]["haze"]["bounds"] = {{1e7, 1e7, 1e7}, {1e7 + 0.01, 1e7 + 0.01, 1e7 + 0.01}};
  EXPECT_NO_THROW(test::loadSceneJson(test::TempDir(), s)) << "a centimetre grid ten million units away is a box";
  s["media"]["haze"]["bounds"] = {{0, 0, 0}, {1, 1, 1}};
  s["media"]["haze"]["resolution"] = {2, 0, 2};
  expectFieldError(s, "media.haze.resolution[1]");
}

}  // namespace
}  // namespace lensfarm
