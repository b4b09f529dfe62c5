#include "util/file_contents.h"
#include "scene/scene_loader.h"

#include <tiny_obj_loader.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "light/environment_light.h"
#include "light/light_types.h"
#include "math/triangle.h"
#include "scene/coplanar.h"
#include "scene/field_reader.h"
#include "scene/obj_check.h"
#include "util/error.h"
#include "util/hash.h"

namespace lensfarm {

namespace fs = std::filesystem;

namespace {

std::string shortNumber(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

std::string showVec3(const DVec3& v) {
  return "[" + shortNumber(v.x) + ", " + shortNumber(v.y) + ", " + shortNumber(v.z) + "]";
}

// ---------------------------------------------------------------------------------------------
// Transform: scale, then rotate, then translate (all optional), in double like the positions.
struct Transform {
  glm::dmat4 matrix{1.0};
  DVec3 apply(const DVec3& p) const { return DVec3(matrix * glm::dvec4(p, 1.0)); }
  bool flipsHandedness() const { return glm::determinant(glm::dmat3(matrix)) < 0.0; }
};

Transform readTransform(FieldReader& parent, const std::string& key) {
  Transform t;
  if (!parent.has(key)) return t;
  FieldReader r(parent.raw(key), parent.field(key), parent.file());
  glm::dmat4 scale(1.0), rotate(1.0), translate(1.0);
  if (r.has("scale")) {
    const json& s = r.raw("scale");
    const DVec3 k = s.is_number() ? DVec3(r.number("scale")) : r.dvec3("scale");
    if (k.x == 0.0 || k.y == 0.0 || k.z == 0.0) r.fail(r.field("scale"), "must not be zero");
    scale = glm::dmat4(glm::dvec4(k.x, 0, 0, 0), glm::dvec4(0, k.y, 0, 0), glm::dvec4(0, 0, k.z, 0), glm::dvec4(0, 0, 0, 1));
  }
  if (r.has("rotate")) {
    FieldReader rot(r.raw("rotate"), r.field("rotate"), r.file());
    const DVec3 axis = rot.dvec3("axis");
    // Divided by its largest component first, so that no length overflows (an axis of 1e300).
    const double largest = largestAbs(axis);
    if (!(largest > 0.0)) rot.fail(rot.field("axis"), "must not be zero");
    const double degrees = rot.number("degrees", -360.0, 360.0);
    rot.finish();
    rotate = glm::rotate(glm::dmat4(1.0), glm::radians(degrees), glm::normalize(axis / largest));
  }
  if (r.has("translate")) {
    const DVec3 d = r.dvec3("translate");
    translate[3] = glm::dvec4(d, 1.0);
  }
  r.finish();
  t.matrix = translate * rotate * scale;
  return t;
}

// ---------------------------------------------------------------------------------------------
class SceneParser {
 public:
  SceneParser(const json& root, const fs::path& file, AssetReader readAsset)
      : root_(root), file_(file), fileName_(file.string()), readAsset_(std::move(readAsset)) {}

  Scene parse() {
    FieldReader top(root_, "", fileName_);
    const std::string format = top.string("format");
    if (format != kSceneFormat)
      top.fail("format", "unsupported format \"" + format + "\" (this renderer reads \"" + kSceneFormat + "\")");
    scene_.file = file_;
    hash_.update(root_.dump());

    parseRender(top);
    parseMaterials(top);
    parseCamera(top);
    parseShapes(top);
    parseLights(top);
    parseEnvironment(top);
    top.finish();
    bringFlushLightsForward(scene_);  // the coplanar rule (scene/coplanar.h)

    if (shapeTriangles_ == 0) top.fail("shapes", "the scene has no triangles (lights alone show nothing)");
    if (shapeTriangles_ > kMaxTriangles)
      top.fail("shapes", std::to_string(shapeTriangles_) + " triangles exceed the limit of " + std::to_string(kMaxTriangles));
    scene_.hash = hash_.hexDigest();
    return std::move(scene_);
  }

 private:
  void parseRender(FieldReader& top) {
    FieldReader r(top.raw("render"), "render", fileName_);
    RenderSettings& s = scene_.render;
    const json& res = r.raw("resolution");
    if (!res.is_array() || res.size() != 2 || !res[0].is_number_integer() || !res[1].is_number_integer())
      r.fail("render.resolution", "must be [width, height] in pixels");
    const int64_t w = res[0].get<int64_t>(), h = res[1].get<int64_t>();
    if (w < 1 || h < 1 || w > kMaxResolution || h > kMaxResolution)
      r.fail("render.resolution", "each side must be in [1, " + std::to_string(kMaxResolution) + "]");
    s.width = int(w);
    s.height = int(h);
    s.samplesPerPixel = r.integer("samples_per_pixel", 1, kMaxSamplesPerPixel);
    s.maxBounces = int(r.integer("max_bounces", 2, 0, kMaxBounces));
    s.seed = r.integer("seed", 0, 0, std::numeric_limits<uint64_t>::max());
    const std::string integrator = r.string("integrator", "nee_mis");
    if (!parseIntegratorName(integrator, s.integrator))
      r.fail("render.integrator", "unknown integrator \"" + integrator + "\" (expected nee_mis, nee or naive)");
    const std::string sampler = r.string("sampler", "sobol");
    if (!parseSamplerName(sampler, s.sampler))
      r.fail("render.sampler", "unknown sampler \"" + sampler + "\" (expected sobol, stratified or independent)");
    s.russianRoulette = r.boolean("russian_roulette", false);
    s.targetError = r.number("target_error", 0.0, 0.0, 0.999);
    s.timeLimitSeconds = r.number("time_limit", 0.0, 0.0, 1e9);
    s.mirrorBouncesCount = r.boolean("mirror_bounces_count", false);
    s.samplesPerUnit = uint32_t(r.integer("samples_per_unit", 0, 0, 1u << 20));
    if (r.has("exposure")) {
      FieldReader e(r.raw("exposure"), "render.exposure", fileName_);
      s.exposure.ev = e.number("ev", 0.0, -64.0, 64.0);
      const std::string tm = e.string("tone_map", "reinhard");
      if (tm == "reinhard")
        s.exposure.toneMap = ToneMap::kReinhard;
      else if (tm == "clamp")
        s.exposure.toneMap = ToneMap::kClamp;
      else
        e.fail("render.exposure.tone_map", "unknown tone map \"" + tm + "\" (expected reinhard or clamp)");
      e.finish();
    }
    r.finish();
  }

  void parseMaterials(FieldReader& top) {
    const json& mats = top.raw("materials");
    if (!mats.is_object() || mats.empty()) top.fail("materials", "must be an object of named materials");
    for (auto it = mats.begin(); it != mats.end(); ++it) {
      FieldReader r(it.value(), "materials." + it.key(), fileName_);
      Material m = parseMaterial(it.key(), r);
      materialIndex_[m.name] = uint32_t(scene_.materials.size());
      scene_.materials.push_back(m);
    }
  }

  uint32_t materialRef(FieldReader& r, const std::string& key) {
    const std::string name = r.string(key);
    return lookupMaterial(r, r.field(key), name);
  }
  uint32_t lookupMaterial(FieldReader& r, const std::string& field, const std::string& name) {
    auto it = materialIndex_.find(name);
    if (it == materialIndex_.end()) r.fail(field, "unknown material \"" + name + "\" (not in materials)");
    return it->second;
  }

  // A number that must be > 0 (camera lengths).
  static double positive(FieldReader& r, const std::string& key) {
    const double x = r.number(key);
    if (!(x > 0.0)) r.fail(r.field(key), "must be > 0, got " + shortNumber(x));
    return x;
  }

  void parseCamera(FieldReader& top) {
    FieldReader r(top.raw("camera"), "camera", fileName_);
    ThinLensParams& p = scene_.cameraParams;
    const std::string type = r.string("type");
    if (type != "thin_lens" && type != "pinhole")
      r.fail("camera.type", "unknown camera type \"" + type + "\" (expected thin_lens or pinhole)");
    // Render space is the world moved so that the camera sits at its origin (toRenderSpace).
    const DVec3 position = r.dvec3("position"), lookAt = r.dvec3("look_at");
    scene_.origin = position;
    p.position = Vec3(0.0f);
    if (!(largestAbs(lookAt - position) <= kMaxRenderDistance)) {
      // Anywhere in the world, but not that far apart: name the one that is off in the distance.
      const bool positionIsOff = largestAbs(position) > largestAbs(lookAt);
      r.fail(positionIsOff ? "camera.position" : "camera.look_at",
             "is " + shortNumber(glm::length(lookAt - position)) + " from camera." +
                 (positionIsOff ? "look_at" : "position") + "; at most " + shortNumber(kMaxRenderDistance) +
                 " (per axis) is supported");
    }
    p.lookAt = toRenderSpace(lookAt, "camera.look_at");
    p.up = r.vec3("up", Vec3(0.0f, 1.0f, 0.0f));
    // The frame before any length: with look_at at position the focus distance is 0 too, and
    // that is not the problem to report.
    if (p.lookAt == p.position)
      r.fail("camera.look_at", "equals camera.position (" + showVec3(position) +
                                   (lookAt == position ? "" : " in single precision") + "): the view direction is undefined");
    if (p.up == Vec3(0.0f))
      r.fail("camera.up", "must not be [0, 0, 0]: it says which way is up in the image");
    const DVec3 view = glm::normalize(DVec3(p.lookAt) - DVec3(p.position));
    if (!(glm::length(glm::cross(view, glm::normalize(DVec3(p.up)))) > 1e-6))
      r.fail("camera.up", showVec3(p.up) + " is parallel to the view direction (look_at - position = " +
                              showVec3(p.lookAt - p.position) + "): the image's up is undefined; give an up that is "
                              "not along the view direction, e.g. " +
                              (std::abs(view.y) < 0.9 ? "[0, 1, 0]" : "[0, 0, 1]"));

    const bool hasF = r.has("focal_length"), hasAngle = r.has("angle_of_view");
    if (hasF == hasAngle) r.fail("camera.focal_length", "give exactly one of focal_length and angle_of_view");
    const bool hasWidth = r.has("sensor_width");
    if (!hasWidth && hasF)
      r.fail("camera.sensor_width", "is required with focal_length (it may be left out with angle_of_view, where it is " +
                                        shortNumber(kDefaultSensorWidth) + ", a 36 mm sensor in a scene in metres)");
    p.sensorWidth = hasWidth ? positive(r, "sensor_width") : kDefaultSensorWidth;
    if (r.has("sensor_height")) {
      p.sensorHeight = r.number("sensor_height");
      if (!(p.sensorHeight >= 0.0))
        r.fail("camera.sensor_height", "must be >= 0 (0: sensor_width * H / W, square cells), got " + shortNumber(p.sensorHeight));
    }
    const double angle = hasAngle ? r.number("angle_of_view", 1e-6, 179.999) : 0.0;
    p.focalLength = hasF ? positive(r, "focal_length") : focalLengthFromAngleOfView(p.sensorWidth, angle);
    const double lookAtDistance = glm::length(lookAt - position);
    p.focusDistance = r.has("focus_distance") ? positive(r, "focus_distance") : lookAtDistance;
    if (type == "pinhole") {
      p.fNumber = std::numeric_limits<double>::infinity();
    } else {
      const json& n = r.raw("f_number");
      if (n.is_string() && (n == "infinity" || n == "inf"))
        p.fNumber = std::numeric_limits<double>::infinity();
      else if (n.is_number())
        p.fNumber = positive(r, "f_number");
      else
        r.fail("camera.f_number", "must be a number > 0 or \"infinity\"");
    }
    r.finish();
    // A focal length as long as the whole distance to look_at is a unit mix-up (millimetres for
    // the lens, metres for the scene), not a focus problem: name the length that was given.
    if (!(lookAtDistance > p.focalLength) && !(p.focusDistance > p.focalLength)) {
      const std::string distance = "the distance to look_at (" + shortNumber(lookAtDistance) +
                                   "), on which the lens focuses (a pinhole's sensor is placed by it too)";
      const std::string units = "camera lengths are in the scene's unit (that of positions), not millimetres";
      // Sensor and lens in one unit (a sensor 1/20 to 20 times f): both were written in millimetres.
      const bool sameUnit = p.sensorWidth / p.focalLength > 0.05 && p.sensorWidth / p.focalLength < 20.0;
      if (hasF)
        r.fail("camera.focal_length",
               "f = " + shortNumber(p.focalLength) + " is not shorter than " + distance + ": " + units +
                   "; if " + shortNumber(p.focalLength) + " means mm and the scene is in metres, write focal_length " +
                   shortNumber(p.focalLength / 1000) +
                   (sameUnit ? " and sensor_width " + shortNumber(p.sensorWidth / 1000) : std::string()) +
                   " (or give angle_of_view)");
      if (hasWidth)
        r.fail("camera.sensor_width",
               shortNumber(p.sensorWidth) + " with angle_of_view " + shortNumber(angle) + " gives f = LW / (2 tan(a/2)) = " +
                   shortNumber(p.focalLength) + ", not shorter than " + distance + ": " + units + "; if " +
                   shortNumber(p.sensorWidth) + " means mm and the scene is in metres, write sensor_width " +
                   shortNumber(p.sensorWidth / 1000) + " (or leave it out: " + shortNumber(kDefaultSensorWidth) + ")");
      r.fail("camera.angle_of_view",
             shortNumber(angle) + " degrees on the default sensor_width " + shortNumber(kDefaultSensorWidth) +
                 " gives f = " + shortNumber(p.focalLength) + ", not shorter than " + distance +
                 ": give sensor_width in the scene's unit, or a wider angle");
    }
    try {
      (void)ThinLensCamera(p, scene_.render.width, scene_.render.height);
    } catch (const InputError& e) {
      // The camera names its own field; report it in the scene file's terms.
      const std::string msg = e.what();
      r.fail("camera." + e.where(), msg.substr(e.where().size() + 2));
    }
  }

  void parseShapes(FieldReader& top) {
    const json& shapes = top.raw("shapes");
    if (!shapes.is_array()) top.fail("shapes", "must be an array");
    for (size_t i = 0; i < shapes.size(); ++i) {
      FieldReader r(shapes[i], "shapes[" + std::to_string(i) + "]", fileName_);
      const std::string type = r.string("type");
      MeshInput mesh;
      mesh.mesh.name = r.string("name", type + "#" + std::to_string(i));
      mesh.mesh.visibleToCamera = r.boolean("visible_to_camera", true);
      if (type == "obj") {
        readObj(r, mesh);
      } else if (type == "quad") {
        const uint32_t material = materialRef(r, "material");
        addQuad(mesh, r.dvec3("corner"), r.dvec3("edge1"), r.dvec3("edge2"), material);
      } else if (type == "triangles") {
        readInlineTriangles(r, mesh);
      } else {
        r.fail(r.field("type"), "unknown shape type \"" + type + "\" (expected obj, quad or triangles)");
      }
      const Transform t = readTransform(r, "transform");
      r.finish();
      applyTransform(mesh, t);
      shapeTriangles_ += addMesh(std::move(mesh), r.path());
    }
  }

  void parseLights(FieldReader& top) {
    if (!top.has("lights")) return;
    const json& lights = top.raw("lights");
    if (!lights.is_array()) top.fail("lights", "must be an array");
    for (size_t i = 0; i < lights.size(); ++i) {
      const std::string path = "lights[" + std::to_string(i) + "]";
      FieldReader r(lights[i], path, fileName_);
      const std::string type = r.string("type");
      if (type != "quad") {
        const LightParser parseLight = findLightType(type);
        if (!parseLight) {
          std::string expected = "quad";
          const std::vector<std::string> names = lightTypeNames();
          for (size_t k = 0; k < names.size(); ++k)
            expected += (k + 1 == names.size() ? " or " : ", ") + names[k];
          r.fail(r.field("type"), "unknown light type \"" + type + "\" (expected " + expected + ")");
        }
        const LightParseContext context{r.string("name", path), [this](const DVec3& world, const std::string& field) {
                                          return toRenderSpace(world, field);
                                        }};
        scene_.lights.push_back(parseLight(r, context));
        r.finish();
        continue;
      }
      const Spectrum radiance = r.color("radiance", kRadianceRange);
      const Material m(path, nullptr, radiance, r.boolean("two_sided", false));
      MeshInput mesh;
      mesh.mesh.name = r.string("name", path);
      mesh.mesh.visibleToCamera = r.boolean("visible_to_camera", true);
      const DVec3 corner = r.dvec3("corner"), e1 = r.dvec3("edge1"), e2 = r.dvec3("edge2");
      r.finish();
      // Divided by their largest components first, so that no product overflows.
      const DVec3 n = glm::cross(e1 / std::max(largestAbs(e1), 1e-300),
                                 e2 / std::max(largestAbs(e2), 1e-300));
      if (!(glm::length(n) > 0.0)) r.fail(path + ".edge2", "the quad has zero area");
      scene_.materials.push_back(m);
      addQuad(mesh, corner, e1, e2, uint32_t(scene_.materials.size() - 1));
      if (addMesh(std::move(mesh), path) != 2)
        r.fail(path + ".edge2", "the quad has zero area in single precision, " +
                                    shortNumber(glm::length(toRenderSpace(corner, path + ".corner"))) + " from the camera");
    }
  }

  // The optional top-level "environment" (light/environment_light.h), after the lights.
  void parseEnvironment(FieldReader& top) {
    if (!top.has("environment")) return;
    FieldReader r(top.raw("environment"), "environment", fileName_);
    scene_.lights.push_back(lensfarm::parseEnvironment(
        r, [this](FieldReader& reader, const std::string& key, const std::string& kind) {
          return readAssetFile(reader, key, kind);
        }));
    r.finish();
  }

  // A file named by field `key` of r, relative to the scene file, read through the asset reader
  // and added to the scene's hash and assets (so the farm ships it to workers), or one error
  // naming the field and the path.
  LoadedAsset readAssetFile(FieldReader& r, const std::string& key, const std::string& kind) {
    const std::string rel = r.string(key);
    const fs::path path = file_.parent_path() / rel;
    std::optional<std::string> content = readAsset_(rel);
    if (!content) r.fail(r.field(key), "cannot read " + kind + " \"" + path.string() + "\"");
    hash_.update(rel);
    hash_.update(*content);
    scene_.assets[rel] = sha256Hex(*content);
    return LoadedAsset{path.string(), std::move(*content)};
  }

  // A shape as read: world positions in double, the rest as it will render.
  struct MeshInput {
    TriangleMesh mesh;  // positions empty until addMesh
    std::vector<DVec3> positions;
  };

  static void addQuad(MeshInput& in, DVec3 corner, DVec3 e1, DVec3 e2, uint32_t material) {
    // Faces the side of cross(e1, e2).
    TriangleMesh& mesh = in.mesh;
    const uint32_t base = uint32_t(in.positions.size());
    in.positions.insert(in.positions.end(), {corner, corner + e1, corner + e1 + e2, corner + e2});
    mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    mesh.materialIds.insert(mesh.materialIds.end(), {material, material});
  }

  void readInlineTriangles(FieldReader& r, MeshInput& in) {
    TriangleMesh& mesh = in.mesh;
    const uint32_t material = materialRef(r, "material");
    const json& verts = r.raw("vertices");
    if (!verts.is_array() || verts.size() < 3) r.fail(r.field("vertices"), "must be an array of at least 3 points");
    for (size_t k = 0; k < verts.size(); ++k)
      in.positions.push_back(r.toDVec3(verts[k], r.field("vertices") + "[" + std::to_string(k) + "]"));
    if (r.has("indices")) {
      const json& idx = r.raw("indices");
      if (!idx.is_array()) r.fail(r.field("indices"), "must be an array of [i, j, k] triples");
      for (size_t k = 0; k < idx.size(); ++k) {
        const std::string name = r.field("indices") + "[" + std::to_string(k) + "]";
        if (!idx[k].is_array() || idx[k].size() != 3) r.fail(name, "must be [i, j, k]");
        for (const json& v : idx[k]) {
          if (!v.is_number_unsigned() || v.get<uint64_t>() >= in.positions.size())
            r.fail(name, "vertex index out of range [0, " + std::to_string(in.positions.size()) + ")");
          mesh.indices.push_back(v.get<uint32_t>());
        }
        mesh.materialIds.push_back(material);
      }
    } else {
      if (verts.size() % 3 != 0) r.fail(r.field("vertices"), "without indices, must hold 3 points per triangle");
      for (uint32_t k = 0; k < verts.size(); ++k) mesh.indices.push_back(k);
      mesh.materialIds.assign(verts.size() / 3, material);
    }
  }

  void readObj(FieldReader& r, MeshInput& in) {
    TriangleMesh& mesh = in.mesh;
    const std::string where = r.field("file");
    const LoadedAsset file = readAssetFile(r, "file", "OBJ file");
    const fs::path path = file.shown;
    const std::string& text = file.bytes;

    // tinyobjloader skips what it does not understand: check first that this is an OBJ at all.
    const ObjCheck check = checkObjText(text);
    if (!check.ok()) r.fail(where, "\"" + path.string() + "\": " + check.problem);

    tinyobj::ObjReaderConfig config;
    config.triangulate = true;
    config.vertex_color = false;
    config.mtl_search_path = "";  // lensfarm materials come from the scene, never from .mtl files
    tinyobj::ObjReader reader;
    if (!reader.ParseFromString(check.text, "", config))
      r.fail(where, "\"" + path.string() + "\" is not a valid OBJ file: " + reader.Error());
    const auto& attrib = reader.GetAttrib();
    const uint32_t defaultMaterial = r.has("material") ? materialRef(r, "material") : UINT32_MAX;

    std::map<std::string, uint32_t> groupMaterials;
    std::set<std::string> groupsUsed;
    if (r.has("group_materials")) {
      FieldReader g(r.raw("group_materials"), r.field("group_materials"), fileName_);
      const json& gm = r.raw("group_materials");
      for (auto it = gm.begin(); it != gm.end(); ++it) {
        const std::string name = g.string(it.key());
        groupMaterials[it.key()] = lookupMaterial(r, g.field(it.key()), name);
      }
      g.finish();
    }

    // tinyobjloader's double build: a model far from the origin keeps its shape until it is
    // re-centred on the camera.
    static_assert(std::is_same_v<tinyobj::real_t, double>, "link tinyobjloader_double");
    for (size_t k = 0; k < attrib.vertices.size(); k += 3) {
      const DVec3 v(attrib.vertices[k], attrib.vertices[k + 1], attrib.vertices[k + 2]);
      if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
        r.fail(where, "\"" + path.string() + "\": vertex " + std::to_string(k / 3 + 1) + " is not finite");
      in.positions.push_back(v);
    }
    for (const auto& shape : reader.GetShapes()) {
      uint32_t material = defaultMaterial;
      if (auto it = groupMaterials.find(shape.name); it != groupMaterials.end()) {
        material = it->second;
        groupsUsed.insert(shape.name);
      }
      if (material == UINT32_MAX)
        r.fail(r.field("material"), "OBJ group \"" + shape.name +
                                        "\" has no material: give material or group_materials." + shape.name);
      for (const auto& index : shape.mesh.indices) {
        if (index.vertex_index < 0 || size_t(index.vertex_index) >= in.positions.size())
          r.fail(where, "\"" + path.string() + "\": face refers to a missing vertex");
        mesh.indices.push_back(uint32_t(index.vertex_index));
      }
      mesh.materialIds.insert(mesh.materialIds.end(), shape.mesh.indices.size() / 3, material);
    }
    for (const auto& [group, material] : groupMaterials)
      if (!groupsUsed.count(group))
        r.fail(r.field("group_materials") + "." + group, "no group of that name in \"" + path.string() + "\"");
  }

  void applyTransform(MeshInput& in, const Transform& t) {
    for (DVec3& p : in.positions) p = t.apply(p);
    // A mirroring transform would turn every face inside out; swap winding to keep facing.
    if (t.flipsHandedness())
      for (size_t k = 0; k < in.mesh.indices.size(); k += 3) std::swap(in.mesh.indices[k + 1], in.mesh.indices[k + 2]);
  }

  // A world position in render space: relative to the camera, in float. The difference is
  // taken in double, so a scene placed anywhere renders as it does at the origin
  // (docs/numerics.md, "Far from the origin"); what must stay finite in float (squared
  // distances) bounds how far from the camera anything may be.
  Vec3 toRenderSpace(const DVec3& world, const std::string& field) const {
    const DVec3 d = world - scene_.origin;
    if (!(largestAbs(d) <= kMaxRenderDistance))
      throw InputError(fileName_, field + ": lies " + shortNumber(glm::length(d)) + " from the camera; at most " +
                                      shortNumber(kMaxRenderDistance) +
                                      " (per axis) is supported (squared distances must stay finite in single precision)");
    return Vec3(d);
  }

  // Moves a shape into render space, drops zero-area triangles (they have no normal and can
  // never be hit meaningfully) and returns how many triangles were kept.
  size_t addMesh(MeshInput in, const std::string& field) {
    TriangleMesh& mesh = in.mesh;
    mesh.positions.reserve(in.positions.size());
    for (size_t k = 0; k < in.positions.size(); ++k)
      mesh.positions.push_back(toRenderSpace(in.positions[k], field + " vertex " + std::to_string(k)));
    TriangleMesh kept = mesh;
    kept.indices.clear();
    kept.materialIds.clear();
    for (size_t tri = 0; tri < mesh.triangleCount(); ++tri) {
      const Vec3& a = mesh.positions[mesh.indices[3 * tri]];
      const Vec3& b = mesh.positions[mesh.indices[3 * tri + 1]];
      const Vec3& c = mesh.positions[mesh.indices[3 * tri + 2]];
      // Zero area as the renderer will see the float vertices (math/triangle.h), at any size.
      if (!triangleNormal(a, b, c)) {
        ++scene_.skippedDegenerateTriangles;
        continue;
      }
      kept.indices.insert(kept.indices.end(), {mesh.indices[3 * tri], mesh.indices[3 * tri + 1], mesh.indices[3 * tri + 2]});
      kept.materialIds.push_back(mesh.materialIds[tri]);
    }
    const size_t count = kept.triangleCount();
    if (count > 0) scene_.meshes.push_back(std::move(kept));
    return count;
  }

  const json& root_;
  fs::path file_;
  std::string fileName_;
  Scene scene_;
  AssetReader readAsset_;
  Sha256 hash_;
  std::map<std::string, uint32_t> materialIndex_;
  size_t shapeTriangles_ = 0;
};

}  // namespace

namespace {
// Finds the field that holds the first non-finite number (e.g. 1e999, which JSON allows but a
// double cannot hold) by replaying the text through nlohmann's SAX interface.
class NonFiniteNumberFinder : public nlohmann::json_sax<json> {
 public:
  std::string path;  // set when found

  bool number_float(number_float_t, const string_t&) override { return advance(); }
  bool null() override { return advance(); }
  bool boolean(bool) override { return advance(); }
  bool number_integer(number_integer_t) override { return advance(); }
  bool number_unsigned(number_unsigned_t) override { return advance(); }
  bool string(string_t&) override { return advance(); }
  bool binary(binary_t&) override { return advance(); }
  bool start_object(std::size_t) override {
    frames_.push_back(Frame{false, 0, ""});
    return true;
  }
  bool key(string_t& k) override {
    frames_.back().key = k;
    return true;
  }
  bool end_object() override { return close(); }
  bool start_array(std::size_t) override {
    frames_.push_back(Frame{true, 0, ""});
    return true;
  }
  bool end_array() override { return close(); }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception& e) override {
    if (e.id == 406) path = currentPath();  // nlohmann reports an overflowing number here
    return false;
  }

 private:
  struct Frame {
    bool array;
    size_t index;
    std::string key;
  };
  bool advance() {
    if (!frames_.empty() && frames_.back().array) ++frames_.back().index;
    return true;
  }
  bool close() {
    frames_.pop_back();
    return advance();
  }
  std::string currentPath() const {
    std::string out;
    for (const Frame& f : frames_) {
      if (f.array)
        out += "[" + std::to_string(f.index) + "]";
      else
        out += (out.empty() ? "" : ".") + f.key;
    }
    return out;
  }
  std::vector<Frame> frames_;
};
}  // namespace

AssetReader fileAssetReader(const fs::path& sceneFile) {
  const fs::path dir = sceneFile.parent_path();
  return [dir](const std::string& rel) { return readWholeFile(dir / rel); };
}

uint32_t unitSize(const RenderSettings& s) {
  if (s.samplesPerUnit > 0) return s.samplesPerUnit;
  const uint64_t pixels = std::max<uint64_t>(1, uint64_t(s.width) * uint64_t(s.height));
  if (s.convergenceDriven()) {
    // Small units, a power of two so that each is a whole net of the Sobol sampler: the stop
    // lands close to the target, and a deadline wastes little.
    const uint64_t fit = std::clamp<uint64_t>(kAutoUnitPaths / 4 / pixels, 1, kMaxConvergenceUnitSamples);
    return uint32_t(std::min<uint64_t>(std::bit_floor(fit), std::max<uint64_t>(1, s.samplesPerPixel)));
  }
  const uint64_t perUnit = std::clamp<uint64_t>((kAutoUnitPaths + pixels - 1) / pixels, 1, std::max<uint64_t>(1, s.samplesPerPixel));
  return uint32_t(std::min<uint64_t>(perUnit, 1u << 20));
}

namespace {
// JSON nesting deeper than any scene needs is refused before parsing (a 10^6-deep array would
// otherwise cost stack in the JSON library's recursive destructor).
constexpr int kMaxNesting = 64;

void checkNesting(const std::string& text, const fs::path& file) {
  int depth = 0, line = 1;
  bool inString = false, escaped = false;
  for (char c : text) {
    if (c == '\n') ++line;
    if (inString) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') inString = false;
    } else if (c == '"') {
      inString = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxNesting)
        throw InputError(file.string(), "line " + std::to_string(line) + ": nested deeper than " +
                                            std::to_string(kMaxNesting) + " levels");
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
}
}  // namespace

Scene parseScene(const std::string& text, const fs::path& file, const AssetReader& readAsset) {
  checkNesting(text, file);
  json root;
  try {
    root = json::parse(text);
  } catch (const json::parse_error& e) {
    // nlohmann's message carries the line and column.
    std::string what = e.what();
    const auto pos = what.find("parse error");
    throw InputError(file.string(), "malformed JSON: " + (pos == std::string::npos ? what : what.substr(pos)));
  } catch (const json::exception& e) {
    // A number too large for a double (406 "number overflow").
    NonFiniteNumberFinder finder;
    json::sax_parse(text, &finder);
    if (!finder.path.empty()) throw InputError(file.string(), finder.path + ": must be a finite number");
    throw InputError(file.string(), std::string("invalid JSON: ") + e.what());
  }
  return SceneParser(root, file, readAsset ? readAsset : fileAssetReader(file)).parse();
}

Scene loadScene(const fs::path& file) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) throw InputError(file.string(), "no such scene file");
  return parseScene(readWholeFileOrThrow(file, file.string()), file);
}

void validateRenderSettings(const RenderSettings& s, const std::string& where) {
  if (s.width < 1 || s.height < 1 || s.width > kMaxResolution || s.height > kMaxResolution)
    throw InputError(where, "resolution: each side must be in [1, " + std::to_string(kMaxResolution) + "]");
  if (s.samplesPerPixel < 1 || s.samplesPerPixel > kMaxSamplesPerPixel)
    throw InputError(where, "samples_per_pixel: must be in [1, " + std::to_string(kMaxSamplesPerPixel) + "]");
  if (s.maxBounces < 0 || s.maxBounces > kMaxBounces)
    throw InputError(where, "max_bounces: must be in [0, " + std::to_string(kMaxBounces) + "]");
  if (!(s.targetError >= 0.0 && s.targetError < 1.0))
    throw InputError(where, "target_error: must be a relative RMSE in (0, 1), e.g. 0.01");
  if (!(s.timeLimitSeconds >= 0.0 && s.timeLimitSeconds <= 1e9))
    throw InputError(where, "time_limit: must be in [0, 1e9] seconds");
}

const char* integratorName(IntegratorKind kind) {
  switch (kind) {
    case IntegratorKind::kNaive: return "naive";
    case IntegratorKind::kNee: return "nee";
    case IntegratorKind::kNeeMis: break;
  }
  return "nee_mis";
}

bool parseIntegratorName(const std::string& name, IntegratorKind& kind) {
  for (IntegratorKind k : {IntegratorKind::kNaive, IntegratorKind::kNee, IntegratorKind::kNeeMis})
    if (name == integratorName(k)) {
      kind = k;
      return true;
    }
  return false;
}

const char* samplerName(SamplerKind kind) {
  switch (kind) {
    case SamplerKind::kIndependent: return "independent";
    case SamplerKind::kStratified: return "stratified";
    case SamplerKind::kSobol: break;
  }
  return "sobol";
}

bool parseSamplerName(const std::string& name, SamplerKind& kind) {
  for (SamplerKind k : {SamplerKind::kIndependent, SamplerKind::kStratified, SamplerKind::kSobol})
    if (name == samplerName(k)) {
      kind = k;
      return true;
    }
  return false;
}

}  // namespace lensfarm
