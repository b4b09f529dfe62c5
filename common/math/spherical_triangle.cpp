#include "common/math/spherical_triangle.h"

#include <algorithm>
#include <cmath>

namespace lensfarm {

namespace {
// The unit vector along the part of v orthogonal to unit vector w (Gram-Schmidt); zero where v is
// parallel to w.
DVec3 orthogonalTo(const DVec3& v, const DVec3& w) {
  const DVec3 o = v - glm::dot(v, w) * w;
  const double length = glm::length(o);
  return length > 0.0 ? o / length : DVec3(0.0);
}
}  // namespace

std::optional<SphericalTriangle> SphericalTriangle::seen(const Vec3& p, const Vec3& v0, const Vec3& v1,
                                                         const Vec3& v2) {
  const DVec3 origin(p);
  const DVec3 d0 = DVec3(v0) - origin, d1 = DVec3(v1) - origin, d2 = DVec3(v2) - origin;
  const double l0 = glm::length(d0), l1 = glm::length(d1), l2 = glm::length(d2);
  if (!(l0 > 0.0 && l1 > 0.0 && l2 > 0.0)) return std::nullopt;  // p on a vertex
  SphericalTriangle t;
  t.a = d0 / l0, t.b = d1 / l1, t.c = d2 / l2;
  // Solid angle by Van Oosterom & Strackee (1983): tan(Omega / 2) = |a . (b x c)| / (1 + a.b +
  // b.c + c.a), accurate for small triangles, where the angle sum cancels.
  const double triple = std::abs(glm::dot(t.a, glm::cross(t.b, t.c)));
  t.solidAngle = 2.0 * std::atan2(triple, 1.0 + glm::dot(t.a, t.b) + glm::dot(t.b, t.c) + glm::dot(t.c, t.a));
  // The angle at a is the dihedral angle between the planes of the arcs a-b and a-c.
  const DVec3 nab = glm::cross(t.a, t.b), nac = glm::cross(t.a, t.c);
  const double lab = glm::length(nab), lac = glm::length(nac);
  if (!(t.solidAngle > 0.0) || !std::isfinite(t.solidAngle) || !(lab > 0.0 && lac > 0.0)) return std::nullopt;
  const DVec3 uab = nab / lab, uac = nac / lac;
  t.cosAlpha = std::clamp(glm::dot(uab, uac), -1.0, 1.0);
  t.sinAlpha = glm::length(glm::cross(uab, uac));
  if (!(t.sinAlpha > 0.0)) return std::nullopt;
  return t;
}

DVec3 SphericalTriangle::sample(Vec2 u) const {
  // Arvo's construction. The sub-triangle (a, b, c') of area A' = u.x Omega has, by Girard's
  // theorem and the spherical law of cosines, its vertex c' on the arc a-c at cos|a c'| = q:
  const double area = double(u.x) * solidAngle;
  const double sinArea = std::sin(area), cosArea = std::cos(area);
  const double s = sinArea * cosAlpha - cosArea * sinAlpha;  // sin(A' - alpha)
  const double t = cosArea * cosAlpha + sinArea * sinAlpha;  // cos(A' - alpha)
  const double uu = t - cosAlpha;
  const double vv = s + sinAlpha * glm::dot(a, b);  // cos of the arc a-b
  double q = ((vv * t - uu * s) * cosAlpha - vv) / ((vv * s + uu * t) * sinAlpha);
  q = std::isfinite(q) ? std::clamp(q, -1.0, 1.0) : 1.0;
  const DVec3 cPrime = q * a + std::sqrt(std::max(0.0, (1.0 - q) * (1.0 + q))) * orthogonalTo(c, a);
  // Then the point on the arc b-c' whose cosine to b is uniform in [cos|b c'|, 1]: z = 1 - u.y (1 - b.c').
  const double oneMinusZ = double(u.y) * (1.0 - glm::dot(cPrime, b));
  const double z = 1.0 - oneMinusZ;
  const DVec3 w = z * b + std::sqrt(std::max(0.0, oneMinusZ * (1.0 + z))) * orthogonalTo(cPrime, b);
  return glm::normalize(w);
}

}  // namespace lensfarm
