#include "common/medium/phase_function.h"

#include <cmath>

#include "common/math/sampling.h"
#include "common/util/error.h"

namespace lensfarm {

HenyeyGreenstein::HenyeyGreenstein(float g) : g_(std::clamp(g, -kMaxAbsG, kMaxAbsG)) {}

// With mu = cos(theta), 1 + g^2 - 2 g mu = (1 - g)^2 + 2 g (1 - mu) = (1 + g)^2 - 2 g (1 + mu);
// the form whose terms are both >= 0 for the sign of g is used, so nothing cancels.
float HenyeyGreenstein::density(float g, float oneMinusCos, float onePlusCos) {
  const float s2 =
      g >= 0.0f ? (1.0f - g) * (1.0f - g) + 2.0f * g * oneMinusCos : (1.0f + g) * (1.0f + g) - 2.0f * g * onePlusCos;
  return (1.0f - g) * (1.0f + g) / (4.0f * kPi * s2 * std::sqrt(s2));
}

float HenyeyGreenstein::eval(const Vec3& wo, const Vec3& wi) const {
  // cos(theta) = -dot(wo, wi); for unit vectors 1 - cos = |wo + wi|^2 / 2 and 1 + cos =
  // |wo - wi|^2 / 2, accurate where the directions (nearly) coincide or oppose, which is where a
  // strongly peaked lobe needs them (1 - dot(...) would keep only ~1e-7 of absolute precision).
  const Vec3 sum = wo + wi, diff = wo - wi;
  return density(g_, 0.5f * glm::dot(sum, sum), 0.5f * glm::dot(diff, diff));
}

// The CDF of mu = cos(theta) under HG is
//   xi = F(mu) = (1 - g^2) / (2 g) (1 / s - 1 / (1 + g)),   s = sqrt(1 + g^2 - 2 g mu),
// so s = (1 - g^2) / D with D = 1 + g (2 xi - 1), and the textbook inverse
//   mu = (1 + g^2 - s^2) / (2 g)
// divides a difference of nearly equal numbers by g -> 0 (pbrt switches to isotropic below
// |g| < 1e-3, a visible kink). Factoring the two differences of squares instead gives
//   1 - mu = (s^2 - (1 - g)^2) / (2 g) = (1 - g) (1 - xi) (s + 1 - g) / D,
//   1 + mu = ((1 + g)^2 - s^2) / (2 g) = (1 + g) xi (1 + g + s) / D,
// products of positive terms, exact at g = 0 (1 - mu = 2 (1 - xi), 1 + mu = 2 xi: isotropic) and
// accurate at both ends of mu for |g| up to kMaxAbsG. D is formed as a sum of positive terms too.
void HenyeyGreenstein::sampleCos(float g, float xi, float* oneMinusCos, float* onePlusCos) {
  const float d = g >= 0.0f ? (1.0f - g) + 2.0f * g * xi : (1.0f + g) - 2.0f * g * (1.0f - xi);
  const float s = (1.0f - g) * (1.0f + g) / d;
  *oneMinusCos = std::clamp((1.0f - g) * (1.0f - xi) * (s + 1.0f - g) / d, 0.0f, 2.0f);
  *onePlusCos = std::clamp((1.0f + g) * xi * (1.0f + g + s) / d, 0.0f, 2.0f);
}

PhaseSample HenyeyGreenstein::sample(const Vec3& wo, Vec2 u) const {
  float oneMinus, onePlus;
  sampleCos(g_, u.x, &oneMinus, &onePlus);
  const float cosTheta = oneMinus < onePlus ? 1.0f - oneMinus : onePlus - 1.0f;
  const float sinTheta = std::sqrt(std::max(0.0f, oneMinus * onePlus));
  const float phi = 2.0f * kPi * u.y;
  // theta is measured from the outgoing propagation direction wo; wi points the other way
  // (light arrives along -wi), hence the minus sign.
  const Vec3 local(sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta);
  const Vec3 wi = -Frame::fromNormal(wo).toWorld(local);
  return PhaseSample{wi, density(g_, oneMinus, onePlus)};
}

void validateHenyeyGreensteinG(float g, const std::string& where, const std::string& field) {
  if (!std::isfinite(g) || !(g > -1.0f && g < 1.0f))
    throw InputError(where, field + ": the Henyey-Greenstein g must lie in (-1, 1), got " + std::to_string(g));
}

}  // namespace lensfarm
