#include "common/light/light_types.h"

#include "common/light/directional_light.h"
#include "common/light/point_light.h"
#include "common/light/spot_light.h"

namespace lensfarm {

namespace {
struct LightType {
  const char* name;
  LightParser parse;
};

// The one registration point of light types (besides "quad", an emitting shape).
constexpr LightType kLightTypes[] = {
    {"point", parsePointLight},
    {"spot", parseSpotLight},
    {"directional", parseDirectionalLight},
};
}  // namespace

LightParser findLightType(const std::string& type) {
  for (const LightType& t : kLightTypes)
    if (type == t.name) return t.parse;
  return nullptr;
}

std::vector<std::string> lightTypeNames() {
  std::vector<std::string> names;
  for (const LightType& t : kLightTypes) names.emplace_back(t.name);
  return names;
}

}  // namespace lensfarm
