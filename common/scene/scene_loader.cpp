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

#include "scene/obj_check.h"
#include "util/error.h"
#include "util/hash.h"

namespace lensfarm {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

std::string shortNumber(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

std::string showVec3(const Vec3& v) {
  return "[" + shortNumber(v.x) + ", " + shortNumber(v.y) + ", " + shortNumber(v.z) + "]";
}

// ---------------------------------------------------------------------------------------------
// FieldReader: typed, range-checked access to one JSON object that remembers which keys were
// read, so that anything left over is reported as an unknown field (a typo must not be ignored).
class FieldReader {
 public:
  FieldReader(const json& object, std::string path, const std::string& file)
      : object_(object), path_(std::move(path)), file_(file) {
    if (!object_.is_object()) fail(path_.empty() ? "(top level)" : path_, "must be a JSON object");
  }

  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw InputError(file_, field + ": " + what);
  }
  std::string field(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

  bool has(const std::string& key) {
    seen_.insert(key);
    return object_.contains(key);
  }
  const json& raw(const std::string& key) {
    if (!has(key)) fail(field(key), "is required");
    return object_.at(key);
  }

  double number(const std::string& key, double lo = -std::numeric_limits<double>::max(),
                double hi = std::numeric_limits<double>::max()) {
    return checkNumber(raw(key), field(key), lo, hi);
  }
  double number(const std::string& key, double fallback, double lo, double hi) {
    return has(key) ? number(key, lo, hi) : fallback;
  }
  double checkNumber(const json& v, const std::string& name, double lo, double hi) const {
    if (!v.is_number()) fail(name, "must be a number");
    const double x = v.get<double>();
    if (!std::isfinite(x)) fail(name, "must be a finite number");
    if (x < lo || x > hi) fail(name, "must be in [" + fmt(lo) + ", " + fmt(hi) + "], got " + fmt(x));
    return x;
  }

  uint64_t integer(const std::string& key, uint64_t lo, uint64_t hi) {
    const json& v = raw(key);
    if (!v.is_number_integer() || (v.is_number_integer() && !v.is_number_unsigned() && v.get<int64_t>() < 0))
      fail(field(key), "must be a non-negative integer");
    const uint64_t x = v.get<uint64_t>();
    if (x < lo || x > hi)
      fail(field(key), "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + std::to_string(x));
    return x;
  }
  uint64_t integer(const std::string& key, uint64_t fallback, uint64_t lo, uint64_t hi) {
    return has(key) ? integer(key, lo, hi) : fallback;
  }

  bool boolean(const std::string& key, bool fallback) {
    if (!has(key)) return fallback;
    const json& v = object_.at(key);
    if (!v.is_boolean()) fail(field(key), "must be true or false");
    return v.get<bool>();
  }

  std::string string(const std::string& key) {
    const json& v = raw(key);
    if (!v.is_string()) fail(field(key), "must be a string");
    return v.get<std::string>();
  }
  std::string string(const std::string& key, const std::string& fallback) {
    return has(key) ? string(key) : fallback;
  }

  Vec3 vec3(const std::string& key) { return toVec3(raw(key), field(key)); }
  Vec3 vec3(const std::string& key, Vec3 fallback) { return has(key) ? vec3(key) : fallback; }
  Vec3 toVec3(const json& v, const std::string& name) const {
    if (!v.is_array() || v.size() != 3) fail(name, "must be an array of 3 numbers");
    Vec3 out;
    for (int i = 0; i < 3; ++i) {
      const double x = checkNumber(v[i], name + "[" + std::to_string(i) + "]", -std::numeric_limits<double>::max(),
                                   std::numeric_limits<double>::max());
      if (std::abs(x) > std::numeric_limits<float>::max())
        fail(name + "[" + std::to_string(i) + "]", "is too large for single precision");
      out[i] = float(x);
    }
    return out;
  }

  // A colour: three non-negative numbers, or one number for grey.
  Spectrum color(const std::string& key, float hi) {
    const json& v = raw(key);
    if (v.is_number()) return Spectrum(float(checkNumber(v, field(key), 0.0, hi)));
    const Vec3 c = toVec3(v, field(key));
    for (int i = 0; i < 3; ++i)
      if (c[i] < 0.0f || c[i] > hi)
        fail(field(key) + "[" + std::to_string(i) + "]", "must be in [0, " + fmt(hi) + "]");
    return c;
  }
  Spectrum color(const std::string& key, Spectrum fallback, float hi) {
    return has(key) ? color(key, hi) : fallback;
  }

  // Reports the first key that no accessor asked for.
  void finish() const {
    for (auto it = object_.begin(); it != object_.end(); ++it) {
      if (!seen_.count(it.key())) {
        std::string allowed;
        for (const auto& k : seen_) allowed += (allowed.empty() ? "" : ", ") + k;
        fail(field(it.key()), "unknown field (expected one of: " + allowed + ")");
      }
    }
  }

  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }

 private:
  static std::string fmt(double x) {
    std::ostringstream s;
    s << x;
    return s.str();
  }
  const json& object_;
  std::string path_;
  const std::string& file_;
  std::set<std::string> seen_;
};

// ---------------------------------------------------------------------------------------------
// Transform: scale, then rotate, then translate (all optional).
struct Transform {
  glm::mat4 matrix{1.0f};
  Vec3 apply(const Vec3& p) const { return Vec3(matrix * glm::vec4(p, 1.0f)); }
  bool flipsHandedness() const { return glm::determinant(glm::mat3(matrix)) < 0.0f; }
};

Transform readTransform(FieldReader& parent, const std::string& key) {
  Transform t;
  if (!parent.has(key)) return t;
  FieldReader r(parent.raw(key), parent.field(key), parent.file());
  glm::mat4 scale(1.0f), rotate(1.0f), translate(1.0f);
  if (r.has("scale")) {
    const json& s = r.raw("scale");
    const Vec3 k = s.is_number() ? Vec3(float(r.number("scale"))) : r.vec3("scale");
    if (k.x == 0.0f || k.y == 0.0f || k.z == 0.0f) r.fail(r.field("scale"), "must not be zero");
    scale = glm::mat4(glm::vec4(k.x, 0, 0, 0), glm::vec4(0, k.y, 0, 0), glm::vec4(0, 0, k.z, 0), glm::vec4(0, 0, 0, 1));
  }
  if (r.has("rotate")) {
    FieldReader rot(r.raw("rotate"), r.field("rotate"), r.file());
    const Vec3 axis = rot.vec3("axis");
    if (!(glm::length(axis) > 0.0f)) rot.fail(rot.field("axis"), "must not be zero");
    const double degrees = rot.number("degrees", -360.0, 360.0);
    rot.finish();
    const glm::mat3 m = glm::mat3(glm::rotate(glm::mat4(1.0f), float(glm::radians(degrees)), glm::normalize(axis)));
    rotate = glm::mat4(m);
  }
  if (r.has("translate")) {
    const Vec3 d = r.vec3("translate");
    translate[3] = glm::vec4(d, 1.0f);
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
    top.finish();

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
      Material m;
      m.name = it.key();
      const std::string type = r.string("type");
      if (type == "lambertian") {
        m.kind = MaterialKind::kLambertian;
        m.albedo = r.color("albedo", 1.0f);
        m.emission = r.color("emission", Spectrum(0.0f), std::numeric_limits<float>::max());
      } else if (type == "mirror") {
        m.kind = MaterialKind::kMirror;
        m.albedo = r.color("reflectance", Spectrum(1.0f), 1.0f);
      } else if (type == "rippled_mirror") {
        m.kind = MaterialKind::kRippledMirror;
        m.albedo = r.color("reflectance", Spectrum(0.5f), 1.0f);  // seed §4.2: halves the light
        m.ripple = float(r.number("ripple", 0.02, 0.0, 1.0));
      } else if (type == "emissive") {
        m.kind = MaterialKind::kEmissive;
        m.emission = r.color("radiance", std::numeric_limits<float>::max());
      } else {
        r.fail(r.field("type"), "unknown material type \"" + type +
                                    "\" (expected lambertian, mirror, rippled_mirror or emissive)");
      }
      if (m.isEmissive() || r.has("two_sided")) m.twoSidedEmission = r.boolean("two_sided", false);
      r.finish();
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
    p.position = r.vec3("position");
    p.lookAt = r.vec3("look_at");
    p.up = r.vec3("up", Vec3(0.0f, 1.0f, 0.0f));
    // The frame before any length: with look_at at position the focus distance is 0 too, and
    // that is not the problem to report.
    if (p.lookAt == p.position)
      r.fail("camera.look_at", "equals camera.position (" + showVec3(p.position) + "): the view direction is undefined");
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
    const double lookAtDistance = double(glm::length(p.lookAt - p.position));
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
      TriangleMesh mesh;
      mesh.name = r.string("name", type + "#" + std::to_string(i));
      mesh.visibleToCamera = r.boolean("visible_to_camera", true);
      if (type == "obj") {
        readObj(r, mesh);
      } else if (type == "quad") {
        const uint32_t material = materialRef(r, "material");
        addQuad(mesh, r.vec3("corner"), r.vec3("edge1"), r.vec3("edge2"), material);
      } else if (type == "triangles") {
        readInlineTriangles(r, mesh);
      } else {
        r.fail(r.field("type"), "unknown shape type \"" + type + "\" (expected obj, quad or triangles)");
      }
      const Transform t = readTransform(r, "transform");
      r.finish();
      applyTransform(mesh, t);
      shapeTriangles_ += addMesh(std::move(mesh));
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
      if (type != "quad") r.fail(r.field("type"), "unknown light type \"" + type + "\" (expected quad)");
      Material m;
      m.name = path;
      m.kind = MaterialKind::kEmissive;
      m.emission = r.color("radiance", std::numeric_limits<float>::max());
      m.twoSidedEmission = r.boolean("two_sided", false);
      TriangleMesh mesh;
      mesh.name = r.string("name", path);
      mesh.visibleToCamera = r.boolean("visible_to_camera", true);
      const Vec3 corner = r.vec3("corner"), e1 = r.vec3("edge1"), e2 = r.vec3("edge2");
      r.finish();
      if (!(glm::length(glm::cross(e1, e2)) > 0.0f)) r.fail(path + ".edge2", "the quad has zero area");
      scene_.materials.push_back(m);
      addQuad(mesh, corner, e1, e2, uint32_t(scene_.materials.size() - 1));
      addMesh(std::move(mesh));
    }
  }

  static void addQuad(TriangleMesh& mesh, Vec3 corner, Vec3 e1, Vec3 e2, uint32_t material) {
    // Faces the side of cross(e1, e2).
    const uint32_t base = uint32_t(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(), {corner, corner + e1, corner + e1 + e2, corner + e2});
    mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    mesh.materialIds.insert(mesh.materialIds.end(), {material, material});
  }

  void readInlineTriangles(FieldReader& r, TriangleMesh& mesh) {
    const uint32_t material = materialRef(r, "material");
    const json& verts = r.raw("vertices");
    if (!verts.is_array() || verts.size() < 3) r.fail(r.field("vertices"), "must be an array of at least 3 points");
    for (size_t k = 0; k < verts.size(); ++k)
      mesh.positions.push_back(r.toVec3(verts[k], r.field("vertices") + "[" + std::to_string(k) + "]"));
    if (r.has("indices")) {
      const json& idx = r.raw("indices");
      if (!idx.is_array()) r.fail(r.field("indices"), "must be an array of [i, j, k] triples");
      for (size_t k = 0; k < idx.size(); ++k) {
        const std::string name = r.field("indices") + "[" + std::to_string(k) + "]";
        if (!idx[k].is_array() || idx[k].size() != 3) r.fail(name, "must be [i, j, k]");
        for (const json& v : idx[k]) {
          if (!v.is_number_unsigned() || v.get<uint64_t>() >= mesh.positions.size())
            r.fail(name, "vertex index out of range [0, " + std::to_string(mesh.positions.size()) + ")");
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

  void readObj(FieldReader& r, TriangleMesh& mesh) {
    const std::string rel = r.string("file");
    const std::string where = r.field("file");
    const fs::path path = file_.parent_path() / rel;
    const std::optional<std::string> content = readAsset_(rel);
    if (!content) r.fail(where, "cannot read OBJ file \"" + path.string() + "\"");
    const std::string& text = *content;
    hash_.update(rel);
    hash_.update(text);
    scene_.assets[rel] = sha256Hex(text);

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

    for (size_t k = 0; k < attrib.vertices.size(); k += 3) {
      const Vec3 v(attrib.vertices[k], attrib.vertices[k + 1], attrib.vertices[k + 2]);
      if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
        r.fail(where, "\"" + path.string() + "\": vertex " + std::to_string(k / 3 + 1) + " is not finite");
      mesh.positions.push_back(v);
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
        if (index.vertex_index < 0 || size_t(index.vertex_index) >= mesh.positions.size())
          r.fail(where, "\"" + path.string() + "\": face refers to a missing vertex");
        mesh.indices.push_back(uint32_t(index.vertex_index));
      }
      mesh.materialIds.insert(mesh.materialIds.end(), shape.mesh.indices.size() / 3, material);
    }
    for (const auto& [group, material] : groupMaterials)
      if (!groupsUsed.count(group))
        r.fail(r.field("group_materials") + "." + group, "no group of that name in \"" + path.string() + "\"");
  }

  void applyTransform(TriangleMesh& mesh, const Transform& t) {
    for (Vec3& p : mesh.positions) p = t.apply(p);
    // A mirroring transform would turn every face inside out; swap winding to keep facing.
    if (t.flipsHandedness())
      for (size_t k = 0; k < mesh.indices.size(); k += 3) std::swap(mesh.indices[k + 1], mesh.indices[k + 2]);
  }

  // Drops zero-area triangles (they have no normal and can never be hit meaningfully) and
  // returns how many triangles were kept.
  size_t addMesh(TriangleMesh mesh) {
    TriangleMesh kept = mesh;
    kept.indices.clear();
    kept.materialIds.clear();
    for (size_t tri = 0; tri < mesh.triangleCount(); ++tri) {
      const Vec3& a = mesh.positions[mesh.indices[3 * tri]];
      const Vec3& b = mesh.positions[mesh.indices[3 * tri + 1]];
      const Vec3& c = mesh.positions[mesh.indices[3 * tri + 2]];
      const Vec3 n = glm::cross(b - a, c - a);
      if (!(glm::dot(n, n) > 0.0f) || !std::isfinite(glm::dot(n, n))) {
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
