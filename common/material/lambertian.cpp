#include "common/material/lambertian.h"

#include "common/util/field_reader.h"

namespace lensfarm {

BsdfTraits LambertianBsdf::traits() const { return BsdfTraits::lambertianLobe(albedo_); }

Spectrum LambertianBsdf::evalCos(const Vec3& n, const Vec3& /*wo*/, const Vec3& wi, bool /*front*/) const {
  return lambertianEvalCos(albedo_, n, wi);
}

float LambertianBsdf::pdf(const Vec3& n, const Vec3& /*wo*/, const Vec3& wi, bool /*front*/) const {
  return lambertianPdf(n, wi);
}

std::optional<MaterialSample> LambertianBsdf::sample(const Vec3& n, const Vec3& /*wo*/, float /*uLobe*/, Vec2 u,
                                                     bool /*front*/) const {
  return sampleLambertian(albedo_, n, u);
}

std::shared_ptr<const Bsdf> parseLambertian(FieldReader& r) {
  return std::make_shared<LambertianBsdf>(r.color("albedo", kReflectanceRange));
}

}  // namespace lensfarm
