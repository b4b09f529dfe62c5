#include "common/material/subsurface.h"

#include <limits>

#include "common/math/sampling.h"
#include "common/medium/medium.h"
#include "common/util/field_reader.h"

namespace lensfarm {

BsdfTraits DiffuseTransmissionBsdf::traits() const {
  BsdfTraits t = BsdfTraits::glossyLobes(true, "subsurface scattering");
  t.choosesLobe = false;
  t.transmits = true;
  return t;
}

// n is on wo's side: transmission is to the other side, f = 1 / pi there.
Spectrum DiffuseTransmissionBsdf::evalCos(const Vec3& n, const Vec3& /*wo*/, const Vec3& wi, bool /*front*/) const {
  const float c = -glm::dot(n, wi);
  return c > 0.0f ? Spectrum(c * kInvPi) : Spectrum(0.0f);
}

float DiffuseTransmissionBsdf::pdf(const Vec3& n, const Vec3& /*wo*/, const Vec3& wi, bool /*front*/) const {
  return cosineHemispherePdf(-glm::dot(n, wi));
}

std::optional<MaterialSample> DiffuseTransmissionBsdf::sample(const Vec3& n, const Vec3& /*wo*/, float /*uLobe*/,
                                                              Vec2 u, bool /*front*/) const {
  const Vec3 local = sampleCosineHemisphere(u);
  if (local.z <= 0.0f) return std::nullopt;
  return MaterialSample{Frame::fromNormal(-n).toWorld(local), Spectrum(1.0f), cosineHemispherePdf(local.z), false};
}

std::shared_ptr<const Bsdf> parseSubsurface(FieldReader& r) {
  const Spectrum albedo = readCoefficients(r, "albedo", Spectrum(0.8f));
  const Spectrum distance = readCoefficients(r, "mean_free_path", Spectrum(std::numeric_limits<float>::quiet_NaN()));
  if (!r.has("mean_free_path")) r.fail(r.field("mean_free_path"), "is required (scene units, one number or three)");
  const float g = float(r.number("g", 0.0, -std::numeric_limits<double>::max(), std::numeric_limits<double>::max()));
  validateSss(albedo, distance, r.file(), r.path());
  validateHenyeyGreensteinG(g, r.file(), r.field("g"));
  const SssCoefficients c = sssCoefficients(albedo, distance);
  // Named after its material ("marble (subsurface)"), for the render report.
  auto medium = std::make_shared<Medium>(r.path().substr(r.path().rfind('.') + 1) + " (subsurface)",
                                         HomogeneousMedium(c.sigmaA, c.sigmaS, g));
  return std::make_shared<DiffuseTransmissionBsdf>(std::move(medium));
}

}  // namespace lensfarm
