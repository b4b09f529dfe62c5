// Polished metal (material "conductor"): the Fresnel term against the complex-index Fresnel
// equations, the mirror direction, and the reflectance a camera sees at normal incidence.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>

#include "common/material/conductor.h"
#include "common/material/fresnel.h"
#include "common/material/material.h"
#include "common/util/error.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// Fresnel's equations with a complex index n = eta + i k (Born & Wolf §14.2), in double: the
// amplitude reflection coefficients computed directly, independent of the real-arithmetic
// rearrangement the renderer uses.
double fresnelComplex(double cosI, double eta, double k) {
  using C = std::complex<double>;
  const C n(eta, k);
  const double sin2 = 1.0 - cosI * cosI;
  const C cosT = std::sqrt(C(1.0) - C(sin2) / (n * n));
  const C rs = (C(cosI) - n * cosT) / (C(cosI) + n * cosT);
  const C rp = (n * C(cosI) - cosT) / (n * C(cosI) + cosT);
  return 0.5 * (std::norm(rs) + std::norm(rp));
}

TEST(Conductor, FresnelMatchesTheComplexIndexEquations) {
  const double metals[][2] = {{0.143, 3.983}, {0.155, 4.828}, {1.102, 2.142}, {1.657, 9.224}, {0.5, 0.5}, {3.0, 0.01}};
  for (const auto& m : metals)
    for (int deg = 0; deg < 90; ++deg) {
      const double c = std::cos(deg * M_PI / 180.0);
      EXPECT_NEAR(fresnelConductor(float(c), float(m[0]), float(m[1])), fresnelComplex(c, m[0], m[1]), 2e-5)
          << "eta " << m[0] << " k " << m[1] << " at " << deg;
    }
  // Normal incidence: ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2); grazing: 1.
  EXPECT_NEAR(fresnelConductor(1.0f, 0.2f, 3.9f), (0.64 + 3.9 * 3.9) / (1.44 + 3.9 * 3.9), 1e-6);
  EXPECT_NEAR(fresnelConductor(1e-4f, 0.2f, 3.9f), 1.0f, 1e-3f);
}

TEST(Conductor, ReflectsIntoTheMirrorDirectionWeightedByFresnel) {
  const Spectrum eta(0.143f, 0.374f, 1.442f), k(3.983f, 2.385f, 1.603f);
  const Material gold("gold", std::make_shared<ConductorBsdf>(eta, k, Spectrum(1.0f)));
  const Vec3 n(0, 0, 1), wo = glm::normalize(Vec3(0.6f, 0.0f, 0.8f));
  const auto s = gold.sample(n, wo, 0.5f, Vec2(0.3f, 0.7f));
  ASSERT_TRUE(s && s->specular);
  EXPECT_NEAR(s->wi.x, -wo.x, 1e-6f);
  EXPECT_NEAR(s->wi.z, wo.z, 1e-6f);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(s->weight[c], fresnelComplex(0.8, eta[c], k[c]), 2e-5);
  EXPECT_GT(s->weight.r, s->weight.b) << "gold reflects red more than blue";
}

TEST(Conductor, ACameraFacingAMetalSphereInAUniformFieldSeesF0) {
  // Walls that only emit 1; the pixel at the image centre sees the sphere at normal incidence and
  // the wall behind the camera in its reflection: F0 per channel.
  test::TempDir dir;
  dir.write("sphere.obj", test::sphereObj(48, 96));
  json scene = test::closedBoxSceneJson({{"type", "emissive"}, {"radiance", 1.0}}, 33, 4, 1);
  scene["materials"]["metal"] = {{"type", "conductor"}, {"metal", "Cu"}};
  scene["shapes"].push_back({{"type", "obj"},
                             {"file", "sphere.obj"},
                             {"material", "metal"},
                             {"transform", {{"scale", 0.4}, {"translate", {0, 0, 0.6}}}}});
  scene["camera"]["angle_of_view"] = 2;
  scene["camera"]["sensor_width"] = 0.01;
  const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
  const size_t centre = (16 * 33 + 16) * 3;
  const double eta[3] = {0.200, 0.924, 1.102}, k[3] = {3.912, 2.452, 2.142};
  for (int c = 0; c < 3; ++c) {
    const double f0 = ((eta[c] - 1) * (eta[c] - 1) + k[c] * k[c]) / ((eta[c] + 1) * (eta[c] + 1) + k[c] * k[c]);
    EXPECT_NEAR(r.image.rgb[centre + c], f0, 2e-3) << "channel " << c;
  }
}

TEST(Conductor, MetalIsNamedOrGivenByEtaAndKAndMistakesAreNamed) {
  test::TempDir dir;
  json scene = test::minimalSceneJson();
  for (const json& bad :
       {json{{"type", "conductor"}}, json{{"type", "conductor"}, {"metal", "Pt"}},
        json{{"type", "conductor"}, {"metal", "Au"}, {"eta", 1.0}, {"k", 2.0}},
        json{{"type", "conductor"}, {"eta", 0.0}, {"k", 2.0}}, json{{"type", "conductor"}, {"eta", 1.0}, {"k", 1e3}}}) {
    scene["materials"]["white"] = bad;
    try {
      test::loadSceneJson(dir, scene);
      ADD_FAILURE() << bad.dump() << " was accepted";
    } catch (const InputError& e) {
      EXPECT_TRUE(test::contains(e.what(), "materials.white.")) << e.what();
    }
  }
  scene["materials"]["white"] = {
      {"type", "conductor"}, {"eta", {0.2, 0.9, 1.1}}, {"k", {3.9, 2.5, 2.1}}, {"tint", 0.9}};
  const Scene s = test::loadSceneJson(dir, scene);
  EXPECT_STREQ(s.materials[0].traits().effect, "metal");
  EXPECT_TRUE(s.materials[0].isSpecular());
}

}  // namespace
}  // namespace lensfarm
