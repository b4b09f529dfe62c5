#include "common/light/spot_light.h"

#include <cmath>
#include <numbers>
#include <sstream>

#include "common/util/field_reader.h"

namespace lensfarm {

namespace {
double radians(double degrees) { return degrees * std::numbers::pi / 180.0; }
}  // namespace

SpotLight::SpotLight(std::string name, const Vec3& position, const Vec3& axis, const Spectrum& intensity,
                     double coneAngle, double falloffStart)
    : LightSource(std::move(name)),
      position_(position),
      axis_(axis),
      intensity_(intensity),
      coneAngle_(coneAngle),
      falloffStart_(falloffStart),
      cosTotal_(float(std::cos(radians(coneAngle)))),
      cosFalloffStart_(float(std::cos(radians(falloffStart)))) {}

std::string SpotLight::describe() const {
  std::ostringstream s;
  s << "intensity " << describeSpectrum(intensity_) << ", cone " << coneAngle_ << " degrees, falloff from "
    << falloffStart_ << " degrees";
  return s.str();
}

double SpotLight::powerOverPi(const SceneSphere&) const {
  return 2.0 * double(luminance(intensity_)) * (1.0 - 0.5 * (double(cosFalloffStart_) + double(cosTotal_)));
}

std::optional<LightBounds> SpotLight::bounds() const {
  return LightBounds{position_,
                     position_,
                     luminance(intensity_),
                     DirectionCone{axis_, cosFalloffStart_},
                     float(std::cos(radians(coneAngle_ - falloffStart_))),
                     false};
}

std::optional<LightSample> SpotLight::sample(const Vec3& ref, Vec2, const SceneSphere&) const {
  const Vec3 toRef = ref - position_;
  const float dist2 = glm::dot(toRef, toRef);
  if (!(dist2 > 0.0f)) return std::nullopt;
  const float f = falloff(toRef / std::sqrt(dist2));
  if (!(f > 0.0f)) return std::nullopt;
  return pointLightSample(position_, intensity_ * f, ref);
}

std::shared_ptr<const LightSource> parseSpotLight(FieldReader& r, const LightParseContext& context) {
  const DVec3 position = r.dvec3("position");
  const bool hasLookAt = r.has("look_at"), hasDirection = r.has("direction");
  if (hasLookAt == hasDirection) r.fail(r.field("look_at"), "give exactly one of look_at and direction");
  Vec3 axis;
  if (hasLookAt) {
    const DVec3 lookAt = r.dvec3("look_at");
    if (lookAt == position) r.fail(r.field("look_at"), "equals position: the spot's direction is undefined");
    axis = r.toDirection(lookAt - position, r.field("look_at"));
  } else {
    axis = r.direction("direction");
  }
  const Spectrum intensity = r.color("intensity", kRadianceRange);
  const double cone = r.number("cone_angle", 0.0, 90.0);
  if (!(cone > 0.0)) r.fail(r.field("cone_angle"), "must be in (0, 90] degrees (the half-angle of the cone), got 0");
  const double falloffStart = r.number("falloff_start", cone, 0.0, 90.0);
  if (falloffStart > cone) {
    std::ostringstream why;
    why << "must be at most cone_angle (" << cone << " degrees), got " << falloffStart;
    r.fail(r.field("falloff_start"), why.str());
  }
  return std::make_shared<SpotLight>(context.name, context.toRenderSpace(position, r.field("position")), axis,
                                     intensity, cone, falloffStart);
}

}  // namespace lensfarm
