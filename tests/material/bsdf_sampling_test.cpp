// Every non-delta scattering model against its own density: chi-square goodness of fit of
// sample() against pdf() over a grid of roughness, index and incident angle (grazing included),
// as pbrt-v4 and Mitsuba 3 test their BSDFs; that every sample's weight is evalCos / pdf; energy
// (white furnace) and reciprocity. Materials are built from scene JSON through parseMaterial, the
// registration point the scene loader uses.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "common/material/fresnel.h"
#include "common/material/ggx_albedo.h"
#include "common/material/material.h"
#include "common/util/field_reader.h"
#include "tests/support/chi2.h"
#include "tests/support/uniform_rng.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;

Material materialFrom(const json& fields) {
  static const std::string file = "test.json";
  FieldReader r(fields, "materials.test", file);
  return parseMaterial("test", r);
}

// Unit direction at `degrees` from +z in the xz-plane (negative x, so reflection goes to +x).
Vec3 incident(double degrees) {
  const double t = degrees * M_PI / 180.0;
  return Vec3(float(-std::sin(t)), 0.0f, float(std::cos(t)));
}

struct Case {
  json material;
  double degrees;
  bool front;
  std::string name() const {
    return material.dump() + " at " + std::to_string(degrees) + " deg " + (front ? "outside" : "inside");
  }
};

std::vector<Case> roughCases() {
  std::vector<Case> cases;
  for (double roughness : {0.1, 0.3, 0.6, 1.0})
    for (double degrees : {0.0, 45.0, 80.0, 89.0}) {
      cases.push_back({{{"type", "conductor"}, {"metal", "Au"}, {"roughness", roughness}}, degrees, true});
      cases.push_back({{{"type", "conductor"},
                        {"reflectance", {0.9, 0.6, 0.3}},
                        {"roughness", roughness},
                        {"energy_compensation", false}},
                       degrees,
                       true});
      for (double metallic : {0.0, 0.5, 1.0})
        cases.push_back({{{"type", "principled"},
                          {"base_color", {0.8, 0.5, 0.2}},
                          {"metallic", metallic},
                          {"roughness", roughness},
                          {"transmission", metallic < 1.0 ? 0.6 : 0.0}},
                         degrees,
                         true});
      for (double ior : {1.1, 1.5, 2.5})
        for (bool front : {true, false})
          cases.push_back({{{"type", "dielectric"}, {"ior", ior}, {"roughness", roughness}}, degrees, front});
      // A solid (not thin-walled) principled surface: its transmitting share refracts, from
      // outside and from inside (glTF with KHR_materials_volume).
      for (bool front : {true, false})
        cases.push_back({{{"type", "principled"},
                          {"base_color", {0.8, 0.5, 0.2}},
                          {"metallic", 0.0},
                          {"roughness", roughness},
                          {"transmission", 0.6},
                          {"ior", 1.5},
                          {"thin_walled", false}},
                         degrees,
                         front});
    }
  return cases;
}

TEST(BsdfSampling, EveryRoughModelSamplesItsOwnDensity) {
  const std::vector<Case> cases = roughCases();
  std::vector<test::Chi2Result> results(cases.size());
  auto run = [&](size_t first) {
    for (size_t k = first; k < cases.size(); k += 2) {
      const Material m = materialFrom(cases[k].material);
      const Vec3 n(0, 0, 1), wo = incident(cases[k].degrees);
      const bool front = cases[k].front;
      test::Chi2Options o;
      o.thetaBins = 24;
      o.sampleCount = 60000;
      o.seed = 7 + k;
      results[k] = test::chi2Test(
          [&](Vec2 u, float uLobe) -> std::optional<Vec3> {
            const auto s = m.sample(n, wo, uLobe, u, front);
            if (!s) return std::nullopt;
            return s->wi;
          },
          [&](const Vec3& wi) { return m.pdf(n, wo, wi, front); }, o);
    }
  };
  std::thread second(run, size_t(1));
  run(0);
  second.join();
  for (size_t k = 0; k < cases.size(); ++k) {
    const test::Chi2Result& r = results[k];
    EXPECT_TRUE(test::passes(r.pValue, 0.01, int(cases.size()))) << cases[k].name() << "\n" << r.histogramDump;
    // The density integrates to the fraction of samples not absorbed (masked reflections).
    EXPECT_NEAR(r.pdfIntegral, r.acceptedFraction, 0.01) << cases[k].name();
  }
}

// The harness sees a wrong density of these models: the dielectric's pdf without its Fresnel
// branch probability.
TEST(BsdfSampling, AWrongDensityIsRejected) {
  const Material m = materialFrom({{"type", "dielectric"}, {"ior", 1.5}, {"roughness", 0.5}});
  const Vec3 n(0, 0, 1), wo = incident(70.0);
  test::Chi2Options o;
  o.thetaBins = 24;
  o.sampleCount = 60000;
  const test::Chi2Result r = test::chi2Test(
      [&](Vec2 u, float uLobe) -> std::optional<Vec3> {
        const auto s = m.sample(n, wo, uLobe, u, true);
        return s ? std::optional<Vec3>(s->wi) : std::nullopt;
      },
      // Reflection and transmission weighted equally instead of by F and 1 - F.
      [&](const Vec3& wi) {
        const float p = m.pdf(n, wo, wi, true);
        float cosT;
        const Vec3 h = glm::normalize(wi.z > 0 ? wo + wi : 1.5f * wi + wo);
        const float f = fresnelDielectric(std::abs(glm::dot(wo, h)), 1.5f, cosT);
        return wi.z > 0 ? p / f * 0.5f : p / (1.0f - f) * 0.5f;
      },
      o);
  EXPECT_LT(r.pValue, 1e-6);
}

TEST(BsdfSampling, EverySampleWeighsEvalCosOverPdf) {
  test::UniformRng rng(3);
  for (const Case& c : roughCases()) {
    const Material m = materialFrom(c.material);
    const Vec3 n(0, 0, 1), wo = incident(c.degrees);
    for (int k = 0; k < 200; ++k) {
      const float uLobe = rng.next();
      const auto s = m.sample(n, wo, uLobe, rng.next2(), c.front);
      if (!s) continue;
      ASSERT_FALSE(s->specular) << c.name();
      const float pdf = m.pdf(n, wo, s->wi, c.front);
      ASSERT_NEAR(s->pdf, pdf, 1e-3f * pdf) << c.name();
      const Spectrum f = m.evalCos(n, wo, s->wi, c.front);
      for (int ch = 0; ch < 3; ++ch) ASSERT_NEAR(s->weight[ch], f[ch] / pdf, 1e-3f * f[ch] / pdf + 1e-7f) << c.name();
    }
  }
}

// The directional albedo of a model at wo, by its own sampling: the mean sample weight.
double albedo(const Material& m, const Vec3& wo, bool front, int samples, int channel = 1) {
  test::UniformRng rng(11);
  double sum = 0.0;
  for (int k = 0; k < samples; ++k) {
    const float uLobe = rng.next();
    const auto s = m.sample(Vec3(0, 0, 1), wo, uLobe, rng.next2(), front);
    if (s) sum += s->weight[channel];
  }
  return sum / samples;
}

TEST(RoughConductor, WhiteFurnaceWithEnergyCompensationKeepsAlmostAllTheLight) {
  // F = 1 (reflectance 1): the single-scattering GGX loses what Kulla-Conty's lobe gives back.
  const Material compensated = materialFrom({{"type", "conductor"}, {"reflectance", 1}, {"roughness", 1}});
  const Material single =
      materialFrom({{"type", "conductor"}, {"reflectance", 1}, {"roughness", 1}, {"energy_compensation", false}});
  for (double degrees : {0.0, 30.0, 60.0, 80.0}) {
    const Vec3 wo = incident(degrees);
    EXPECT_GE(albedo(compensated, wo, true, 200000), 0.99) << degrees;
    EXPECT_LE(albedo(compensated, wo, true, 200000), 1.01) << degrees;
    // At alpha = 1, D = 1/pi and the single-scattering albedo is 1 - mu ln(1 + 1/mu) in closed
    // form (material/ggx_albedo.h): 0.307 at normal incidence, a 69 % loss.
    const double mu = wo.z;
    EXPECT_NEAR(albedo(single, wo, true, 200000), 1.0 - mu * std::log(1.0 + 1.0 / mu), 0.01) << degrees;
  }
}

TEST(RoughConductor, ANarrowLobeReflectsLikeThePolishedMetal) {
  // Roughness 0.1 (alpha 0.01) of gold at 45 degrees: the albedo is the Fresnel term at 45 degrees
  // (within the lobe's width), and a roughness below the smooth limit is the polished metal.
  const Material rough = materialFrom({{"type", "conductor"}, {"metal", "Au"}, {"roughness", 0.1}});
  const Material polished = materialFrom({{"type", "conductor"}, {"metal", "Au"}});
  const Material tiny = materialFrom({{"type", "conductor"}, {"metal", "Au"}, {"roughness", 0.01}});
  EXPECT_TRUE(polished.isSpecular());
  EXPECT_TRUE(tiny.isSpecular());
  EXPECT_FALSE(rough.isSpecular());
  const Vec3 wo = incident(45.0);
  const auto mirror = polished.sample(Vec3(0, 0, 1), wo, 0.5f, Vec2(0.5f), true);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(albedo(rough, wo, true, 50000, c), mirror->weight[c], 0.01) << c;
}

TEST(RoughConductor, IsReciprocal) {
  test::UniformRng rng(5);
  for (const json& j : {json{{"type", "conductor"}, {"metal", "Cu"}, {"roughness", 0.4}},
                        json{{"type", "conductor"}, {"reflectance", 0.8}, {"roughness", 0.9}}}) {
    const Material m = materialFrom(j);
    for (int k = 0; k < 500; ++k) {
      const Vec3 a = Frame::fromNormal(Vec3(0, 0, 1)).toWorld(sampleCosineHemisphere(rng.next2()));
      const Vec3 b = Frame::fromNormal(Vec3(0, 0, 1)).toWorld(sampleCosineHemisphere(rng.next2()));
      if (a.z < 1e-3f || b.z < 1e-3f) continue;
      // f(a, b) = evalCos(a, b) / cos_b.
      const Spectrum fab = m.evalCos(Vec3(0, 0, 1), a, b) / b.z, fba = m.evalCos(Vec3(0, 0, 1), b, a) / a.z;
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(fab[c], fba[c], 1e-4f * std::max(fab[c], 1.0f)) << j.dump();
    }
  }
}

TEST(RoughDielectric, ObeysTheGeneralisedReciprocityOfTransmission) {
  // With eta = n_b / n_a (b the side of wi): f(wo=a, wi=b) eta^2 = f(wo=b, wi=a), the radiance form
  // of Veach 1997 eq. 5.14 (f / n_i^2 symmetric, up to the 1/eta^2 radiance scaling).
  const float ior = 1.5f;
  const Material m = materialFrom({{"type", "dielectric"}, {"ior", ior}, {"roughness", 0.5}});
  const Vec3 up(0, 0, 1);
  test::UniformRng rng(9);
  int checked = 0;
  for (int k = 0; k < 2000; ++k) {
    const Vec3 a = sampleCosineHemisphere(rng.next2());   // outside, above
    const Vec3 b = -sampleCosineHemisphere(rng.next2());  // inside, below
    if (a.z < 1e-2f || b.z > -1e-2f) continue;
    const float fab = m.evalCos(up, a, b, true).g / std::abs(b.z);    // from outside (front)
    const float fba = m.evalCos(-up, b, a, false).g / std::abs(a.z);  // from inside: n turned to b's side
    if (fab <= 0.0f && fba <= 0.0f) continue;
    // Near the critical angle Fresnel's transmittance falls to 0 with an infinite slope, so the
    // float rounding of m moves it by more than the tolerance: those pairs are not compared.
    const Vec3 half = glm::normalize(ior * b + a);
    const float sinInside2 = 1.0f - glm::dot(b, half) * glm::dot(b, half), sinCritical2 = 1.0f / (ior * ior);
    if (std::abs(sinInside2 - sinCritical2) < 1e-2f) continue;
    ASSERT_NEAR(fab * ior * ior, fba, 1e-3f * fba + 1e-6f) << glm::dot(b, half);
    ++checked;
  }
  EXPECT_GT(checked, 500);
  // Reflection is plainly reciprocal.
  for (int k = 0; k < 500; ++k) {
    const Vec3 a = sampleCosineHemisphere(rng.next2()), b = sampleCosineHemisphere(rng.next2());
    if (a.z < 1e-2f || b.z < 1e-2f) continue;
    ASSERT_NEAR(m.evalCos(up, a, b, true).g / b.z, m.evalCos(up, b, a, true).g / a.z,
                1e-4f * std::max(1.0f, m.evalCos(up, a, b, true).g / b.z));
  }
}

TEST(RoughDielectric, ReflectsAndTransmitsTheFresnelShareAtLowRoughness) {
  // At roughness 0.1 (alpha 0.01) the reflected share of the sampled paths is Fresnel's.
  const Material m = materialFrom({{"type", "dielectric"}, {"ior", 1.5}, {"roughness", 0.1}});
  for (double degrees : {0.0, 40.0, 70.0}) {
    const Vec3 wo = incident(degrees);
    test::UniformRng rng(2);
    double reflected = 0.0, total = 0.0;
    for (int k = 0; k < 50000; ++k) {
      const float uLobe = rng.next();
      const auto s = m.sample(Vec3(0, 0, 1), wo, uLobe, rng.next2(), true);
      if (!s) continue;
      if (s->wi.z > 0) reflected += s->weight.g;
      total += s->wi.z > 0 ? s->weight.g : s->weight.g * 1.5f * 1.5f;  // undo 1/eta^2 to count energy
    }
    float cosT;
    EXPECT_NEAR(reflected / 50000.0, fresnelDielectric(wo.z, 1.5f, cosT), 0.01) << degrees;
    EXPECT_NEAR(total / 50000.0, 1.0, 0.03) << degrees;  // single scattering loses little at alpha 0.01
  }
}

TEST(RoughMaterials, BadFieldsNameTheField) {
  const std::vector<std::pair<json, std::string>> bad = {
      {{{"type", "conductor"}, {"metal", "Au"}, {"roughness", 1.5}}, "materials.test.roughness"},
      {{{"type", "conductor"}, {"metal", "Au"}, {"roughness", -0.1}}, "materials.test.roughness"},
      {{{"type", "dielectric"}, {"roughness", 2}}, "materials.test.roughness"},
      {{{"type", "dielectric"}, {"ior", 0}}, "materials.test.ior"},
      {{{"type", "dielectric"}, {"ior", -1.5}}, "materials.test.ior"},
      {{{"type", "dielectric"}, {"thin_walled", true}, {"roughness", 0.3}}, "materials.test.roughness"},
      {{{"type", "conductor"}, {"metal", "Au"}, {"reflectance", 0.5}}, "materials.test.metal"},
      {{{"type", "conductor"}, {"reflectance", 1.5}}, "materials.test.reflectance"},
      {{{"type", "velvet"}}, "materials.test.type"},
      {{{"type", "principled"}, {"metallic", 1.2}}, "materials.test.metallic"},
      {{{"type", "principled"}, {"transmission", -0.5}}, "materials.test.transmission"},
      {{{"type", "principled"}, {"roughness", 3}}, "materials.test.roughness"},
  };
  for (const auto& [fields, where] : bad) {
    try {
      materialFrom(fields);
      ADD_FAILURE() << fields.dump() << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(where + ":"), std::string::npos) << e.what();
    }
  }
}

// The glTF 2.0 BRDF (Appendix B) written out in double from the specification, independently of
// PrincipledBsdf, for reflection (wi above) and thin-walled transmission (wi below), with the base
// weighted by 1 - F_d(N.V) (the one documented difference, material/principled.h).
double gltfBsdfCos(double c, double metallic, double roughness, double transmission, double ior, const DVec3& v,
                   const DVec3& l) {
  const double alpha = roughness * roughness, a2 = alpha * alpha;
  const DVec3 lr(l.x, l.y, std::abs(l.z));  // thin-walled transmission: the reflection lobe mirrored
  const DVec3 h = glm::normalize(v + lr);
  const double nh = h.z, vh = glm::dot(v, h), nv = v.z, nl = lr.z;
  const double d = a2 / (M_PI * std::pow(nh * nh * (a2 - 1.0) + 1.0, 2.0));
  const double vis = 0.5 / (nl * std::sqrt(nv * nv * (1 - a2) + a2) + nv * std::sqrt(nl * nl * (1 - a2) + a2));
  const double specular = vis * d;  // G D / (4 |N.L| |N.V|), glTF's V = G / (4 |N.L| |N.V|)
  const double f0 = std::pow((ior - 1) / (ior + 1), 2.0), w = std::pow(1.0 - std::abs(vh), 5.0);
  const double fd = f0 + (1 - f0) * w, fv = f0 + (1 - f0) * std::pow(1.0 - nv, 5.0);
  if (l.z < 0) return (1 - metallic) * transmission * (1 - fv) * c * specular * nl;
  const double metal = specular * (c + (1 - c) * w);
  const double dielectric = (1 - fv) * (1 - transmission) * c / M_PI + fd * specular;
  return ((1 - metallic) * dielectric + metallic * metal) * nl;
}

TEST(Principled, IsTheGltfBrdfOfTheSpecification) {
  test::UniformRng rng(4);
  for (double metallic : {0.0, 0.3, 1.0})
    for (double roughness : {0.2, 0.5, 1.0})
      for (double transmission : {0.0, 0.5}) {
        const json fields = {{"type", "principled"},   {"base_color", {0.9, 0.4, 0.1}}, {"metallic", metallic},
                             {"roughness", roughness}, {"transmission", transmission},  {"ior", 1.45}};
        const Material m = materialFrom(fields);
        for (int k = 0; k < 50; ++k) {
          const Vec3 v = sampleCosineHemisphere(rng.next2());
          Vec3 l = sampleCosineHemisphere(rng.next2());
          if (k % 2) l.z = -l.z;
          if (v.z < 1e-2f || std::abs(l.z) < 1e-2f) continue;
          const Spectrum f = m.evalCos(Vec3(0, 0, 1), v, l);
          const double base[3] = {0.9, 0.4, 0.1};
          for (int c = 0; c < 3; ++c) {
            const double expected = gltfBsdfCos(base[c], metallic, roughness, transmission, 1.45, DVec3(v), DVec3(l));
            ASSERT_NEAR(f[c], expected, 1e-4 * std::max(1.0, expected)) << fields.dump() << " channel " << c;
          }
        }
      }
}

TEST(Principled, NeverReflectsMoreThanItReceives) {
  for (double metallic : {0.0, 0.5, 1.0})
    for (double roughness : {0.05, 0.4, 1.0})
      for (double transmission : {0.0, 1.0})
        for (double degrees : {0.0, 60.0, 85.0}) {
          const Material m = materialFrom({{"type", "principled"},
                                           {"base_color", 1},
                                           {"metallic", metallic},
                                           {"roughness", roughness},
                                           {"transmission", transmission}});
          EXPECT_LE(albedo(m, incident(degrees), true, 20000), 1.01) << metallic << " " << roughness << " " << degrees;
        }
}

TEST(Principled, AFullMetalIsTheUncompensatedRoughConductorWithItsBaseColourAsF0) {
  const Material principled =
      materialFrom({{"type", "principled"}, {"base_color", {0.9, 0.6, 0.3}}, {"metallic", 1}, {"roughness", 0.5}});
  const Material conductor = materialFrom(
      {{"type", "conductor"}, {"reflectance", {0.9, 0.6, 0.3}}, {"roughness", 0.5}, {"energy_compensation", false}});
  test::UniformRng rng(8);
  for (int k = 0; k < 200; ++k) {
    const Vec3 v = sampleCosineHemisphere(rng.next2()), l = sampleCosineHemisphere(rng.next2());
    const Spectrum a = principled.evalCos(Vec3(0, 0, 1), v, l), b = conductor.evalCos(Vec3(0, 0, 1), v, l);
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(a[c], b[c], 1e-5f * std::max(1.0f, b[c]));
  }
}

// Not thin-walled (glTF's KHR_materials_volume), a principled surface that transmits everything
// is the dielectric boundary of its index, tinted by the base colour: smooth, the same delta
// samples (Snell's direction, the 1/eta^2 radiance scaling) from outside and from inside (total
// internal reflection included); rough, the same evalCos and pdf.
TEST(Principled, ASolidThatTransmitsEverythingIsTheDielectric) {
  for (double roughness : {0.0, 0.4}) {
    const Material solid = materialFrom({{"type", "principled"},
                                         {"base_color", {0.9, 0.8, 0.7}},
                                         {"metallic", 0},
                                         {"roughness", roughness},
                                         {"transmission", 1},
                                         {"ior", 1.5},
                                         {"thin_walled", false}});
    const Material glass = materialFrom(
        {{"type", "dielectric"}, {"transmittance", {0.9, 0.8, 0.7}}, {"ior", 1.5}, {"roughness", roughness}});
    EXPECT_EQ(solid.isSpecular(), roughness == 0.0);
    EXPECT_TRUE(solid.traits().transmits);
    test::UniformRng rng(21);
    for (const bool front : {true, false})
      for (double degrees : {0.0, 30.0, 50.0, 80.0}) {
        const Vec3 n(0, 0, 1), wo = incident(degrees);
        for (int k = 0; k < 64; ++k) {
          const float uLobe = rng.next();
          const Vec2 u = rng.next2();
          const auto a = solid.sample(n, wo, uLobe, u, front), b = glass.sample(n, wo, uLobe, u, front);
          ASSERT_EQ(a.has_value(), b.has_value());
          if (!a) continue;
          ASSERT_EQ(a->specular, b->specular);
          for (int c = 0; c < 3; ++c) {
            ASSERT_NEAR(a->wi[c], b->wi[c], 1e-6f) << degrees << (front ? " outside" : " inside");
            ASSERT_NEAR(a->weight[c], b->weight[c], 1e-5f * std::max(1.0f, b->weight[c]));
          }
          ASSERT_EQ(a->eta, b->eta);
          if (a->specular) continue;
          const Vec3 wi = a->wi;
          ASSERT_NEAR(solid.pdf(n, wo, wi, front), glass.pdf(n, wo, wi, front), 1e-4f * glass.pdf(n, wo, wi, front));
        }
      }
  }
}

// Partly transmitting, the solid is the mixture of material/principled.h: w = t (1 - m) of the
// dielectric and the rest the opaque principled model with metallic m / (1 - w).
TEST(Principled, ASolidThatTransmitsSomeIsTheDocumentedMixture) {
  const double t = 0.6, metallic = 0.2, w = t * (1 - metallic);
  const Material solid = materialFrom({{"type", "principled"},
                                       {"base_color", {0.9, 0.5, 0.3}},
                                       {"metallic", metallic},
                                       {"roughness", 0.5},
                                       {"transmission", t},
                                       {"ior", 1.4},
                                       {"thin_walled", false}});
  const Material glass =
      materialFrom({{"type", "dielectric"}, {"transmittance", {0.9, 0.5, 0.3}}, {"ior", 1.4}, {"roughness", 0.5}});
  const Material opaque = materialFrom({{"type", "principled"},
                                        {"base_color", {0.9, 0.5, 0.3}},
                                        {"metallic", metallic / (1 - w)},
                                        {"roughness", 0.5},
                                        {"ior", 1.4}});
  test::UniformRng rng(22);
  for (int k = 0; k < 300; ++k) {
    const Vec3 v = sampleCosineHemisphere(rng.next2());
    Vec3 l = sampleCosineHemisphere(rng.next2());
    if (k % 2) l.z = -l.z;
    if (v.z < 1e-2f || std::abs(l.z) < 1e-2f) continue;
    const bool front = k % 3 != 0;
    const Spectrum f = solid.evalCos(Vec3(0, 0, 1), v, l, front);
    const Spectrum expected = glass.evalCos(Vec3(0, 0, 1), v, l, front) * float(w) +
                              opaque.evalCos(Vec3(0, 0, 1), v, l, front) * float(1 - w);
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(f[c], expected[c], 1e-5f * std::max(1.0f, expected[c]));
  }
}

// KHR_materials_specular's specularColorFactor scales F0 (by its luminance): 0, as Blender writes
// its Specular 0, leaves no reflection at normal incidence, so the base is Lambertian there; 1 is
// the plain model.
TEST(Principled, ASpecularColourOfZeroLeavesOnlyGrazingReflection) {
  const Material none = materialFrom(
      {{"type", "principled"}, {"base_color", 0.8}, {"metallic", 0}, {"roughness", 1}, {"specular_color", 0}});
  const Vec3 n(0, 0, 1);
  const Spectrum f = none.evalCos(n, n, n);
  EXPECT_NEAR(f.g, 0.8f / float(M_PI), 1e-6f);
  const Material plain = materialFrom({{"type", "principled"}, {"base_color", 0.8}, {"metallic", 0}, {"roughness", 1}});
  const Material unit = materialFrom(
      {{"type", "principled"}, {"base_color", 0.8}, {"metallic", 0}, {"roughness", 1}, {"specular_color", 1}});
  EXPECT_EQ(plain.evalCos(n, incident(40), incident(-20)), unit.evalCos(n, incident(40), incident(-20)));
  EXPECT_LT(plain.evalCos(n, n, n).g, f.g);  // F0 = 0.04 takes its share from the base
}

TEST(Principled, EmissionStrengthScalesTheEmission) {
  const Material m = materialFrom({{"type", "principled"}, {"emission", {1, 0.5, 0}}, {"emission_strength", 4}});
  EXPECT_EQ(m.emission, Spectrum(4.0f, 2.0f, 0.0f));
  try {
    materialFrom({{"type", "principled"}, {"emission", 1e20}, {"emission_strength", 1e20}});
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("materials.test.emission_strength:"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace lensfarm
