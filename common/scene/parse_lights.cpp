// SceneParser, lights: the scene's `lights` (quad lights as emissive meshes, the other types
// through light/light_types.h), the lights the models bring, and the `environment`.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "common/light/environment_light.h"
#include "common/light/light_types.h"
#include "common/math/triangle.h"
#include "common/scene/scene_parser.h"
#include "common/util/field_reader.h"

namespace lensfarm {

void SceneParser::parseLights(FieldReader& top) {
  if (!top.has("lights")) return;
  const json& lights = top.raw("lights");
  if (!lights.is_array()) top.fail("lights", "must be an array");
  for (size_t i = 0; i < lights.size(); ++i) parseLightEntry(lights[i], "lights[" + std::to_string(i) + "]");
}

void SceneParser::addModelLights() {
  for (const ModelImport& m : imports_)
    for (size_t k = 0; k < m.model.lights.size(); ++k)
      parseLightEntry(m.model.lights[k],
                      m.field + " light \"" + m.model.lights[k].value("name", std::to_string(k)) + "\"");
}

void SceneParser::parseLightEntry(const json& entry, const std::string& path) {
  {
    FieldReader r(entry, path, fileName_);
    const std::string type = r.string("type");
    if (type != "quad") {
      const LightParser parseLight = findLightType(type);
      if (!parseLight) {
        std::string expected = "quad";
        const std::vector<std::string> names = lightTypeNames();
        for (size_t k = 0; k < names.size(); ++k) expected += (k + 1 == names.size() ? " or " : ", ") + names[k];
        r.fail(r.field("type"), "unknown light type \"" + type + "\" (expected " + expected + ")");
      }
      const LightParseContext context{r.string("name", path), [this](const DVec3& world, const std::string& field) {
                                        return toRenderSpace(world, field);
                                      }};
      scene_.lights.push_back(parseLight(r, context));
      r.finish();
      return;
    }
    const Spectrum radiance = r.color("radiance", kRadianceRange);
    const Material m(path, nullptr, radiance, r.boolean("two_sided", false));
    MeshInput mesh;
    mesh.mesh.name = r.string("name", path);
    mesh.mesh.visibleToCamera = r.boolean("visible_to_camera", true);
    const DVec3 corner = r.dvec3("corner"), e1 = r.dvec3("edge1"), e2 = r.dvec3("edge2");
    r.finish();
    // Divided by their largest components first, so that no product overflows.
    const DVec3 n = glm::cross(e1 / std::max(largestAbs(e1), 1e-300), e2 / std::max(largestAbs(e2), 1e-300));
    if (!(glm::length(n) > 0.0)) r.fail(path + ".edge2", "the quad has zero area");
    scene_.materials.push_back(m);
    addQuad(mesh, corner, e1, e2, uint32_t(scene_.materials.size() - 1));
    if (addMesh(std::move(mesh), path) != 2)
      r.fail(path + ".edge2", "the quad has zero area in single precision, " +
                                  shortNumber(glm::length(toRenderSpace(corner, path + ".corner"))) +
                                  " from the camera");
    holdQuadPower(scene_.meshes.back(), glm::length(glm::cross(e1, e2)), scene_.materials.back());
  }
}

void SceneParser::holdQuadPower(const TriangleMesh& placed, double writtenArea, Material& material) {
  double floatArea = 0.0;
  for (size_t tri = 0; tri < placed.triangleCount(); ++tri)
    floatArea += triangleArea(placed.positions[placed.indices[3 * tri]], placed.positions[placed.indices[3 * tri + 1]],
                              placed.positions[placed.indices[3 * tri + 2]]);
  const double ratio = writtenArea / floatArea;
  if (std::isfinite(ratio) && std::abs(ratio - 1.0) > 1e-4) material.emission *= float(ratio);
}

void SceneParser::parseEnvironment(FieldReader& top) {
  if (!top.has("environment")) return;
  FieldReader r(top.raw("environment"), "environment", fileName_);
  scene_.lights.push_back(
      lensfarm::parseEnvironment(r, [this](FieldReader& reader, const std::string& key, const std::string& kind) {
        return readAssetFile(reader, key, kind);
      }));
  r.finish();
}

}  // namespace lensfarm
