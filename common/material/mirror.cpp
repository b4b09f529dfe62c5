#include "common/material/mirror.h"

#include "common/math/sampling.h"
#include "common/util/field_reader.h"

namespace lensfarm {

BsdfTraits MirrorBsdf::traits() const { return BsdfTraits::deltaLobes(reflectance_, "mirror"); }

std::optional<MaterialSample> MirrorBsdf::sample(const Vec3& n, const Vec3& wo, float /*uLobe*/, Vec2 /*u*/,
                                                 bool /*front*/) const {
  return MaterialSample{reflect(wo, n), reflectance_, 0.0f, true};
}

BsdfTraits RippledMirrorBsdf::traits() const { return BsdfTraits::deltaLobes(reflectance_, "rippled mirror"); }

std::optional<MaterialSample> RippledMirrorBsdf::sample(const Vec3& n, const Vec3& wo, float /*uLobe*/, Vec2 u,
                                                        bool /*front*/) const {
  // Reflect about a normal tilted by a random slope of at most `ripple` (a rippled glass
  // surface), then fold any direction that would leave below the surface back above it. The fold
  // keeps every ray (energy = reflectance exactly) and the direction strictly in the upper
  // hemisphere, however grazing wo is.
  const Frame frame = Frame::fromNormal(n);
  const Vec2 slope = sampleConcentricDisk(u) * ripple_;
  const Vec3 tilted = glm::normalize(frame.toWorld(Vec3(slope.x, slope.y, 1.0f)));
  Vec3 wi = reflect(wo, tilted);
  const float below = glm::dot(wi, n);
  if (below < 0.0f) wi -= 2.0f * below * n;
  return MaterialSample{glm::normalize(wi), reflectance_, 0.0f, true};
}

std::shared_ptr<const Bsdf> parseMirror(FieldReader& r) {
  return std::make_shared<MirrorBsdf>(r.color("reflectance", Spectrum(1.0f), kReflectanceRange));
}

std::shared_ptr<const Bsdf> parseRippledMirror(FieldReader& r) {
  const Spectrum reflectance =
      r.color("reflectance", Spectrum(0.5f), kReflectanceRange);  // 2013 report §4.2: halves it
  return std::make_shared<RippledMirrorBsdf>(reflectance, float(r.number("ripple", 0.02, 0.0, 1.0)));
}

}  // namespace lensfarm
