// Smooth glass (material "dielectric"): Fresnel against Fresnel's own sine and tangent laws,
// Snell's law and total internal reflection, and the radiance a glass object shows in a uniform
// field (exactly the field's, which needs the 1/eta^2 of refraction).
#include <gtest/gtest.h>

#include <cmath>

#include "common/material/dielectric.h"
#include "common/material/fresnel.h"
#include "common/material/material.h"
#include "common/scene/effects.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// Fresnel's equations in their sine / tangent form (Born & Wolf 1.5 (21a)), in double: an
// expression independent of the cosine form the renderer uses.
double fresnelBySines(double thetaI, double eta) {
  const double sinT = std::sin(thetaI) / eta;
  if (sinT >= 1.0) return 1.0;
  const double thetaT = std::asin(sinT);
  if (thetaI == 0.0) return std::pow((eta - 1) / (eta + 1), 2);
  const double rs = -std::sin(thetaI - thetaT) / std::sin(thetaI + thetaT);
  const double rp = std::tan(thetaI - thetaT) / std::tan(thetaI + thetaT);
  return 0.5 * (rs * rs + rp * rp);
}

TEST(Dielectric, FresnelMatchesTheSineAndTangentLawsAndReflectsTotallyBeyondTheCriticalAngle) {
  for (double eta : {1.5, 1.0 / 1.5, 2.42, 1.0 / 2.42, 1.0001})
    for (int k = 0; k < 90; ++k) {
      const double theta = k * M_PI / 180.0;
      float cosT;
      const float f = fresnelDielectric(float(std::cos(theta)), float(eta), cosT);
      EXPECT_NEAR(f, fresnelBySines(theta, eta), 2e-5) << "eta " << eta << " at " << k << " degrees";
      if (eta < 1 && std::sin(theta) > eta) {
        EXPECT_EQ(f, 1.0f) << "total internal reflection at " << k;
      }
    }
  float cosT;
  EXPECT_NEAR(fresnelDielectric(1.0f, 1.5f, cosT), 0.04f, 1e-7f);  // ((1.5 - 1) / (1.5 + 1))^2
  EXPECT_NEAR(fresnelDielectric(0.3f, 1.0f, cosT), 0.0f, 1e-12f);  // index-matched: invisible
}

TEST(Dielectric, RefractsBySnellsLawAndReflectsWithProbabilityF) {
  const Material glass("glass", std::make_shared<DielectricBsdf>(Spectrum(1.0f), 1.5f, false));
  const Vec3 n(0, 0, 1);
  for (bool front : {true, false})
    for (int k = 1; k < 90; k += 4) {
      const float theta = float(k * M_PI / 180.0);
      const Vec3 wo(std::sin(theta), 0.0f, std::cos(theta));
      const float eta = front ? 1.5f : 1.0f / 1.5f;
      float cosT;
      const float f = fresnelDielectric(wo.z, eta, cosT);
      int reflected = 0;
      constexpr int kSamples = 2000;
      for (int s = 0; s < kSamples; ++s) {
        const auto m = glass.sample(n, wo, (float(s) + 0.5f) / float(kSamples), Vec2(0.5f), front);
        ASSERT_TRUE(m && m->specular);
        if (m->wi.z > 0) {
          ++reflected;
          EXPECT_NEAR(m->wi.x, -wo.x, 1e-6f);
          EXPECT_EQ(m->weight, Spectrum(1.0f));
        } else {
          // Snell: n_i sin(theta_i) = n_t sin(theta_t), in the plane of incidence, opposite side.
          EXPECT_NEAR(-m->wi.x * eta, wo.x, 1e-5f) << k << (front ? " entering" : " leaving");
          EXPECT_NEAR(m->wi.y, 0.0f, 1e-6f);
          EXPECT_NEAR(m->weight.r, 1.0f / (eta * eta), 1e-6f);
        }
      }
      EXPECT_NEAR(double(reflected) / kSamples, f, 1.0 / kSamples) << k << (front ? " entering" : " leaving");
    }
}

// A closed box of walls that only emit (radiance 1) holding a glass sphere in the camera's view:
// a uniform field, so the sphere must show exactly 1 wherever it is seen (inside it the field
// is eta^2; refraction's 1/eta^2 brings it back). Every path has weight 1 once it leaves the
// glass; only paths still trapped after the segment limit could lose energy.
json glassInAUniformField(const json& glass, const std::string& integrator) {
  json scene = test::closedBoxSceneJson({{"type", "emissive"}, {"radiance", 1.0}}, 16, 16, 1);
  scene["materials"]["glass"] = glass;
  scene["shapes"].push_back({{"type", "obj"},
                             {"file", "sphere.obj"},
                             {"material", "glass"},
                             {"transform", {{"scale", 0.5}, {"translate", {0.1, 0, 0.5}}}}});
  scene["render"]["integrator"] = integrator;
  return scene;
}

TEST(Dielectric, AGlassSphereInAUniformFieldShowsExactlyTheField) {
  // Every path that leaves the glass ends on the field and carries exactly 1 (Fresnel choices
  // weigh 1, refraction's 1/eta^2 cancels on the way out). The only exception is a path that is
  // still inside when it reaches pathSegmentLimit(B): faceted glass of high index traps some light
  // by total internal reflection (a whispering-gallery orbit), and such a path carries 0. So each
  // pixel is exactly 1 minus its truncated samples / spp, and the renderer counts them.
  test::TempDir dir;
  dir.write("sphere.obj", test::sphereObj(24, 48));
  for (const json& glass : {json{{"type", "dielectric"}, {"ior", 1.5}}, json{{"type", "dielectric"}, {"ior", 2.42}},
                            json{{"type", "dielectric"}, {"ior", 1.5}, {"thin_walled", true}}}) {
    for (const char* integrator : {"naive", "nee_mis"}) {
      const Scene scene = test::loadSceneJson(dir, glassInAUniformField(glass, integrator));
      const test::Rendered r = test::renderScene(scene);
      const double spp = double(scene.render.samplesPerPixel);
      double missing = 0.0;  // samples' worth of light short of 1, summed over the pixels
      for (size_t p = 0; p < r.image.rgb.size(); p += 3) {
        const double lost = (1.0 - r.image.rgb[p]) * spp;
        ASSERT_NEAR(lost, std::round(lost), 1e-3) << glass.dump() << " " << integrator << " pixel " << p / 3;
        for (int c = 1; c < 3; ++c) ASSERT_EQ(r.image.rgb[p + c], r.image.rgb[p]);
        missing += lost;
      }
      EXPECT_NEAR(missing, double(r.stats.truncated), 1e-2) << glass.dump() << " " << integrator;
      // Trapped paths are rare: those that enter near the rim at the angles of an orbit (8 of 4096
      // for a diamond at this framing).
      EXPECT_LE(r.stats.truncated * 200, r.stats.paths) << glass.dump() << " " << integrator;
      if (glass.value("ior", 1.5) < 2.0) {
        EXPECT_EQ(r.stats.truncated, 0u) << glass.dump() << " " << integrator;
      }
    }
  }
}

TEST(Dielectric, ACameraInsideGlassSeesTheFieldTimesEtaSquared) {
  // The n^2 law: in equilibrium radiance inside a medium of index eta is eta^2 times outside
  // (L / n^2 is invariant along a ray, Veach 1997 §5.2). A camera at the centre of a glass
  // sphere in the uniform field sees 2.25 at eta 1.5: this needs refraction's 1/eta^2, which a
  // path that enters and leaves the glass cancels; a thin-walled pane leaves the field at 1.
  test::TempDir dir;
  dir.write("sphere.obj", test::sphereObj(24, 48));
  for (const auto& [glass, expected] :
       {std::pair{json{{"type", "dielectric"}, {"ior", 1.5}}, 2.25f},
        std::pair{json{{"type", "dielectric"}, {"ior", 1.5}, {"thin_walled", true}}, 1.0f}}) {
    json scene = glassInAUniformField(glass, "nee_mis");
    scene["shapes"].back()["transform"] = {{"scale", 0.9}};
    const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
    for (size_t p = 0; p < r.image.rgb.size(); ++p)
      ASSERT_NEAR(r.image.rgb[p], expected, 1e-4f) << glass.dump() << " value " << p;
  }
}

TEST(Dielectric, AGlassSphereInAWhiteFurnaceKeepsTheFurnacesValue) {
  // Lambertian walls of albedo 0.5 emitting 1, B = 8: every path sees sum_{k<=8} 0.5^k, glass
  // bounces not counting; with NEE + MIS too (light samples are blocked by the glass, and the
  // paths through it carry that light instead). Roulette off: it is what makes every path's
  // value the same (the default roulette would add its own, unbiased, noise).
  test::TempDir dir;
  dir.write("sphere.obj", test::sphereObj(24, 48));
  json scene = test::closedBoxSceneJson({{"type", "lambertian"}, {"albedo", 0.5}, {"emission", 1.0}}, 12, 16, 8);
  scene["render"]["russian_roulette"] = "off";
  scene["materials"]["glass"] = {{"type", "dielectric"}, {"ior", 1.5}};
  scene["shapes"].push_back({{"type", "obj"},
                             {"file", "sphere.obj"},
                             {"material", "glass"},
                             {"transform", {{"scale", 0.5}, {"translate", {0.1, 0, 0.5}}}}});
  for (const char* integrator : {"naive", "nee_mis"}) {
    scene["render"]["integrator"] = integrator;
    const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.mean[c], 1.99609375, 0.01) << integrator;
  }
}

TEST(Dielectric, ASceneWithoutGlassDecidesAsBefore) {
  // Simulate only what the scene calls for: glass turns on the specular path, and only glass.
  test::TempDir dir;
  json scene = test::closedBoxSceneJson({{"type", "lambertian"}, {"albedo", 0.5}, {"emission", 1.0}}, 8, 1, 2);
  const Scene plain = test::loadSceneJson(dir, scene);
  EXPECT_FALSE(analyzeEffects(plain, plain.camera()).specular);
  dir.write("sphere.obj", test::sphereObj(8, 16));
  scene["materials"]["glass"] = {{"type", "dielectric"}};
  scene["shapes"].push_back(
      {{"type", "obj"}, {"file", "sphere.obj"}, {"material", "glass"}, {"transform", {{"scale", 0.3}}}});
  const Scene withGlass = test::loadSceneJson(dir, scene);
  EXPECT_TRUE(analyzeEffects(withGlass, withGlass.camera()).specular);
}

}  // namespace
}  // namespace lensfarm
