#include "common/light/light_bounds.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace lensfarm {

namespace {
constexpr float kPiF = std::numbers::pi_v<float>;

float safeSqrt(float x) { return std::sqrt(std::max(x, 0.0f)); }
float safeAcos(float x) { return std::acos(std::clamp(x, -1.0f, 1.0f)); }

// cos(max(0, a - b)) and sin(max(0, a - b)) from the sines and cosines of a and b, both in [0, pi].
float cosMinusClamped(float sinA, float cosA, float sinB, float cosB) {
  return cosA > cosB ? 1.0f : cosA * cosB + sinA * sinB;
}
float sinMinusClamped(float sinA, float cosA, float sinB, float cosB) {
  return cosA > cosB ? 0.0f : sinA * cosB - cosA * sinB;
}

// v rotated by `angle` about the unit axis k (Rodrigues' formula).
Vec3 rotate(const Vec3& v, const Vec3& k, float angle) {
  const float c = std::cos(angle), s = std::sin(angle);
  return v * c + glm::cross(k, v) * s + k * (glm::dot(k, v) * (1.0f - c));
}
}  // namespace

DirectionCone DirectionCone::merge(const DirectionCone& a, const DirectionCone& b) {
  if (a.empty()) return b;
  if (b.empty()) return a;
  // The cone around both: its half-angle covers a's, the angle between the axes and b's.
  const float thetaA = safeAcos(a.cosTheta), thetaB = safeAcos(b.cosTheta);
  const float thetaD = safeAcos(glm::dot(a.w, b.w));
  if (std::min(thetaD + thetaB, kPiF) <= thetaA) return a;
  if (std::min(thetaD + thetaA, kPiF) <= thetaB) return b;
  const float thetaO = 0.5f * (thetaA + thetaD + thetaB);
  if (thetaO >= kPiF) return sphere();
  // Turn a's axis towards b's by thetaO - thetaA.
  const Vec3 axis = glm::cross(a.w, b.w);
  const float length = glm::length(axis);
  if (!(length > 0.0f)) return sphere();  // opposite axes
  return DirectionCone{glm::normalize(rotate(a.w, axis / length, thetaO - thetaA)), std::cos(thetaO)};
}

LightBounds LightBounds::merge(const LightBounds& a, const LightBounds& b) {
  if (a.intensity == 0.0f) return b;
  if (b.intensity == 0.0f) return a;
  LightBounds m;
  m.lo = glm::min(a.lo, b.lo), m.hi = glm::max(a.hi, b.hi);
  m.intensity = a.intensity + b.intensity;
  m.normals = DirectionCone::merge(a.normals, b.normals);
  m.cosThetaE = std::min(a.cosThetaE, b.cosThetaE);
  m.twoSided = a.twoSided || b.twoSided;
  return m;
}

LightCluster::LightCluster(const LightBounds& b)
    : centre(b.centroid()),
      radius(0.5f * glm::length(b.hi - b.lo)),
      w(b.normals.w),
      cosO(std::clamp(b.normals.cosTheta, -1.0f, 1.0f)),
      sinO(safeSqrt(1.0f - cosO * cosO)),
      cosE(b.cosThetaE),
      intensity(b.intensity),
      twoSided(b.twoSided ? 1u : 0u) {}

float LightCluster::importance(const Vec3& p) const {
  const Vec3 toP = p - centre;
  const float dist2 = glm::dot(toP, toP);
  const float d2 = std::max(dist2, radius * radius);
  if (!(d2 > 0.0f)) return intensity;  // a point light at p itself: any positive value serves
  // theta_w: the angle between the cone's axis and the direction from the box's centre to p.
  const float length = std::sqrt(dist2);
  float cosW = length > 0.0f ? glm::dot(w, toP) / length : 1.0f;
  if (twoSided) cosW = std::abs(cosW);
  cosW = std::clamp(cosW, -1.0f, 1.0f);
  const float sinW = safeSqrt(1.0f - cosW * cosW);
  // theta_b: the half-angle the box's bounding sphere subtends at p (pi inside it).
  float cosB = -1.0f, sinB = 0.0f;
  if (length > radius) sinB = radius / length, cosB = safeSqrt(1.0f - sinB * sinB);
  // theta' = max(0, theta_w - theta_o - theta_b): the smallest angle between a normal of the cone
  // and a direction from the box to p.
  const float cosX = cosMinusClamped(sinW, cosW, sinO, cosO), sinX = sinMinusClamped(sinW, cosW, sinO, cosO);
  const float cosThetaP = cosMinusClamped(sinX, cosX, sinB, cosB);
  // No emitter faces p (at theta_e itself emission has fallen to zero: a positive estimate there
  // only keeps a hard-edged spot, theta_e = 0, from being never chosen).
  if (cosThetaP < cosE) return 0.0f;
  // Clamped to the largest float, so that clusters compare even where intensity / d2 overflows.
  return std::clamp(intensity * cosThetaP / d2, 0.0f, std::numeric_limits<float>::max());
}

}  // namespace lensfarm
