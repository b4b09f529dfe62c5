#pragma once
// Fresnel reflectance of smooth boundaries for unpolarised light, per wavelength (the renderer
// calls these once per RGB channel where the index varies).
#include <algorithm>
#include <cmath>

namespace lensfarm {

// Fresnel reflectance of a smooth conductor of complex index eta + i k (relative to the outside
// medium, air) for unpolarised light at cosine cosI (pbrt-v3 FrConductor; Born & Wolf §14.2).
inline float fresnelConductor(float cosI, float eta, float k) {
  cosI = std::min(1.0f, std::abs(cosI));
  const float cos2 = cosI * cosI, sin2 = 1.0f - cos2;
  const float eta2 = eta * eta, k2 = k * k;
  const float t0 = eta2 - k2 - sin2;
  const float a2b2 = std::sqrt(t0 * t0 + 4.0f * eta2 * k2);
  const float t1 = a2b2 + cos2;
  const float a = std::sqrt(std::max(0.0f, 0.5f * (a2b2 + t0)));
  const float t2 = 2.0f * cosI * a;
  const float rs = (t1 - t2) / (t1 + t2);
  const float t3 = cos2 * a2b2 + sin2 * sin2;
  const float t4 = t2 * sin2;
  const float rp = rs * (t3 - t4) / (t3 + t4);
  return 0.5f * (rs + rp);
}

// Fresnel reflectance of a smooth dielectric boundary for unpolarised light (the mean of the s
// and p reflectances, Born & Wolf §1.5.2), at cosine cosI of the incident direction with the
// normal on its side and relative index eta = n_transmitted / n_incident. 1 beyond the critical
// angle (total internal reflection). cosTransmitted receives |cos| of the refracted direction.
inline float fresnelDielectric(float cosI, float eta, float& cosTransmitted) {
  cosI = std::min(1.0f, std::abs(cosI));
  const float sin2T = (1.0f - cosI * cosI) / (eta * eta);
  if (sin2T >= 1.0f) {
    cosTransmitted = 0.0f;
    return 1.0f;
  }
  const float cosT = std::sqrt(1.0f - sin2T);
  const float rParallel = (eta * cosI - cosT) / (eta * cosI + cosT);
  const float rPerpendicular = (cosI - eta * cosT) / (cosI + eta * cosT);
  cosTransmitted = cosT;
  return 0.5f * (rParallel * rParallel + rPerpendicular * rPerpendicular);
}

}  // namespace lensfarm
