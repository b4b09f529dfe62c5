#pragma once
// The principled model's formulas (material/principled.h has the model and its references) in the
// local shading frame (+z the normal, wo above it), as inline functions of a record of floats:
// PrincipledBsdf evaluates through them, and the packet tracer's lane loops (render/integrator.cpp)
// gather one record per lane from the scene's materials and call the same functions, so a lane
// computes exactly the bits the one-path code computes (math/lanes.h).
//
// The record holds everything but the solid (refracting) share, which stays with PrincipledBsdf;
// the lane loops take only records without it and without a straight (delta) transmission.
#include <algorithm>
#include <cmath>

#include "common/material/bsdf.h"
#include "common/material/microfacet.h"
#include "common/math/sampling.h"

namespace lensfarm {

struct PrincipledModel {
  float baseR = 1.0f, baseG = 1.0f, baseB = 1.0f;  // C
  float metallic = 1.0f, transmission = 0.0f;
  float specular = 1.0f;  // KHR_materials_specular's factor
  float f0 = 0.04f;       // the dielectric's reflectance at normal incidence
  float alpha = 1.0f;     // GGX width, at least GgxDistribution::kSmoothAlpha
  float colour = 1.0f;    // max(luminance(C), 0): the base layers' share of the lobe choice
  float straight = 0.0f;  // 1: the thin wall's transmission is a delta straight through

  Spectrum base() const { return Spectrum(baseR, baseG, baseB); }
  GgxDistribution ggx() const { return GgxDistribution{alpha}; }

  static float schlickWeight(float cosI) {
    const float m = 1.0f - std::min(1.0f, std::abs(cosI)), m2 = m * m;
    return m2 * m2 * m;
  }
  // The surface's mirror image of a direction below it.
  static Vec3 mirrored(const Vec3& w) { return Vec3(w.x, w.y, -w.z); }

  struct LobeChoice {
    float specular, diffuse, transmission;  // probabilities, summing to 1
  };
  // The lobes' probabilities at wo (cosO = wo.z): their approximate albedos.
  [[gnu::always_inline]] LobeChoice lobes(float cosO) const {
    const float fd = specular * (f0 + (1.0f - f0) * schlickWeight(cosO));
    const float dielectric = 1.0f - metallic;
    const float s = metallic + dielectric * fd;
    const float d = dielectric * (1.0f - fd) * (1.0f - transmission) * colour;
    const float t = dielectric * (1.0f - fd) * transmission * colour;
    const float total = s + d + t;
    const bool some = total > 0.0f;
    const float divisor = some ? total : 1.0f;
    return {some ? s / divisor : 1.0f, some ? d / divisor : 0.0f, some ? t / divisor : 0.0f};
  }

  // f(wo, wi) cos(theta_i) of the non-delta lobes.
  [[gnu::always_inline]] Spectrum evalLocal(const Vec3& wo, const Vec3& wi) const {
    // Written without early returns (each case computed, then selected), so that the lane loops
    // that call it vectorise; zero where wo is not above the surface or wi lies in it.
    const bool reflection = wi.z > 0.0f;
    const Vec3 wr = reflection ? wi : mirrored(wi);
    const Vec3 sum = wo + wr;
    const float length = glm::length(sum);
    const bool exists = (wo.z > 0.0f) & (wi.z != 0.0f) & (length > 0.0f);
    const Vec3 h = sum / (length > 0.0f ? length : 1.0f);
    const float vh = glm::dot(wo, h);
    const float lobe = ggxReflectionCos(ggx(), wo, wr, h);  // specular_brdf(alpha) cos_i
    // KHR_materials_specular: the dielectric's Fresnel term times specularFactor, in the layer and
    // in the base's weight alike.
    const float fd = specular * (f0 + (1.0f - f0) * schlickWeight(vh));
    const float baseWeight = 1.0f - specular * (f0 + (1.0f - f0) * schlickWeight(wo.z));  // 1 - F_d(N.V)
    const float dielectric = 1.0f - metallic;
    const Spectrum transmitted =
        straight > 0.0f ? Spectrum(0.0f) : base() * (dielectric * transmission * baseWeight * lobe);
    const Spectrum metalFresnel = base() + (Spectrum(1.0f) - base()) * schlickWeight(vh);
    const Spectrum metal = metalFresnel * (metallic * lobe);
    const Spectrum diffuse = base() * (baseWeight * (1.0f - transmission) * kInvPi * wi.z);
    const Spectrum reflected = metal + dielectric * (Spectrum(fd * lobe) + diffuse);
    return exists ? (reflection ? reflected : transmitted) : Spectrum(0.0f);
  }

  // The density with which sampleLocal gives wi (solid angle), the lobes mixed by their choice.
  [[gnu::always_inline]] float pdfLocal(const Vec3& wo, const Vec3& wi) const {
    const LobeChoice c = lobes(wo.z);
    const bool reflection = wi.z > 0.0f;
    const Vec3 wr = reflection ? wi : mirrored(wi);
    const Vec3 sum = wo + wr;
    const float length = glm::length(sum);
    const float g = length > 0.0f ? ggxReflectionPdf(ggx(), wo, sum / (length > 0.0f ? length : 1.0f)) : 0.0f;
    const float transmitted = straight > 0.0f ? 0.0f : c.transmission * g;
    const float reflected = c.specular * g + c.diffuse * cosineHemispherePdf(wi.z);
    return (wo.z > 0.0f) & (wi.z != 0.0f) ? (reflection ? reflected : transmitted) : 0.0f;
  }

  // A direction of the non-delta lobes for wo (wo.z > 0), the lobe chosen by `choice` in [0, 1)
  // against c (after a straight transmission's share is taken out): cosine-weighted diffuse, GGX
  // visible normals reflected, or those mirrored through the surface. z == 0 where the GGX
  // reflection falls below the surface (masked: absorbed).
  [[gnu::always_inline]] Vec3 sampleLocal(const Vec3& wo, const LobeChoice& c, float choice, Vec2 u) const {
    const Vec3 diffuse = sampleCosineHemisphere(u);
    const Vec3 wr = reflect(wo, ggx().sampleVisibleNormal(wo, u));
    const Vec3 glossy = (straight == 0.0f) & (choice < c.diffuse + c.transmission) ? mirrored(wr) : wr;
    return choice < c.diffuse ? diffuse : (wr.z > 0.0f ? glossy : Vec3(0.0f));
  }
};

}  // namespace lensfarm
