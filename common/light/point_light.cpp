#include "common/light/point_light.h"

#include <sstream>

#include "common/util/field_reader.h"

namespace lensfarm {

std::string describeSpectrum(const Spectrum& s) {
  std::ostringstream out;
  if (s.r == s.g && s.g == s.b)
    out << s.r;
  else
    out << "[" << s.r << ", " << s.g << ", " << s.b << "]";
  return out.str();
}

std::shared_ptr<const LightSource> parsePointLight(FieldReader& r, const LightParseContext& context) {
  const Vec3 position = context.toRenderSpace(r.dvec3("position"), r.field("position"));
  const Spectrum intensity = r.color("intensity", kRadianceRange);
  return std::make_shared<PointLight>(context.name, position, intensity);
}

}  // namespace lensfarm
