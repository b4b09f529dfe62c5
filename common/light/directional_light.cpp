#include "common/light/directional_light.h"

#include <cmath>
#include <numbers>
#include <sstream>

#include "common/light/point_light.h"
#include "common/math/sampling.h"
#include "common/util/field_reader.h"

namespace lensfarm {

DirectionalLight::DirectionalLight(std::string name, const Vec3& toLight, const Spectrum& irradiance,
                                   double angularDiameter)
    : LightSource(std::move(name)),
      toLight_(toLight),
      frame_(Frame::fromNormal(toLight)),
      irradiance_(irradiance),
      radiance_(irradiance),
      angularDiameter_(angularDiameter) {
  if (angularDiameter > 0.0) {
    const double thetaMax = 0.5 * angularDiameter * std::numbers::pi / 180.0;
    const double half = std::sin(0.5 * thetaMax), sinMax = std::sin(thetaMax);
    sin2Max_ = float(sinMax * sinMax);
    oneMinusCosMax_ = float(2.0 * half * half);  // 1 - cos, without cancellation
    conePdf_ = float(1.0 / (2.0 * std::numbers::pi * (2.0 * half * half)));
    radiance_ = Spectrum(DVec3(irradiance) / (std::numbers::pi * sinMax * sinMax));
  }
}

std::string DirectionalLight::describe() const {
  std::ostringstream s;
  s << "irradiance " << describeSpectrum(irradiance_) << ", ";
  if (isDelta())
    s << "no angular diameter (hard shadows)";
  else
    s << "angular diameter " << angularDiameter_ << " degrees";
  return s.str();
}

double DirectionalLight::powerOverPi(const SceneSphere& sphere) const {
  return double(sphere.radius) * double(sphere.radius) * double(luminance(irradiance_));
}

std::optional<LightSample> DirectionalLight::sample(const Vec3& ref, Vec2 u, const SceneSphere& sphere) const {
  if (isDelta()) return sphere.infiniteSample(ref, toLight_, irradiance_, 1.0f, true);
  // Uniform in the cone: 1 - cos(theta) uniform in [0, 1 - cos theta_max], sin from it directly.
  const float t = u.x * oneMinusCosMax_;
  const float sinTheta = std::sqrt(std::max(0.0f, t * (2.0f - t))), phi = 2.0f * kPi * u.y;
  const Vec3 wi = frame_.toWorld(Vec3(sinTheta * std::cos(phi), sinTheta * std::sin(phi), 1.0f - t));
  return sphere.infiniteSample(ref, wi, radiance_, conePdf_, false);
}

std::shared_ptr<const LightSource> parseDirectionalLight(FieldReader& r, const LightParseContext& context) {
  const Vec3 toLight = r.direction("direction");
  const Spectrum irradiance = r.color("irradiance", kRadianceRange);
  const double diameter = r.number("angular_diameter", 0.0, 0.0, 90.0);
  if (diameter > 0.0 && diameter < 1e-6)  // the cone's density 1 / (2 pi (1 - cos)) stays finite in float
    r.fail(r.field("angular_diameter"), "must be 0 (a delta light) or in [1e-06, 90] degrees");
  auto light = std::make_shared<DirectionalLight>(context.name, toLight, irradiance, diameter);
  if (!isFinite(light->radiance()) || luminance(light->radiance()) > 1e30f)
    r.fail(r.field("angular_diameter"),
           "gives the disk a radiance E / (pi sin^2(d/2)) above 1e30; choose a larger angular diameter or 0 (a delta "
           "light)");
  return light;
}

}  // namespace lensfarm
