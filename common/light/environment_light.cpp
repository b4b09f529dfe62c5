#include "common/light/environment_light.h"

#include <sstream>

#include "common/film/image_io.h"
#include "common/light/point_light.h"
#include "common/texture/image_decode.h"
#include "common/util/error.h"
#include "common/util/field_reader.h"

namespace lensfarm {

EnvironmentLight::EnvironmentLight(std::string source, std::shared_ptr<const EnvironmentMap> map)
    : LightSource("environment"), source_(std::move(source)), map_(std::move(map)) {}

std::string EnvironmentLight::describe() const {
  std::ostringstream s;
  if (map_->isConstant())
    s << "constant radiance " << describeSpectrum(map_->eval(Vec3(0.0f, 1.0f, 0.0f)));
  else
    s << source_ << " " << map_->width() << "x" << map_->height();
  return s.str();
}

double EnvironmentLight::powerOverPi(const SceneSphere& sphere) const {
  return double(sphere.radius) * double(sphere.radius) * double(map_->integralLuminance());
}

std::optional<LightSample> EnvironmentLight::sample(const Vec3& ref, Vec2 u, const SceneSphere& sphere) const {
  const auto s = map_->sample(u);
  if (!s) return std::nullopt;
  return sphere.infiniteSample(ref, s->wi, s->radiance, s->pdf, false);
}

std::shared_ptr<const LightSource> parseEnvironment(FieldReader& r, const AssetLoader& load) {
  const bool hasRadiance = r.has("radiance"), hasFile = r.has("file");
  if (hasRadiance == hasFile)
    r.fail(
        r.field("radiance"),
        "give exactly one of radiance (a constant colour) and file (an equirectangular OpenEXR or Radiance HDR image)");
  if (hasRadiance) {
    const Spectrum radiance = r.color("radiance", kRadianceRange);
    return std::make_shared<EnvironmentLight>("", std::make_shared<EnvironmentMap>(EnvironmentMap::constant(radiance)));
  }
  const double strength = r.number("strength", 1.0, 0.0, 1e30);
  const double rotation = r.number("rotation", 0.0, -360.0, 360.0);
  const std::string relative = r.string("file");
  const LoadedAsset file = load(r, "file", "environment map");
  Image image;
  if (file.bytes.rfind("#?", 0) == 0) {
    // A Radiance HDR (RGBE) image, "#?RADIANCE" or "#?RGBE": decoded by stb_image, linear.
    try {
      const RgbaImage rgba = decodeImage(file.bytes, file.shown, ColorEncoding::kLinear);
      image.width = rgba.width, image.height = rgba.height;
      image.rgb.reserve(3 * size_t(rgba.width) * size_t(rgba.height));
      for (size_t k = 0; k < rgba.texels.size(); k += 4)
        image.rgb.insert(image.rgb.end(), {rgba.texels[k], rgba.texels[k + 1], rgba.texels[k + 2]});
    } catch (const InputError& e) {
      r.fail(r.field("file"), e.what());
    }
  } else {
    try {
      image = decodeExr(file.bytes);
    } catch (const std::exception& e) {
      r.fail(r.field("file"),
             "\"" + file.shown + "\" is not a readable OpenEXR image (nor a Radiance HDR): " + e.what());
    }
  }
  if (auto problem = EnvironmentMap::validate(image)) r.fail(r.field("file"), *problem);
  try {
    return std::make_shared<EnvironmentLight>(
        relative, std::make_shared<EnvironmentMap>(EnvironmentMap::fromImage(image, float(strength), float(rotation))));
  } catch (const InputError& e) {
    // Only strength is left to refuse: a pixel times it overflows.
    const std::string what = e.what();
    r.fail(r.field("strength"), what.substr(e.where().size() + 2));
  }
}

}  // namespace lensfarm
