#pragma once
// The types of a scene's `lights` entries beyond "quad" (whose triangles the scene loader makes,
// scene/scene_loader.cpp), registered in one place: kLightTypes in light_types.cpp. A new type
// adds its own header/source pair (its LightSource and its parse function) and one line there.
// The environment is the scene's top-level "environment" (light/environment_light.h).
#include <memory>
#include <string>
#include <vector>

#include "common/light/light_source.h"

namespace lensfarm {

using LightParser = std::shared_ptr<const LightSource> (*)(FieldReader& r, const LightParseContext& context);

// The parser of lights of `type`, or null for a type not registered here.
LightParser findLightType(const std::string& type);
// The names of the registered types, in registration order.
std::vector<std::string> lightTypeNames();

}  // namespace lensfarm
