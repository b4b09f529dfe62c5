#pragma once
// The Henyey-Greenstein phase function (Henyey & Greenstein 1941, "Diffuse radiation in the
// galaxy", ApJ 93:70): the angular distribution of light scattered inside a medium.
//
// Convention (pbrt-v4's, PBR 4th ed. §11.3.1, so that a phase function reads like a BSDF here):
// wo and wi both point AWAY from the scattering point; wo towards the previous path vertex (the
// camera side), wi towards the next one. Light travels along -wi, scatters, and leaves along wo,
// so the angle theta between the incoming and outgoing PROPAGATION directions is given by
//     cos(theta) = dot(-wi, wo) = -dot(wo, wi),
// and
//     p(wo, wi) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos(theta))^(3/2))          [HG41 eq. 3]
// with g = <cos(theta)> the mean cosine: g > 0 scatters forward (wi ~ -wo), g < 0 backward
// (wi ~ wo), g = 0 is isotropic (1 / 4 pi). p is a density in solid angle over the whole sphere,
// integrates to 1 and is symmetric in wo and wi. eval, pdf and sample all use this convention.
//
// g is restricted to (-1, 1): at |g| = 1 the distribution is a Dirac delta with no density.
// Inside, |g| is clamped to kMaxAbsG = 0.999 (validateHenyeyGreensteinG rejects |g| >= 1): the
// peak density (1 + |g|) / (4 pi (1 - |g|)^2) is already ~1.6e5 at 0.999 and grows without bound,
// while a float g near 1 is known to only ~6e-8, so 1 - |g| (everything depends on it) would carry
// a relative error above 1e-4 beyond that; pbrt-v4 clamps to 0.99 for the same reason.
#include <string>

#include "common/math/vec.h"

namespace lensfarm {

inline constexpr float kMaxAbsG = 0.999f;

struct PhaseSample {
  Vec3 wi;    // unit, pointing away from the scattering point
  float pdf;  // = p(wo, wi): sampling is exact, so the weight p / pdf is 1
};

class HenyeyGreenstein {
 public:
  explicit HenyeyGreenstein(float g);
  float g() const { return g_; }  // after clamping to [-kMaxAbsG, kMaxAbsG]
  // p(wo, wi) for unit wo, wi (convention above).
  float eval(const Vec3& wo, const Vec3& wi) const;
  float pdf(const Vec3& wo, const Vec3& wi) const { return eval(wo, wi); }
  // Draws wi with density p(wo, .) from u in [0,1)^2 by inverting the CDF of cos(theta).
  PhaseSample sample(const Vec3& wo, Vec2 u) const;

  // The density as a function of the propagation angle, given 1 - cos(theta) and 1 + cos(theta)
  // separately (each exact near its own end, where cos(theta) itself has lost its digits).
  static float density(float g, float oneMinusCos, float onePlusCos);
  // The inverse CDF: cos(theta) as 1 - (1 - cos) and (1 + cos) for xi in [0, 1], without the
  // division by g of the textbook formula (see the .cpp), so g = 0 needs no special case.
  static void sampleCos(float g, float xi, float* oneMinusCos, float* onePlusCos);

 private:
  float g_;
};

// Throws InputError(where, field + ": ...") unless g is finite and in (-1, 1).
void validateHenyeyGreensteinG(float g, const std::string& where, const std::string& field);

}  // namespace lensfarm
