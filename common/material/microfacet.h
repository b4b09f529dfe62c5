#pragma once
// The isotropic GGX (Trowbridge-Reitz) microfacet distribution in the local shading frame, where
// the macro-surface normal is +z. Every direction here is a unit vector in that frame.
//
// References (equation numbers are the papers'):
//  [W07] Walter, Marschner, Li, Torrance 2007, "Microfacet Models for Refraction through Rough
//        Surfaces" (EGSR): GGX D (eq. 33) and its Smith G1 (eq. 34); the normalisation of D
//        (§3.1: the microsurface projects onto the macro-surface with the same area).
//  [H14] Heitz 2014, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs"
//        (JCGT 3(2)): Lambda for GGX (§5.3, eq. 72), G1 = 1 / (1 + Lambda), the distribution of
//        visible normals and its normalisation (the "weak white furnace": the visible microsurface
//        projects onto wo with area cos theta_o), the height-correlated masking-shadowing
//        function G2 = 1 / (1 + Lambda(wo) + Lambda(wi)) (eq. 99).
//  [H18] Heitz 2018, "Sampling the GGX Distribution of Visible Normals" (JCGT 7(4)): the visible
//        normal density D_w(m) = G1(w) max(0, w.m) D(m) / w.z (eq. 1) and its exact sampling
//        routine (the paper's reference code), which this file follows for the isotropic case.
//
// Numerics (every function below keeps these):
//  - alpha is in [kMinAlpha, 1] (alphaFromRoughness produces only such values). Within that range
//    and for any unit direction, including the horizon (z == 0 or |z| ~ 1e-8) and the normal
//    (x = y = 0), every function returns a finite value; the one documented exception is
//    lambda() at z == 0 exactly, whose true value +infinity it returns (never a NaN).
//  - No formula goes through tan(theta) = sqrt(1 - z^2) / z or through cos(theta) of a direction
//    near the pole: in float, 1 - z^2 has lost all its digits once the angle is below ~2.5e-4 rad,
//    i.e. inside the lobe of a narrow GGX. Instead the transverse part x^2 + y^2, which is exact
//    near the pole, is used directly, and G1, G and the visible density are written as ratios
//    that stay finite at the horizon (see each function).
//  - Float throughout: the quantities are products and ratios of O(1) values with alpha^2 >= 1e-8,
//    far from float's range limits, and sqrt of sums of squares (no cancellation).
#include <algorithm>
#include <cmath>
#include <limits>

#include "common/math/sampling.h"
#include "common/math/vec.h"

namespace lensfarm {

struct GgxDistribution {
  // The GGX width (the slope standard deviation scale; alpha = 1 is the roughest surface a
  // material may ask for). Precondition for every member: kMinAlpha <= alpha <= 1.
  float alpha = 1.0f;

  // The smallest alpha the functions below accept. Its limit is not D's range (1/(pi alpha^2)
  // overflows float only near alpha ~ 1e-19) but the precision of the directions it is evaluated
  // at: a half vector normalize(wo + wi) computed in float carries an absolute error of about
  // 1e-7 in its x, y components. At alpha = 1e-4 that is 1e-3 of the lobe's width, so D at that
  // vector is within a few tenths of a percent of D at the exact one; at alpha = 1e-6 the error
  // would be tens of percent, and below ~1e-7 the lobe is a delta function as far as float
  // directions can tell. alpha^2 = 1e-8 and D(peak) = 3.2e7 stay
  // far inside float's range.
  static constexpr float kMinAlpha = 1e-4f;

  // Below this width a material should be rendered as a smooth mirror / smooth dielectric (a
  // delta lobe) instead of through these functions: the lobe's half width is then < 0.06 degrees
  // (reflections blur by ~0.1 degrees: a few pixels at most in a high-resolution close-up, usually
  // less than one), so the image is the mirror's, while the rough BRDF's peak
  // f = D G / (4 cos cos) >= 1 / (4 pi alpha^2) ~ 8e4 turns light sampling into fireflies. pbrt-v4 uses the same
  // threshold (TrowbridgeReitzDistribution::EffectivelySmooth). In perceptual roughness: r < 0.0316.
  static constexpr float kSmoothAlpha = 1e-3f;

  // The glTF 2.0 / Disney (Burley 2012) mapping alpha = roughness^2 from perceptual roughness in
  // [0, 1], clamped to [kMinAlpha, 1]. Roughness outside [0, 1] (or NaN) is clamped first.
  static float alphaFromRoughness(float roughness) {
    const float r = roughness > 0.0f ? std::min(roughness, 1.0f) : 0.0f;  // NaN -> 0
    return std::max(r * r, kMinAlpha);
  }

  bool isEffectivelySmooth() const { return alpha < kSmoothAlpha; }

  // The normal distribution function [W07 eq. 33]:
  //   D(m) = 1 / (pi alpha^2 cos^4(theta_m) (1 + tan^2(theta_m) / alpha^2)^2)   for m.z > 0,
  // normalised so that the projected microfacet area is the macro-surface's [W07 §3.1]:
  //   integral over the hemisphere of D(m) cos(theta_m) dw_m = 1.
  // Multiplying the bracket by cos^4 gives the pole-safe form 1 / (pi alpha^2 t^2) with
  // t = (x^2 + y^2) / alpha^2 + z^2, which uses no tangent and has no cancellation.
  float D(const Vec3& m) const {
    if (!(m.z > 0.0f)) return 0.0f;
    const float a2 = alpha * alpha;
    const float t = (m.x * m.x + m.y * m.y) / a2 + m.z * m.z;
    return 1.0f / (kPi * a2 * t * t);
  }

  // Smith's Lambda for GGX [H14 §5.3 eq. 72]: Lambda(w) = (-1 + sqrt(1 + q^2)) / 2 with
  // q = alpha tan(theta_w) = alpha |w_xy| / |w_z|. Written as q^2 / (2 (sqrt(1 + q^2) + 1)) =
  // q (q / (hypot(1, q) + 1)) / 2, which has no cancellation for small q and no overflow for
  // large q. Symmetric in w.z (the surface seen from below masks the same way). +infinity exactly
  // at the horizon (z == 0), which is the true value: G1 = 1 / (1 + Lambda) = 0 there. Finite
  // for every |z| > 0 that is not subnormal.
  float lambda(const Vec3& w) const {
    const float az = std::abs(w.z);
    const float q = alpha * std::sqrt(w.x * w.x + w.y * w.y) / az;  // az == 0 -> +inf (x, y != 0)
    if (std::isinf(q)) return std::numeric_limits<float>::infinity();
    return 0.5f * q * (q / (std::hypot(1.0f, q) + 1.0f));
  }

  // sqrt(z^2 + alpha^2 (x^2 + y^2)) = |z| sqrt(1 + q^2): the common factor of G1, G and the
  // visible normal density. Positive for every unit w (alpha > 0).
  float stretchedLength(const Vec3& w) const { return std::sqrt(w.z * w.z + alpha * alpha * (w.x * w.x + w.y * w.y)); }

  // Smith's masking function G1(w) = 1 / (1 + Lambda(w)) [W07 eq. 34; H14], without the
  // chi+(w.m) visibility factor (callers apply max(0, w.m)). Written as
  //   G1 = 2 |z| / (|z| + sqrt(z^2 + alpha^2 (x^2 + y^2))),
  // which is in [0, 1], exactly 1 at normal incidence and exactly 0 at the horizon.
  float G1(const Vec3& w) const {
    const float az = std::abs(w.z);
    return 2.0f * az / (az + stretchedLength(w));
  }

  // The height-correlated masking-shadowing function for reflection (wo and wi on the same side)
  // [H14 eq. 99]: G2 = 1 / (1 + Lambda(wo) + Lambda(wi)). Since 1 + Lambda(w) = (1 + S/|z|) / 2
  // with S = stretchedLength(w), 1 + Lambda(wo) + Lambda(wi) = (So/|zo| + Si/|zi|) / 2, so
  //   G2 = 2 |zo| |zi| / (|zi| So + |zo| Si),
  // finite everywhere and 0 when either direction is at the horizon. In [G1(wo) G1(wi),
  // min(G1(wo), G1(wi))]. (For transmission the height-correlated form is a Beta function
  // [H14]; this one is for reflection only.)
  float G(const Vec3& wo, const Vec3& wi) const {
    const float zo = std::abs(wo.z), zi = std::abs(wi.z);
    const float denominator = zi * stretchedLength(wo) + zo * stretchedLength(wi);
    return denominator > 0.0f ? 2.0f * zo * zi / denominator : 0.0f;
  }

  // The distribution of visible normals seen from w [H14; H18 eq. 1]:
  //   D_w(m) = G1(w) max(0, w.m) D(m) / |cos(theta_w)|,
  // a density over the hemisphere of m (solid angle measure) that integrates to 1 for every w: the
  // visible microfacets' projected area is the macro-surface's, cos(theta_w) (the weak white
  // furnace). G1(w) / |z| = 2 / (|z| + S) is finite at the horizon, so D_w is too.
  // For w below the surface (w.z < 0, e.g. leaving a dielectric) the density is that seen from
  // -w: normals are always the surface's (m.z > 0), and sampleVisibleNormal flips the same way.
  float D(const Vec3& w, const Vec3& m) const {
    const Vec3 wu = w.z < 0.0f ? -w : w;
    const float az = wu.z;
    const float cosWm = glm::dot(wu, m);
    if (!(cosWm > 0.0f)) return 0.0f;
    return 2.0f / (az + stretchedLength(wu)) * cosWm * D(m);
  }

  // Samples a microfacet normal m with density D_w(m) (pdfVisibleNormal) from u in [0,1)^2: Heitz
  // 2018, Listing 1 (isotropic). The view is stretched to the alpha = 1 configuration, where the
  // visible normals are the hemisphere's normals seen in projection along Vh: a point is sampled
  // uniformly on the projected area (a disk whose lower half is squashed by (1 + Vh.z) / 2), lifted
  // onto the hemisphere, and the normal is stretched back. Works for every w, including the
  // horizon (Vh.z = 0: half a disk) and the pole (Vh = z: the whole disk); w below the surface is
  // flipped (see D(w, m)). The result has m.z >= 0; m.z == 0 only on the disk's rim, a set of
  // measure zero where the pdf is 0.
  Vec3 sampleVisibleNormal(const Vec3& w, Vec2 u) const {
    // A uniform point on the unit disk by the concentric map (H18's code uses the polar map; any
    // area-preserving map will do, and this one needs no libm call, so the packet tracer's lane
    // loops vectorise it). It sends the square's rim (u.x or u.y exactly 0) to the disk's rim,
    // where the normal would lie in the surface (density 0, a sample lost): such u, a set of
    // measure zero, are taken a little inside instead, which leaves the distribution as it is.
    const float inside = (u.x > 0.0f) & (u.y > 0.0f) ? 1.0f : kInsideRim;
    return visibleNormalFromDisk(w, sampleConcentricDisk(u) * inside);
  }
  static constexpr float kInsideRim = 0.999f;

  // The same distribution by H18's polar map (r = sqrt(u.x), phi = 2 pi u.y), smooth in u: for
  // quadratures over u (material/ggx_albedo.h), which a map with kinks would slow down.
  Vec3 sampleVisibleNormalPolar(const Vec3& w, Vec2 u) const {
    const float r = std::sqrt(u.x);
    const float phi = 2.0f * kPi * u.y;
    return visibleNormalFromDisk(w, Vec2(r * std::cos(phi), r * std::sin(phi)));
  }

  // The visible normal seen from w for a point of the unit disk (uniform there: uniform over the
  // projected area): H18's projected-area warp and reprojection. The hemisphere seen along Vh
  // projects to the upper half disk plus half an ellipse of semi-axis Vh.z (its rim), so each
  // chord [-h, h] of the disk at p1 (h = sqrt(1 - p1^2)) is mapped linearly onto [-Vh.z h, h].
  Vec3 visibleNormalFromDisk(const Vec3& w, Vec2 disk) const {
    const Vec3 wu = w.z < 0.0f ? -w : w;
    // The view direction stretched to the alpha = 1 configuration. Its length is >= alpha |w| > 0.
    const Vec3 vh = glm::normalize(Vec3(alpha * wu.x, alpha * wu.y, wu.z));
    // Orthonormal basis (T1, T2, Vh); T1 is horizontal. At the pole any horizontal T1 will do.
    const float lensq = vh.x * vh.x + vh.y * vh.y;
    const Vec3 t1 = lensq > 0.0f ? Vec3(-vh.y, vh.x, 0.0f) / std::sqrt(lensq) : Vec3(1.0f, 0.0f, 0.0f);
    const Vec3 t2 = glm::cross(vh, t1);
    const float p1 = disk.x;
    const float s = 0.5f * (1.0f + vh.z);
    const float p2 = (1.0f - s) * std::sqrt(std::max(0.0f, 1.0f - p1 * p1)) + s * disk.y;
    // Reprojection onto the hemisphere, and back to the ellipsoid configuration.
    const Vec3 nh = p1 * t1 + p2 * t2 + std::sqrt(std::max(0.0f, 1.0f - p1 * p1 - p2 * p2)) * vh;
    return glm::normalize(Vec3(alpha * nh.x, alpha * nh.y, std::max(0.0f, nh.z)));
  }

  // The density of sampleVisibleNormal(w, .) at m, in solid angle: D_w(m).
  float pdfVisibleNormal(const Vec3& w, const Vec3& m) const { return D(w, m); }
};

// Reflection off the microfacets of a GGX surface, without the Fresnel factor (the caller's), in
// the local frame with wo.z > 0 and wi.z > 0 and h = normalize(wo + wi) [W07 eq. 20, 14]:
//   f cos(theta_i) = D(h) G(wo, wi) / (4 cos(theta_o)),
//   pdf(wi) = D_wo(h) / (4 (wo.h))   (visible normals reflected: the Jacobian dh/dwi = 1 / (4 wo.h)).
inline float ggxReflectionCos(const GgxDistribution& ggx, const Vec3& wo, const Vec3& wi, const Vec3& h) {
  return ggx.D(h) * ggx.G(wo, wi) / (4.0f * wo.z);
}
inline float ggxReflectionPdf(const GgxDistribution& ggx, const Vec3& wo, const Vec3& h) {
  const float oh = glm::dot(wo, h);
  return oh > 0.0f ? ggx.pdfVisibleNormal(wo, h) / (4.0f * oh) : 0.0f;
}

}  // namespace lensfarm
