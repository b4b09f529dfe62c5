#include "common/scene/scene_loader.h"
#include "common/util/file_contents.h"

#include <tbb/parallel_invoke.h>
#include <tiny_obj_loader.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "common/camera/aperture_image.h"
#include "common/light/environment_light.h"
#include "common/light/light_types.h"
#include "common/math/triangle.h"
#include "common/medium/medium.h"
#include "common/scene/asset_path.h"
#include "common/scene/coplanar.h"
#include "common/scene/gltf_import.h"
#include "common/scene/imported_model.h"
#include "common/scene/keyframes.h"
#include "common/scene/lens_prescription.h"
#include "common/scene/obj_check.h"
#include "common/scene/obj_import.h"
#include "common/scene/tile_size.h"
#include "common/scene/transform.h"
#include "common/util/error.h"
#include "common/util/field_reader.h"
#include "common/util/hash.h"

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
class SceneParser {
 public:
  // `root` is evaluated at `frame` in place (scene/keyframes.h) after it is hashed.
  SceneParser(json& root, const fs::path& file, AssetReader readAsset, std::optional<double> frame)
      : root_(root), file_(file), fileName_(file.string()), readAsset_(std::move(readAsset)), frame_(frame) {}

  Scene parse() {
    FieldReader top(root_, "", fileName_);
    const std::string format = top.string("format");
    if (format != kSceneFormat)
      top.fail("format", "unsupported format \"" + format + "\" (this renderer reads \"" + kSceneFormat + "\")");
    scene_.file = file_;
    hash_.update(root_.dump());  // the file as written: one hash for every frame of an animation
    scene_.frame = frame_.value_or(0.0);
    if (std::optional<Animation> animation = applyKeyframes(root_, frame_, fileName_)) {
      scene_.keyframeRange = animation->range;
      scene_.frame = animation->frame;
    }

    parseRender(top);
    parseMedia(top);
    parseMaterials(top);
    importModels(top);
    parseCamera(top);
    placeMedia(top);
    parseShapes(top);
    parseLights(top);
    addModelLights();
    parseEnvironment(top);
    top.finish();
    bringFlushLightsForward(scene_);  // the coplanar rule (scene/coplanar.h)

    if (shapeTriangles_ == 0 && instancedTriangles_ == 0)
      top.fail("shapes", "the scene has no triangles (lights alone show nothing)");
    size_t stored = shapeTriangles_;
    for (const TriangleMesh& mesh : scene_.prototypes) stored += mesh.triangleCount();
    if (stored > kMaxTriangles)
      top.fail("shapes", std::to_string(stored) + " triangles exceed the limit of " + std::to_string(kMaxTriangles));
    if (scene_.instances.size() > kMaxInstances)
      top.fail("shapes", std::to_string(scene_.instances.size()) + " instances exceed the limit of " +
                             std::to_string(kMaxInstances));
    scene_.hash = hash_.hexDigest();
    scene_.notes = std::move(notes_);
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
    s.maxMediumBounces = int(r.integer("max_medium_bounces", 256, 0, kMaxMediumBounces));
    s.seed = r.integer("seed", 0, 0, std::numeric_limits<uint64_t>::max());
    const std::string integrator = r.string("integrator", "nee_mis");
    if (!parseIntegratorName(integrator, s.integrator))
      r.fail("render.integrator", "unknown integrator \"" + integrator + "\" (expected nee_mis, nee or naive)");
    const std::string sampler = r.string("sampler", "sobol");
    if (!parseSamplerName(sampler, s.sampler))
      r.fail("render.sampler", "unknown sampler \"" + sampler + "\" (expected sobol, stratified or independent)");
    if (r.has("russian_roulette")) {
      // A bool, as in the older form (true: the max-throughput rule), or a rule's name.
      const json& rr = r.raw("russian_roulette");
      if (rr.is_boolean())
        s.roulette = rr.get<bool>() ? RouletteRule::kMax : RouletteRule::kOff;
      else if (!rr.is_string() || !parseRouletteName(rr.get<std::string>(), s.roulette))
        r.fail("render.russian_roulette", "must be \"off\", \"max\", \"throughput\", true or false, got " + rr.dump());
    }
    s.rouletteMinBounces = int(r.integer("roulette_min_bounces", 1, 0, kMaxBounces));
    const std::string lightTracing = r.string("light_tracing", "auto");
    if (lightTracing == "auto" || lightTracing == "on" || lightTracing == "off")
      s.lightTracing = lightTracing == "on"    ? LightTracingMode::kOn
                       : lightTracing == "off" ? LightTracingMode::kOff
                                               : LightTracingMode::kAuto;
    else
      r.fail("render.light_tracing", "unknown mode \"" + lightTracing + "\" (expected auto, on or off)");
    s.lightTracingRatio = r.number("light_tracing_ratio", 0.25, 1e-6, 64.0);
    if (r.has("aovs")) {
      // A list of names (or one comma-separated string), docs/aovs.md.
      const json& list = r.raw("aovs");
      std::string text;
      if (list.is_string()) {
        text = list.get<std::string>();
      } else if (list.is_array()) {
        for (const json& name : list) {
          if (!name.is_string()) r.fail("render.aovs", "must be a list of AOV names, got " + name.dump() + " in it");
          text += (text.empty() ? "" : ",") + name.get<std::string>();
        }
      } else {
        r.fail("render.aovs", "must be a list of AOV names (" + aovNames() + "), got " + list.dump());
      }
      std::string bad;
      if (!parseAovList(text, s.aovs, &bad))
        r.fail("render.aovs", "unknown AOV \"" + bad + "\" (expected " + aovNames() + ")");
    }
    s.targetError = r.number("target_error", 0.0, 0.0, 0.999);
    s.timeLimitSeconds = r.number("time_limit", 0.0, 0.0, 1e9);
    s.mirrorBouncesCount = r.boolean("mirror_bounces_count", false);
    s.samplesPerUnit = uint32_t(r.integer("samples_per_unit", 0, 0, 1u << 20));
    if (r.has("tile_size")) {
      const json& t = r.raw("tile_size");
      const std::optional<int> code = tileSizeFromJson(t);
      if (!code) r.fail("render.tile_size", "must be " + tileSizeForms() + ", got " + t.dump());
      s.tileSize = *code;
    }
    if (r.has("adaptive")) {
      const json& a = r.raw("adaptive");
      if (a.is_boolean()) {
        s.adaptive.enabled = a.get<bool>();
      } else if (a.is_object()) {
        FieldReader ar(a, "render.adaptive", fileName_);
        s.adaptive.enabled = true;
        s.adaptive.uniform = ar.number("uniform", s.adaptive.uniform, 1e-6, 1.0);
        s.adaptive.blockEdge = int(ar.integer("block", 0, 1, kMaxResolution));
        s.adaptive.floor = ar.number("floor", s.adaptive.floor, 1e-6, 1.0);
        ar.finish();
      } else {
        r.fail("render.adaptive", "must be true, false or an object {uniform, block, floor}, got " + a.dump());
      }
    }
    if (r.has("exposure")) {
      FieldReader e(r.raw("exposure"), "render.exposure", fileName_);
      s.exposure.ev = e.number("ev", 0.0, -kMaxExposureEv, kMaxExposureEv);
      const std::string tm = e.string("tone_map", "reinhard");
      if (tm == "reinhard")
        s.exposure.toneMap = ToneMap::kReinhard;
      else if (tm == "clamp")
        s.exposure.toneMap = ToneMap::kClamp;
      else
        e.fail("render.exposure.tone_map", "unknown tone map \"" + tm + "\" (expected reinhard or clamp)");
      const std::string meter = e.string("meter", "lit");
      if (meter == "lit")
        s.exposure.meter = ExposureMeter::kLit;
      else if (meter == "mean")
        s.exposure.meter = ExposureMeter::kMean;
      else if (meter == "fixed")
        s.exposure.meter = ExposureMeter::kFixed;
      else
        e.fail("render.exposure.meter", "unknown meter \"" + meter + "\" (expected lit, mean or fixed)");
      e.finish();
    }
    r.finish();
  }

  // `media` (docs/scene-format.md, "Media"): named media, read before the materials that put
  // them inside their meshes.
  void parseMedia(FieldReader& top) {
    if (!top.has("media")) return;
    const json& media = top.raw("media");
    if (!media.is_object()) top.fail("media", "must be an object of named media");
    for (auto it = media.begin(); it != media.end(); ++it) {
      FieldReader r(it.value(), "media." + it.key(), fileName_);
      std::shared_ptr<Medium> m =
          parseMedium(it.key(), r, [this](FieldReader& reader, const std::string& key, const std::string& kind) {
            return readAssetFile(reader, key, kind);
          });
      unplacedMedia_.push_back(m);
      scene_.media[it.key()] = m;
    }
  }
  // Grids move to render space with the rest of the scene; then the scene's own `medium`.
  void placeMedia(FieldReader& top) {
    for (const std::shared_ptr<Medium>& m : unplacedMedia_) m->place(scene_.origin);
    unplacedMedia_.clear();
    if (!top.has("medium")) return;
    const std::string name = top.string("medium");
    const auto it = scene_.media.find(name);
    if (it == scene_.media.end()) top.fail("medium", "unknown medium \"" + name + "\" (not in media)");
    scene_.medium = it->second;
  }

  void parseMaterials(FieldReader& top) {
    // Optional where every shape brings its own (glTF, OBJ with MTL).
    if (!top.has("materials")) return;
    const json& mats = top.raw("materials");
    if (!mats.is_object()) top.fail("materials", "must be an object of named materials");
    for (auto it = mats.begin(); it != mats.end(); ++it) {
      FieldReader r(it.value(), "materials." + it.key(), fileName_);
      Material m = parseMaterial(it.key(), r, scene_.media);
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
    if (!top.has("camera") || top.raw("camera").is_string()) {
      json camera = top.has("camera") ? modelCamera(top.raw("camera").get<std::string>()) : modelCamera();
      FieldReader r(camera, cameraOrigin_, fileName_);
      parseCameraFields(r);
      return;
    }
    FieldReader r(top.raw("camera"), "camera", fileName_);
    parseCameraFields(r);
  }

  // Without a "camera" in the scene: the first camera of the first model that has one, else one
  // that frames every model: a pinhole whose 40-degree view along the image's shorter side holds
  // every corner of their bounds (with a 10 % margin), from the front, +z, and a little above,
  // so the whole model shows at any aspect ratio; named in the scene's notes.
  // With `wanted` (the scene's "camera": "NAME"), the model camera of that name, or an error listing
  // the cameras the models have.
  json modelCamera(const std::optional<std::string>& wanted = std::nullopt) {
    if (wanted) {
      std::string names;
      for (const ModelImport& m : imports_)
        for (const json& c : m.model.cameras) {
          const std::string name = c.value("name", std::string());
          if (name == *wanted) return useModelCamera(m.field, m.shown, c, name);
          names += (names.empty() ? "\"" : ", \"") + name + "\"";
        }
      throw InputError(fileName_,
                       "camera: no model camera named \"" + *wanted + "\" (" +
                           (names.empty() ? std::string("the models have no cameras") : "the models have " + names) +
                           ")");
    }
    for (const ModelImport& m : imports_) {
      if (!m.model.cameras.empty())
        return useModelCamera(m.field, m.shown, m.model.cameras.front(),
                              m.model.cameras.front().value("name", std::string("cameras[0]")));
    }
    DVec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    for (const ModelImport& m : imports_) lo = glm::min(lo, m.worldLo), hi = glm::max(hi, m.worldHi);
    if (imports_.empty() || !(lo.x <= hi.x))
      throw InputError(fileName_, "camera: is required (no model in shapes brings one to frame)");
    const DVec3 centre = 0.5 * (lo + hi);
    const double radius = std::max(0.5 * glm::length(hi - lo), 1e-6 * std::max(1.0, largestAbs(centre)));
    // The nearest distance from which every corner of the bounds lies within 20 degrees of the
    // axis, less a 10 % margin, both across and up (the shorter side's half-angle: it holds on the
    // longer side too, whatever the aspect ratio); never inside the bounds.
    const DVec3 back = glm::normalize(DVec3(0.0, 0.25, 1.0));  // from the centre towards the camera
    const DVec3 right = glm::normalize(glm::cross(-back, DVec3(0.0, 1.0, 0.0))), up = glm::cross(right, -back);
    const double slope = std::tan(glm::radians(20.0)) / 1.1;
    double distance = 0.0;
    for (int c = 0; c < 8; ++c) {
      const DVec3 d = boxCorner(lo, hi, c) - centre;
      const double across = std::max(std::abs(glm::dot(d, right)), std::abs(glm::dot(d, up)));
      distance = std::max({distance, across / slope + glm::dot(d, back), glm::dot(d, back) + 0.05 * radius});
    }
    distance = std::max(distance, 0.05 * radius);
    const DVec3 from = centre + distance * back;
    cameraOrigin_ = "camera (framing every model)";
    notes_.push_back("camera: none in the scene or its models; framing them from the front: position " +
                     showVec3(from) + ", look_at " + showVec3(centre) + ", angle_of_view 40, fov_axis smaller");
    return json{{"type", "pinhole"},
                {"position", {from.x, from.y, from.z}},
                {"look_at", {centre.x, centre.y, centre.z}},
                {"angle_of_view", 40.0},
                {"fov_axis", "smaller"}};
  }

  // A model's camera as the scene's, with a note naming it, and the aspect ratio it was framed for
  // (Scene::cameraFramedAspect).
  json useModelCamera(const std::string& field, const std::string& shown, const json& modelCamera,
                      const std::string& name) {
    json camera = modelCamera;
    camera.erase("name");
    cameraOrigin_ = field + " camera \"" + name + "\"";
    notes_.push_back("camera: " + shown + "'s camera \"" + name + "\"");
    if (camera.contains("aspect_ratio")) {
      scene_.cameraFramedAspect = camera["aspect_ratio"].get<double>();
      camera.erase("aspect_ratio");
    }
    return camera;
  }

  // camera.diffraction (film/diffraction_psf.h): true, false, or an object with `wavelengths` (per
  // colour channel) and, for a thin lens, `scene_units_per_mm` (a real lens has its own).
  void parseDiffraction(FieldReader& r, const std::string& type) {
    if (!r.has("diffraction")) return;
    const json& v = r.raw("diffraction");
    if (v.is_boolean()) {
      if (v.get<bool>()) scene_.diffraction = DiffractionSettings{};
      return;
    }
    if (!v.is_object())
      r.fail(r.field("diffraction"), "must be true, false or an object {\"wavelengths\", \"scene_units_per_mm\"}");
    FieldReader d(v, r.field("diffraction"), fileName_);
    DiffractionSettings settings;
    settings.wavelengthsPerChannel = int(d.integer("wavelengths", 4, 1, 16));
    if (d.has("scene_units_per_mm")) {
      if (type == "real_lens")
        d.fail(d.field("scene_units_per_mm"),
               "a real lens's scene unit is camera.scene_units_per_mm; leave it out here");
      settings.sceneUnitsPerMm = positive(d, "scene_units_per_mm");
    }
    d.finish();
    scene_.diffraction = settings;
  }

  // A camera with a real lens (camera/real_lens_camera.h): the frame is read already; the lens
  // file, the sensor, the focus and the stop. cameraParams become the lens's thin-lens
  // equivalent, for the effect analysis and `lensfarm dof`.
  void parseRealLens(FieldReader& r, double lookAtDistance) {
    ThinLensParams& p = scene_.cameraParams;
    RealLensParams lens;
    // `lens`: a lens file (pbrt-v4 tabular or JSON, scene/lens_prescription.h) or the JSON
    // prescription inline.
    std::optional<LensPrescription> prescription;
    std::string shown;
    if (r.has("lens") && r.raw("lens").is_object()) {
      prescription = lensFromJson(r.raw("lens"), r.field("lens"), fileName_);
      shown = r.field("lens");
      lens.name = prescription->name.empty() ? "the inline lens" : prescription->name;
    } else {
      const LoadedAsset file = readAssetFile(r, "lens", "lens file");
      lens.name = r.string("lens");
      prescription = readLensFile(file.bytes, file.shown);
      shown = file.shown;
    }
    LensSystem system = std::move(prescription->system);
    lens.sceneUnitsPerMm = r.has("scene_units_per_mm") ? positive(r, "scene_units_per_mm") : 0.001;
    p.sensorWidth = positive(r, "sensor_width");
    if (r.has("sensor_height")) p.sensorHeight = positive(r, "sensor_height");
    p.focusDistance = r.has("focus_distance") ? positive(r, "focus_distance") : lookAtDistance;
    const LensSystem::Paraxial design = system.paraxial();
    if (!(design.efl > 0.0))
      r.fail(r.field("lens"), shown + " is not a converging lens (EFL " + shortNumber(design.efl) + " mm)");
    double n = design.fNumber;
    if (r.has("f_number")) {
      n = positive(r, "f_number");
      // The f-number a lens is sold at is its paraxial one rounded (f/1.4 for f/1.403): within
      // 1 % of it, the lens is used wide open, at its own.
      if (n < design.fNumber * (1.0 - 0.01))
        r.fail(r.field("f_number"), "f/" + shortNumber(n) + " is wider than " + lens.name + " opens (f/" +
                                        shortNumber(design.fNumber) + ")");
      if (n < design.fNumber) n = design.fNumber;
      // Closing the stop: the entrance pupil, and so the f-number, scales with it.
      std::vector<LensSurface> surfaces = system.surfaces();
      surfaces[system.stopIndex()].aperture *= design.fNumber / n;
      system = LensSystem(std::move(surfaces), shown);
    }
    parseDiffraction(r, "real_lens");
    r.finish();
    p.focalLength = design.efl * lens.sceneUnitsPerMm;
    p.fNumber = n;
    if (!(p.focusDistance > p.focalLength))
      r.fail(r.field("focus_distance"), shortNumber(p.focusDistance) + " is not beyond the lens's focal length " +
                                            shortNumber(p.focalLength) + " (" + shortNumber(design.efl) +
                                            " mm at scene_units_per_mm " + shortNumber(lens.sceneUnitsPerMm) + ")");
    lens.lens = std::make_shared<const LensSystem>(std::move(system));
    scene_.realLens = std::move(lens);
    try {
      (void)scene_.realLensCamera();
    } catch (const InputError& e) {
      r.fail(r.field(e.where()), e.what());
    }
  }

  void parseCameraFields(FieldReader& r) {
    ThinLensParams& p = scene_.cameraParams;
    const std::string type = r.string("type");
    if (type != "thin_lens" && type != "pinhole" && type != "real_lens")
      r.fail(r.field("type"), "unknown camera type \"" + type + "\" (expected thin_lens, pinhole or real_lens)");
    // Render space is the world moved so that the camera sits at its origin (toRenderSpace).
    const DVec3 position = r.dvec3("position"), lookAt = r.dvec3("look_at");
    scene_.origin = position;
    p.position = Vec3(0.0f);
    if (!(largestAbs(lookAt - position) <= kMaxRenderDistance)) {
      // Anywhere in the world, but not that far apart: name the one that is off in the distance.
      const bool positionIsOff = largestAbs(position) > largestAbs(lookAt);
      r.fail(positionIsOff ? r.field("position") : r.field("look_at"),
             "is " + shortNumber(glm::length(lookAt - position)) + " from camera." +
                 (positionIsOff ? "look_at" : "position") + "; at most " + shortNumber(kMaxRenderDistance) +
                 " (per axis) is supported");
    }
    p.lookAt = toRenderSpace(lookAt, r.field("look_at"));
    p.up = r.vec3("up", Vec3(0.0f, 1.0f, 0.0f));
    // The frame before any length: with look_at at position the focus distance is 0 too, and
    // that is not the problem to report.
    if (p.lookAt == p.position)
      r.fail(r.field("look_at"), "equals camera.position (" + showVec3(position) +
                                     (lookAt == position ? "" : " in single precision") +
                                     "): the view direction is undefined");
    if (p.up == Vec3(0.0f)) r.fail(r.field("up"), "must not be [0, 0, 0]: it says which way is up in the image");
    const DVec3 view = glm::normalize(DVec3(p.lookAt) - DVec3(p.position));
    if (!(glm::length(glm::cross(view, glm::normalize(DVec3(p.up)))) > 1e-6))
      r.fail(r.field("up"), showVec3(p.up) + " is parallel to the view direction (look_at - position = " +
                                showVec3(p.lookAt - p.position) +
                                "): the image's up is undefined; give an up that is "
                                "not along the view direction, e.g. " +
                                (std::abs(view.y) < 0.9 ? "[0, 1, 0]" : "[0, 0, 1]"));

    if (type == "real_lens") return parseRealLens(r, glm::length(lookAt - position));
    const bool hasF = r.has("focal_length"), hasAngle = r.has("angle_of_view");
    if (hasF == hasAngle) r.fail(r.field("focal_length"), "give exactly one of focal_length and angle_of_view");
    const bool hasWidth = r.has("sensor_width");
    if (!hasWidth && hasF)
      r.fail(r.field("sensor_width"),
             "is required with focal_length (it may be left out with angle_of_view, where it is " +
                 shortNumber(kDefaultSensorWidth) + ", a 36 mm sensor in a scene in metres)");
    p.sensorWidth = hasWidth ? positive(r, "sensor_width") : kDefaultSensorWidth;
    if (r.has("sensor_height")) {
      p.sensorHeight = r.number("sensor_height");
      if (!(p.sensorHeight >= 0.0))
        r.fail(r.field("sensor_height"),
               "must be >= 0 (0: sensor_width * H / W, square cells), got " + shortNumber(p.sensorHeight));
    }
    const double angle = hasAngle ? r.number("angle_of_view", 1e-6, 179.999) : 0.0;
    if (r.has("fov_axis")) {
      if (!hasAngle) r.fail(r.field("fov_axis"), "says which axis angle_of_view is measured along; give angle_of_view");
      p.fovAxis = fovAxisNamed(r, r.string("fov_axis"));
    }
    p.angleOfView = angle;
    p.focalLength =
        hasF ? positive(r, "focal_length")
             : focalLengthFromAngleOfView(sensorExtent(p.sensorWidth, sceneSensorHeight(p), p.fovAxis), angle);
    const double lookAtDistance = glm::length(lookAt - position);
    // A pinhole has no focus: its sensor sits at f, so the angle of view is the one given.
    if (type == "pinhole") {
      if (r.has("focus_distance")) {
        (void)positive(r, "focus_distance");
        notes_.push_back("camera.focus_distance: a pinhole has no focus; it is ignored");
      }
      p.focusDistance = std::numeric_limits<double>::infinity();
    } else {
      p.focusDistance = r.has("focus_distance") ? positive(r, "focus_distance") : lookAtDistance;
    }
    if (type == "thin_lens") {
      if (r.has("aperture_blades")) p.apertureBlades = int(r.integer("aperture_blades", 3, 64));
      if (r.has("aperture_rotation")) p.apertureRotation = r.number("aperture_rotation", -360.0, 360.0);
      if (r.has("aperture_curvature")) p.apertureCurvature = r.number("aperture_curvature", 0.0, 1.0);
      if (r.has("aperture_image")) {
        // camera/aperture.h: a square transmission image over the aperture, shipped like a mesh.
        const LoadedAsset file = readAssetFile(r, "aperture_image", "aperture image");
        try {
          p.apertureImage = ApertureImage::decode(file.bytes, file.shown);
        } catch (const InputError& e) {
          r.fail(r.field("aperture_image"), e.what());
        }
      }
    }
    if (type == "pinhole") {
      p.fNumber = std::numeric_limits<double>::infinity();
    } else {
      const json& n = r.raw("f_number");
      if (n.is_string() && (n == "infinity" || n == "inf"))
        p.fNumber = std::numeric_limits<double>::infinity();
      else if (n.is_number())
        p.fNumber = positive(r, "f_number");
      else
        r.fail(r.field("f_number"), "must be a number > 0 or \"infinity\"");
    }
    parseDiffraction(r, type);
    if (scene_.diffraction && std::isinf(p.fNumber))
      r.fail(r.field("diffraction"), std::string("needs a lens aperture to diffract at: ") +
                                         (type == "pinhole" ? "a pinhole camera has none" : "f_number is infinity") +
                                         " (use a thin_lens with a finite f_number)");
    r.finish();
    // A focal length as long as the whole distance to look_at is a unit mix-up (millimetres for
    // the lens, metres for the scene), not a focus problem: name the length that was given. (A
    // pinhole's image would not change with the unit, but its sensor would then sit farther behind
    // it than the subject stands in front: the same slip, said the same way.)
    // (A pinhole given only an angle has no length of the user's to blame.)
    const bool pinholeLength = type == "pinhole" && (hasF || hasWidth);
    if (!(lookAtDistance > p.focalLength) &&
        (pinholeLength || (type != "pinhole" && !(p.focusDistance > p.focalLength)))) {
      const std::string distance = "the distance to look_at (" + shortNumber(lookAtDistance) + ")" +
                                   (type == "pinhole" ? std::string() : ", on which the lens focuses");
      const std::string units = "camera lengths are in the scene's unit (that of positions), not millimetres";
      // Sensor and lens in one unit (a sensor 1/20 to 20 times f): both were written in millimetres.
      const bool sameUnit = p.sensorWidth / p.focalLength > 0.05 && p.sensorWidth / p.focalLength < 20.0;
      if (hasF)
        r.fail(r.field("focal_length"),
               "f = " + shortNumber(p.focalLength) + " is not shorter than " + distance + ": " + units + "; if " +
                   shortNumber(p.focalLength) + " means mm and the scene is in metres, write focal_length " +
                   shortNumber(p.focalLength / 1000) +
                   (sameUnit ? " and sensor_width " + shortNumber(p.sensorWidth / 1000) : std::string()) +
                   " (or give angle_of_view)");
      if (hasWidth)
        r.fail(r.field("sensor_width"),
               shortNumber(p.sensorWidth) + " with angle_of_view " + shortNumber(angle) +
                   " gives f = LW / (2 tan(a/2)) = " + shortNumber(p.focalLength) + ", not shorter than " + distance +
                   ": " + units + "; if " + shortNumber(p.sensorWidth) +
                   " means mm and the scene is in metres, write sensor_width " + shortNumber(p.sensorWidth / 1000) +
                   " (or leave it out: " + shortNumber(kDefaultSensorWidth) + ")");
      r.fail(r.field("angle_of_view"), shortNumber(angle) + " degrees on the default sensor_width " +
                                           shortNumber(kDefaultSensorWidth) +
                                           " gives f = " + shortNumber(p.focalLength) + ", not shorter than " +
                                           distance + ": give sensor_width in the scene's unit, or a wider angle");
    }
    try {
      const ThinLensCamera camera(p, scene_.render.width, scene_.render.height);
      if (type == "thin_lens") noteFocusBreathing(camera, hasAngle);
    } catch (const InputError& e) {
      // The camera names its own field; report it in the scene file's terms.
      const std::string msg = e.what();
      r.fail(r.field(e.where()), msg.substr(e.where().size() + 2));
    }
  }

  // A thin lens focused near moves its sensor back (S2 > f) and sees a narrower angle than at
  // infinity focus, as a real lens "breathes": say so when the difference shows (0.5 %).
  void noteFocusBreathing(const ThinLensCamera& camera, bool hasAngle) {
    const ThinLensParams& p = camera.params();
    const double extent = sensorExtent(p.sensorWidth, p.sensorHeight, p.fovAxis);
    const double atInfinity = angleOfViewDegrees(extent, p.focalLength),
                 focused = angleOfViewDegrees(extent, camera.imageDistance());
    if (!(focused < atInfinity * (1.0 - 0.005))) return;
    notes_.push_back(
        "camera: focused at " + shortNumber(p.focusDistance) + ", the thin lens sees " + shortNumber(focused) +
        " degrees " + fovAxisName(p.fovAxis) + ", not the " + shortNumber(atInfinity) +
        (hasAngle ? " of its angle_of_view (which holds at infinity focus)" : " it sees at infinity focus") +
        "; a pinhole sees its angle_of_view exactly");
  }

  // The sensor height the camera will have at the scene's resolution (0 in the scene: square cells).
  double sceneSensorHeight(const ThinLensParams& p) const {
    return p.sensorHeight > 0.0 ? p.sensorHeight : p.sensorWidth * scene_.render.height / scene_.render.width;
  }

  static FovAxis fovAxisNamed(FieldReader& r, const std::string& name) {
    for (const FovAxis axis :
         {FovAxis::kHorizontal, FovAxis::kVertical, FovAxis::kDiagonal, FovAxis::kSmaller, FovAxis::kLarger})
      if (name == fovAxisName(axis)) return axis;
    r.fail(r.field("fov_axis"),
           "unknown axis \"" + name + "\" (expected horizontal, vertical, diagonal, smaller or larger)");
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
      if (type == "obj" || type == "gltf") {
        addImportedShape(r, mesh, i);
      } else if (type == "quad") {
        const uint32_t material = materialRef(r, "material");
        addQuad(mesh, r.dvec3("corner"), r.dvec3("edge1"), r.dvec3("edge2"), material);
      } else if (type == "triangles") {
        readInlineTriangles(r, mesh);
      } else {
        r.fail(r.field("type"), "unknown shape type \"" + type + "\" (expected obj, gltf, quad or triangles)");
      }
      // (A model's transform was applied when it was imported, to its cameras and lights too.)
      const Transform t = type == "obj" || type == "gltf" ? Transform{} : readTransform(r, "transform");
      r.finish();
      applyTransform(mesh, t);
      shapeTriangles_ += addMesh(std::move(mesh), r.path());
    }
  }

  void parseLights(FieldReader& top) {
    if (!top.has("lights")) return;
    const json& lights = top.raw("lights");
    if (!lights.is_array()) top.fail("lights", "must be an array");
    for (size_t i = 0; i < lights.size(); ++i) parseLightEntry(lights[i], "lights[" + std::to_string(i) + "]");
  }

  // The lights the models bring (KHR_lights_punctual), after the scene's own.
  void addModelLights() {
    for (const ModelImport& m : imports_)
      for (size_t k = 0; k < m.model.lights.size(); ++k)
        parseLightEntry(m.model.lights[k],
                        m.field + " light \"" + m.model.lights[k].value("name", std::to_string(k)) + "\"");
  }

  void parseLightEntry(const json& entry, const std::string& path) {
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

  // A quad light far smaller than its distance from the camera has its float corners rounded by a
  // good part of its size (a 1e-6 quad 2 from the camera: ~10 % of its area), which changes its
  // power. Its radiance is scaled by the written area over the float one, so that the power is
  // what the scene says; a light whose float area is within 1e-4 of the written one keeps its
  // radiance (and every scene of ordinary proportions its bits).
  static void holdQuadPower(const TriangleMesh& placed, double writtenArea, Material& material) {
    double floatArea = 0.0;
    for (size_t tri = 0; tri < placed.triangleCount(); ++tri)
      floatArea +=
          triangleArea(placed.positions[placed.indices[3 * tri]], placed.positions[placed.indices[3 * tri + 1]],
                       placed.positions[placed.indices[3 * tri + 2]]);
    const double ratio = writtenArea / floatArea;
    if (std::isfinite(ratio) && std::abs(ratio - 1.0) > 1e-4) material.emission *= float(ratio);
  }

  // The optional top-level "environment" (light/environment_light.h), after the lights.
  void parseEnvironment(FieldReader& top) {
    if (!top.has("environment")) return;
    FieldReader r(top.raw("environment"), "environment", fileName_);
    scene_.lights.push_back(
        lensfarm::parseEnvironment(r, [this](FieldReader& reader, const std::string& key, const std::string& kind) {
          return readAssetFile(reader, key, kind);
        }));
    r.finish();
  }

  // A file named by field `key` of r, relative to the scene file, read through the asset reader
  // and added to the scene's hash and assets (so the farm ships it to workers), or one error
  // naming the field and the path.
  // A path the asset root refuses (scene/asset_path.h) is named with the reason.
  LoadedAsset readAssetFile(FieldReader& r, const std::string& key, const std::string& kind) {
    const std::string rel = r.string(key);
    if (const std::optional<std::string> problem = unreadablePathProblem(rel))
      r.fail(r.field(key), "\"" + rel + "\" " + *problem);
    const fs::path path = file_.parent_path() / rel;
    std::optional<std::string> content;
    try {
      content = readAsset_(rel);
    } catch (const AssetRefused& e) {
      r.fail(r.field(key), "\"" + rel + "\" " + e.what());
    }
    if (!content) r.fail(r.field(key), "cannot read " + kind + " \"" + path.string() + "\": " + missingFile(path));
    addAssetHash(rel, *content);
    return LoadedAsset{path.string(), std::move(*content)};
  }

  // Why a file could not be read, with the path it was looked for at.
  static std::string missingFile(const fs::path& path) {
    std::error_code ec;
    const fs::path absolute = fs::absolute(path, ec).lexically_normal();
    const std::string shown = ec ? path.string() : absolute.string();
    if (fs::is_directory(path, ec)) return "is a folder, not a file (" + shown + ")";
    if (fs::exists(path, ec)) return "cannot be opened (" + shown + "; check its permissions)";
    return "no such file (looked for " + shown + ")";
  }

  // An asset into the scene's hash, and its own hash into the scene's assets: two passes over the
  // bytes (a big model's take a while), side by side.
  void addAssetHash(const std::string& rel, const std::string& content) {
    std::string own;
    tbb::parallel_invoke([&] { hash_.update(rel), hash_.update(content); }, [&] { own = sha256Hex(content); });
    scene_.assets[rel] = std::move(own);
  }

  static void addQuad(MeshInput& in, DVec3 corner, DVec3 e1, DVec3 e2, uint32_t material) {
    // Faces the side of cross(e1, e2).
    TriangleMesh& mesh = in.mesh;
    const uint32_t base = uint32_t(in.positions.size());
    in.positions.insert(in.positions.end(), {corner, corner + e1, corner + e1 + e2, corner + e2});
    mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    mesh.materialIds.insert(mesh.materialIds.end(), {material, material});
  }

  // A model file (OBJ with MTL, glTF) a shape names, imported in world space before the camera is
  // read (a scene may take its camera from a model, or frame the models), with the shape's
  // transform applied to everything it brings.
  struct ModelImport {
    size_t shape;       // index in shapes
    std::string field;  // "shapes[2]"
    std::string shown;  // the model file's path, for messages
    bool obj;
    ImportedModel model;
    std::vector<std::string> groupNames;  // OBJ: groups and the group of each triangle
    std::vector<uint32_t> triangleGroups;
    std::vector<std::string> readerNotes;  // what reading its files noted (a missing mtllib)
    DVec3 worldLo{std::numeric_limits<double>::max()}, worldHi{-std::numeric_limits<double>::max()};
  };

  void importModels(FieldReader& top) {
    const json& shapes = top.raw("shapes");
    if (!shapes.is_array()) top.fail("shapes", "must be an array");
    for (size_t i = 0; i < shapes.size(); ++i) {
      if (!shapes[i].is_object() || !shapes[i].contains("type")) continue;  // parseShapes reports it
      const json& type = shapes[i]["type"];
      if (type != "obj" && type != "gltf") continue;
      ModelImport m;
      m.shape = i;
      m.field = "shapes[" + std::to_string(i) + "]";
      m.obj = type == "obj";
      FieldReader r(shapes[i], m.field, fileName_);
      const std::string rel = r.string("file");
      LoadedAsset file = readAssetFile(r, "file", m.obj ? "OBJ file" : "glTF file");
      m.shown = file.shown;
      const ModelFileReader read = modelFileReader(rel, m);
      if (m.obj) {
        // tinyobjloader skips what it does not understand: check first that this is an OBJ at all.
        // (Checked in place and moved on: the file's bytes become the text that is parsed.)
        ObjCheck check = checkObjTextInPlace(std::move(file.bytes));
        if (!check.ok()) r.fail(r.field("file"), "\"" + m.shown + "\": " + check.problem);
        ImportedObj obj = importCheckedObj(std::move(check.text), m.shown, read);
        m.model = std::move(obj.model);
        m.groupNames = std::move(obj.groupNames);
        m.triangleGroups = std::move(obj.triangleGroups);
      } else {
        m.model = importGltf(std::move(file.bytes), m.shown, read);
      }
      const Transform t = readTransform(r, "transform");
      transformModel(m, t);
      for (const std::string& note : m.readerNotes) notes_.push_back(m.shown + ": " + note);
      for (const std::string& note : m.model.notes) notes_.push_back(m.shown + ": " + note);
      imports_.push_back(std::move(m));
    }
  }

  // Files a model refers to, relative to the model file, read through the scene's asset reader
  // and recorded as assets. A missing MTL library is an empty one (noted): an OBJ exported with
  // materials still loads when the scene gives its materials.
  ModelFileReader modelFileReader(const std::string& modelRel, ModelImport& m) {
    const fs::path dir = fs::path(modelRel).parent_path();
    return [this, dir, &m](const std::string& rel) -> std::optional<std::string> {
      if (const std::optional<std::string> problem = unreadablePathProblem(rel))
        throw InputError(m.shown, "\"" + rel + "\" " + *problem);
      const std::string path = (dir / rel).lexically_normal().generic_string();
      std::optional<std::string> content;
      try {
        content = readAsset_(path);
      } catch (const AssetRefused& e) {
        throw InputError(m.shown, "\"" + rel + "\" " + e.what());
      }
      if (!content) {
        if (m.obj && fs::path(rel).extension() == ".mtl") {
          m.readerNotes.push_back("mtllib " + rel + " not found: its materials must come from the scene");
          return std::string();
        }
        return std::nullopt;
      }
      addAssetHash(path, *content);
      return content;
    };
  }

  // The shape's transform on every mesh, camera and light of a model (still in world space).
  static void transformModel(ModelImport& m, const Transform& t) {
    const auto point = [&](json& j, const char* key) {
      if (!j.contains(key) || !j[key].is_array() || j[key].size() != 3) return;
      const DVec3 p = t.apply(DVec3(j[key][0].get<double>(), j[key][1].get<double>(), j[key][2].get<double>()));
      j[key] = {p.x, p.y, p.z};
    };
    const auto vector = [&](json& j, const char* key) {
      if (!j.contains(key) || !j[key].is_array() || j[key].size() != 3) return;
      const Vec3 v = t.applyToVector(Vec3(j[key][0].get<float>(), j[key][1].get<float>(), j[key][2].get<float>()));
      j[key] = {v.x, v.y, v.z};
    };
    for (json& c : m.model.cameras) point(c, "position"), point(c, "look_at"), vector(c, "up");
    for (json& l : m.model.lights) point(l, "position"), point(l, "look_at"), vector(l, "direction");
    for (MeshInput& in : m.model.meshes) {
      applyTransform(in, t);
      for (const DVec3& p : in.positions) m.worldLo = glm::min(m.worldLo, p), m.worldHi = glm::max(m.worldHi, p);
    }
    // Instances: the transform joins each node's; the bounds take each prototype's box as placed.
    std::vector<std::pair<DVec3, DVec3>> boxes;
    for (const MeshInput& in : m.model.prototypes) boxes.push_back(boundsOf(in.positions));
    for (ModelInstance& instance : m.model.instances) {
      instance.world = t.matrix * instance.world;
      const auto& [lo, hi] = boxes[instance.prototype];
      for (int c = 0; c < 8; ++c) {
        const DVec3 p(instance.world * glm::dvec4(boxCorner(lo, hi, c), 1.0));
        m.worldLo = glm::min(m.worldLo, p), m.worldHi = glm::max(m.worldHi, p);
      }
    }
  }

  // A model's meshes that several nodes use (ImportedModel::prototypes), their materials mapped
  // by `material`: each is stored once in object space and placed by instances (scene/scene.h),
  // unless one of its materials emits or the shape sets "instancing": false; then each use is a
  // copy, moved into `copies` in world space.
  template <typename MapMaterial>
  void addPrototypes(FieldReader& r, ModelImport& m, bool instancing, bool visibleToCamera, MapMaterial material,
                     std::vector<MeshInput>& copies) {
    std::vector<uint32_t> sceneIndex(m.model.prototypes.size(), UINT32_MAX);
    std::vector<size_t> usesLeft(m.model.prototypes.size(), 0);
    for (const ModelInstance& instance : m.model.instances) ++usesLeft[instance.prototype];
    for (size_t k = 0; k < m.model.prototypes.size(); ++k) {
      MeshInput& in = m.model.prototypes[k];
      for (uint32_t& id : in.mesh.materialIds) id = material(id);
      const bool emits = std::any_of(in.mesh.materialIds.begin(), in.mesh.materialIds.end(),
                                     [&](uint32_t id) { return scene_.materials[id].isEmissive(); });
      if (emits && instancing)
        notes_.push_back(m.shown + ": mesh \"" + in.mesh.name + "\" emits light: copied for each of its " +
                         std::to_string(usesLeft[k]) + " uses (each copy is a light to sample)");
      if (emits || !instancing) continue;
      // In object space: the float positions are the object's; zero-area triangles there dropped.
      MeshInput object = std::move(in);
      sceneIndex[k] = uint32_t(scene_.prototypes.size());
      TriangleMesh& mesh = object.mesh;
      for (const DVec3& p : object.positions) {
        if (!(largestAbs(p) <= kMaxRenderDistance))
          r.fail(r.field("file"), "\"" + m.shown + "\": mesh \"" + mesh.name + "\" has a vertex " + showVec3(p) +
                                      " beyond " + shortNumber(kMaxRenderDistance) + " in its own space");
        mesh.positions.push_back(Vec3(p));
      }
      std::vector<DVec3>().swap(object.positions);
      dropDegenerateTriangles(mesh);
      finishAttributes(mesh);
      scene_.prototypes.push_back(std::move(mesh));
    }
    // Each kept prototype's box, once.
    const uint32_t firstPrototype = uint32_t(scene_.prototypes.size()) -
                                    uint32_t(std::count_if(sceneIndex.begin(), sceneIndex.end(),
                                                           [](uint32_t index) { return index != UINT32_MAX; }));
    std::vector<std::pair<Vec3, Vec3>> boxes;
    for (size_t k = firstPrototype; k < scene_.prototypes.size(); ++k)
      boxes.push_back(boundsOf(scene_.prototypes[k].positions));
    for (const ModelInstance& instance : m.model.instances) {
      const uint32_t k = instance.prototype;
      const bool last = --usesLeft[k] == 0;
      if (sceneIndex[k] == UINT32_MAX) {
        // A copy in world space (the last use takes the prototype's arrays).
        MeshInput copy;
        if (last)
          copy = std::move(m.model.prototypes[k]);
        else
          copy = m.model.prototypes[k];
        copy.mesh.name = instance.name;
        applyTransform(copy, Transform{instance.world});
        copies.push_back(std::move(copy));
        continue;
      }
      if (scene_.prototypes[sceneIndex[k]].triangleCount() == 0) continue;
      addInstance(r, sceneIndex[k], boxes[sceneIndex[k] - firstPrototype], instance, visibleToCamera, m.shown);
    }
    std::vector<MeshInput>().swap(m.model.prototypes);
    std::vector<ModelInstance>().swap(m.model.instances);
  }

  // One use of prototype `prototype`, placed in render space by `instance.world` (its world
  // transform): the matrix composed in double with the move to render space, then rounded.
  // `box`: the prototype's, in its own space.
  void addInstance(FieldReader& r, uint32_t prototype, const std::pair<Vec3, Vec3>& box, const ModelInstance& instance,
                   bool visibleToCamera, const std::string& shown) {
    const TriangleMesh& mesh = scene_.prototypes[prototype];
    glm::dmat4 world = instance.world;
    world[3] = glm::dvec4(DVec3(world[3]) - scene_.origin, 1.0);
    const auto& [lo, hi] = box;
    for (int c = 0; c < 8; ++c) {
      const DVec3 p(world * glm::dvec4(DVec3(boxCorner(lo, hi, c)), 1.0));
      if (!(largestAbs(p) <= kMaxRenderDistance))
        r.fail(r.field("file"), "\"" + shown + "\": instance \"" + instance.name + "\" of mesh \"" + mesh.name +
                                    "\" reaches " + shortNumber(glm::length(p)) + " from the camera; at most " +
                                    shortNumber(kMaxRenderDistance) + " (per axis) is supported");
    }
    const glm::dmat3 linear(world);
    const double det = glm::determinant(linear);
    MeshInstance out;
    out.prototype = prototype;
    out.toRender = glm::mat4x3(world);
    out.normalMatrix = glm::mat3(cofactorMatrix(linear) * (det < 0.0 ? -1.0 : 1.0));
    out.mirrors = det < 0.0;
    out.visibleToCamera = visibleToCamera;
    out.name = instance.name;
    scene_.instances.push_back(std::move(out));
    instancedTriangles_ += mesh.triangleCount();
  }

  // The shape of a model: its meshes as one, with its materials mapped (the shape's overrides,
  // then the model's own).
  void addImportedShape(FieldReader& r, MeshInput& out, size_t shapeIndex) {
    ModelImport* found = nullptr;
    for (ModelImport& m : imports_)
      if (m.shape == shapeIndex) found = &m;
    (void)r.has("file");
    (void)r.has("transform");  // read (and applied) by importModels
    ModelImport& m = *found;
    const uint32_t all = r.has("material") ? materialRef(r, "material") : UINT32_MAX;
    // For triangles that have no material otherwise (an OBJ without usemtl, or without its .mtl).
    const uint32_t fallback = r.has("fallback_material") ? materialRef(r, "fallback_material") : UINT32_MAX;
    size_t fellBack = 0;
    // Overrides by the model's material name ("materials") and, for OBJ, by group.
    std::map<std::string, uint32_t> byName, byGroup;
    std::set<std::string> namesUsed, groupsUsed;
    const auto readOverrides = [&](const char* key, std::map<std::string, uint32_t>& into) {
      if (!r.has(key)) return;
      FieldReader g(r.raw(key), r.field(key), fileName_);
      const json& object = r.raw(key);
      for (auto it = object.begin(); it != object.end(); ++it)
        into[it.key()] = lookupMaterial(r, g.field(it.key()), g.string(it.key()));
      g.finish();
    };
    readOverrides("materials", byName);
    if (m.obj) readOverrides("group_materials", byGroup);
    // The model's materials join the scene's, named after the model.
    const uint32_t first = uint32_t(scene_.materials.size());
    for (Material mat : m.model.materials) {
      mat.name = m.shown + ": " + mat.name;
      scene_.materials.push_back(std::move(mat));
    }
    std::vector<uint32_t> modelToScene(m.model.materials.size());
    for (size_t k = 0; k < m.model.materials.size(); ++k) {
      const std::string& name = m.model.materials[k].name;
      modelToScene[k] = first + uint32_t(k);
      if (auto it = byName.find(name); it != byName.end()) modelToScene[k] = it->second, namesUsed.insert(name);
    }
    for (const auto& [name, id] : byName)
      if (!namesUsed.count(name))
        r.fail(r.field("materials") + "." + name, "no material of that name in \"" + m.shown + "\"");

    // Meshes that several nodes use: instances, or copies that join the shape's meshes (their
    // materials mapped already).
    size_t firstCopy = SIZE_MAX;
    {
      const bool instancing = r.boolean("instancing", true);
      std::vector<MeshInput> copies;
      addPrototypes(
          r, m, instancing, out.mesh.visibleToCamera,
          [&](uint32_t id) { return all != UINT32_MAX ? all : modelToScene[id]; }, copies);
      firstCopy = m.model.meshes.size();
      for (MeshInput& copy : copies) m.model.meshes.push_back(std::move(copy));
    }
    // One mesh (one Embree geometry) for the whole shape, as an OBJ always was.
    TriangleMesh& mesh = out.mesh;
    const bool anyNormals = std::any_of(m.model.meshes.begin(), m.model.meshes.end(),
                                        [](const MeshInput& in) { return !in.mesh.normals.empty(); });
    bool anyUv[2];
    for (int set = 0; set < 2; ++set)
      anyUv[set] = std::any_of(m.model.meshes.begin(), m.model.meshes.end(),
                               [set](const MeshInput& in) { return !in.mesh.uv[set].empty(); });
    const bool anyTangents = std::any_of(m.model.meshes.begin(), m.model.meshes.end(),
                                         [](const MeshInput& in) { return !in.mesh.tangents.empty(); });
    size_t triangle = 0;
    for (size_t part = 0; part < m.model.meshes.size(); ++part) {
      MeshInput& in = m.model.meshes[part];
      const uint32_t base = uint32_t(out.positions.size());
      const size_t vertices = in.positions.size();
      appendAndFree(out.positions, in.positions);
      // Attributes a part lacks where another has them: its face normals are taken from the
      // geometry (zero: the shading code falls back to the geometric normal), uv 0.
      if (anyNormals) {
        if (in.mesh.normals.empty()) in.mesh.normals.assign(vertices, Vec3(0.0f));
        appendAndFree(mesh.normals, in.mesh.normals);
      }
      for (int set = 0; set < 2; ++set) {
        if (!anyUv[set]) continue;
        if (in.mesh.uv[set].empty()) in.mesh.uv[set].assign(vertices, Vec2(0.0f));
        appendAndFree(mesh.uv[set], in.mesh.uv[set]);
      }
      if (anyTangents) {
        if (in.mesh.tangents.empty()) in.mesh.tangents.assign(vertices, glm::vec4(0.0f));
        appendAndFree(mesh.tangents, in.mesh.tangents);
      }
      for (uint32_t& index : in.mesh.indices) index += base;
      appendAndFree(mesh.indices, in.mesh.indices);
      for (uint32_t& id : in.mesh.materialIds) {
        if (part >= firstCopy) continue;
        uint32_t material = all;
        if (m.obj) {
          const std::string& group = m.groupNames[m.triangleGroups[triangle]];
          if (auto it = byGroup.find(group); it != byGroup.end()) {
            material = it->second;
            groupsUsed.insert(group);
          } else if (material == UINT32_MAX && id != kNoObjMaterial) {
            material = modelToScene[id];
          }
          if (material == UINT32_MAX && fallback != UINT32_MAX) material = fallback, ++fellBack;
          if (material == UINT32_MAX)
            r.fail(r.field("material"), "OBJ group \"" + group +
                                            "\" has no material: give material or group_materials." + group +
                                            " (or a usemtl with an mtllib)");
        } else if (material == UINT32_MAX) {
          material = modelToScene[id];
        }
        id = material;
        ++triangle;
      }
      appendAndFree(mesh.materialIds, in.mesh.materialIds);
    }
    std::vector<MeshInput>().swap(m.model.meshes);  // spent: each part was moved or copied and freed
    std::vector<uint32_t>().swap(m.triangleGroups);
    for (const auto& [group, material] : byGroup)
      if (!groupsUsed.count(group))
        r.fail(r.field("group_materials") + "." + group, "no group of that name in \"" + m.shown + "\"");
    if (fellBack > 0)
      notes_.push_back(m.shown + ": " + std::to_string(fellBack) + " triangle(s) without a material use \"" +
                       scene_.materials[fallback].name + "\"");
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

  static void applyTransform(MeshInput& in, const Transform& t) {
    for (DVec3& p : in.positions) p = t.apply(p);
    const glm::dmat3 normalMatrix = t.normalMatrix();  // once, not per normal
    for (Vec3& n : in.mesh.normals) n = Vec3(normalMatrix * DVec3(n));
    // (A mirror reverses the bitangent w cross(n, t): w changes sign with the winding.)
    const float handedness = t.flipsHandedness() ? -1.0f : 1.0f;
    for (glm::vec4& v : in.mesh.tangents) v = glm::vec4(t.applyToVector(Vec3(v)), handedness * v.w);
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
      throw InputError(fileName_,
                       field + ": lies " + shortNumber(glm::length(d)) + " from the camera; at most " +
                           shortNumber(kMaxRenderDistance) +
                           " (per axis) is supported (squared distances must stay finite in single precision)");
    return Vec3(d);
  }

  // Moves a shape into render space, drops zero-area triangles (they have no normal and can
  // never be hit meaningfully) and returns how many triangles were kept.
  // In place: a big mesh is never copied.
  size_t addMesh(MeshInput in, const std::string& field) {
    TriangleMesh& mesh = in.mesh;
    mesh.positions.reserve(in.positions.size());
    for (size_t k = 0; k < in.positions.size(); ++k) {
      // (toRenderSpace's field is built only for a vertex it refuses.)
      const DVec3 d = in.positions[k] - scene_.origin;
      mesh.positions.push_back(largestAbs(d) <= kMaxRenderDistance
                                   ? Vec3(d)
                                   : toRenderSpace(in.positions[k], field + " vertex " + std::to_string(k)));
    }
    std::vector<DVec3>().swap(in.positions);
    const size_t count = dropDegenerateTriangles(mesh);
    finishAttributes(mesh);
    if (count > 0) scene_.meshes.push_back(std::move(mesh));
    return count;
  }

  // Drops the triangles of zero area as the renderer will see the float vertices
  // (math/triangle.h), at any size, and counts them in the scene; returns how many are kept.
  size_t dropDegenerateTriangles(TriangleMesh& mesh) {
    const size_t triangles = mesh.triangleCount();
    size_t count = 0;
    for (size_t tri = 0; tri < triangles; ++tri) {
      const uint32_t* idx = &mesh.indices[3 * tri];
      // Zero area as the renderer will see the float vertices (math/triangle.h), at any size.
      if (!triangleNormal(mesh.positions[idx[0]], mesh.positions[idx[1]], mesh.positions[idx[2]])) {
        ++scene_.skippedDegenerateTriangles;
        continue;
      }
      if (count != tri) {
        std::copy(idx, idx + 3, &mesh.indices[3 * count]);
        mesh.materialIds[count] = mesh.materialIds[tri];
      }
      ++count;
    }
    if (count < triangles) {
      mesh.indices.resize(3 * count), mesh.indices.shrink_to_fit();
      mesh.materialIds.resize(count), mesh.materialIds.shrink_to_fit();
    }
    return count;
  }

  // Vertex normals made unit length (after transforms) and tangents likewise; normals that only
  // repeat each triangle's geometric normal (a faceted mesh exported with normals) are dropped,
  // so such a mesh renders exactly, and as fast, as one without them.
  static void finishAttributes(TriangleMesh& mesh) {
    const auto unit = [](Vec3 v) {
      const float length = glm::length(v);
      return length > 0.0f && std::isfinite(length) ? v / length : Vec3(0.0f);
    };
    for (Vec3& n : mesh.normals) n = unit(n);
    for (glm::vec4& t : mesh.tangents) t = glm::vec4(unit(Vec3(t)), t.w < 0.0f ? -1.0f : 1.0f);
    if (mesh.normals.empty()) return;
    bool flat = true;
    for (size_t tri = 0; tri < mesh.triangleCount() && flat; ++tri) {
      const uint32_t* idx = &mesh.indices[3 * tri];
      const auto n = triangleNormal(mesh.positions[idx[0]], mesh.positions[idx[1]], mesh.positions[idx[2]]);
      for (int k = 0; k < 3 && flat; ++k) flat = n && glm::dot(*n, mesh.normals[idx[k]]) > 1.0f - 1e-6f;
    }
    if (flat) std::vector<Vec3>().swap(mesh.normals);
  }

  json& root_;
  fs::path file_;
  std::string fileName_;
  Scene scene_;
  AssetReader readAsset_;
  Sha256 hash_;
  std::map<std::string, uint32_t> materialIndex_;
  size_t shapeTriangles_ = 0;
  size_t instancedTriangles_ = 0;  // drawn through instances (each use counted)
  std::vector<ModelImport> imports_;
  std::string cameraOrigin_ = "camera";                 // where the camera's fields come from, for messages
  std::vector<std::string> notes_;                      // Scene::notes
  std::vector<std::shared_ptr<Medium>> unplacedMedia_;  // grids still in world space (placeMedia)
  std::optional<double> frame_;                         // the frame to evaluate keyframes at (none: the first)
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

AssetReader fileAssetReader(const fs::path& sceneFile, const std::vector<fs::path>& allowed) {
  const fs::path dir = sceneFile.parent_path();
  return [dir, allowed](const std::string& rel) { return readWholeFile(confinedFile(dir, rel, allowed)); };
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
  if (s.adaptive.enabled) {
    // Sixteen passes or more (farm/job_layout.h: a quarter uniform, then rounds), each a power
    // of two of at most kMaxConvergenceUnitSamples.
    const uint64_t fit = std::clamp<uint64_t>(std::min<uint64_t>(kAutoUnitPaths / 4 / pixels, s.samplesPerPixel / 16),
                                              1, kMaxConvergenceUnitSamples);
    return uint32_t(std::bit_floor(fit));
  }
  const uint64_t perUnit =
      std::clamp<uint64_t>((kAutoUnitPaths + pixels - 1) / pixels, 1, std::max<uint64_t>(1, s.samplesPerPixel));
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
      if (escaped)
        escaped = false;
      else if (c == '\\')
        escaped = true;
      else if (c == '"')
        inString = false;
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

namespace {
// What a binary file given as a scene is, by its magic bytes; nothing for text.
std::optional<std::string> binaryKind(const std::string& text) {
  static const std::pair<std::string, const char*> kMagic[] = {
      {"\x89PNG\r\n\x1a\n", "a PNG image"},
      {"\xff\xd8\xff", "a JPEG image"},
      {"\x76\x2f\x31\x01", "an OpenEXR image"},
      {"glTF", "a binary glTF model (.glb): give it a .glb name"},
      {"%PDF", "a PDF document"},
      {"PK\x03\x04", "a zip archive"},
      {"\x1f\x8b", "a gzip archive"},
      {"\x7f"
       "ELF",
       "a program"},
      {"BM", "a BMP image"},
      {"GIF8", "a GIF image"}};
  for (const auto& [magic, kind] : kMagic)
    if (text.compare(0, magic.size(), magic) == 0) return std::string(kind);
  const size_t head = std::min<size_t>(text.size(), 4096);
  if (text.find('\0') < head) return std::string("a binary file");
  return std::nullopt;
}
}  // namespace

Scene parseScene(const std::string& text, const fs::path& file, const AssetReader& readAsset,
                 std::optional<double> frame) {
  if (const std::optional<std::string> kind = binaryKind(text))
    throw InputError(file.string(), "is " + *kind +
                                        ", not a scene: a scene is a JSON file (docs/scene-format.md), a "
                                        "model a .gltf, .glb or .obj file");
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
  return SceneParser(root, file, readAsset ? readAsset : fileAssetReader(file), frame).parse();
}

Scene loadScene(const fs::path& file, std::optional<double> frame) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) throw InputError(file.string(), "no such scene file");
  if (isModelFile(file)) {
    std::string text;
    return modelScene(file, text);
  }
  return parseScene(readWholeFileOrThrow(file, file.string()), file, {}, frame);
}

bool isModelFile(const fs::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".gltf" || ext == ".glb" || ext == ".obj";
}

std::string withModelCamera(const std::string& text, const fs::path& file, const std::string& camera) {
  json root = json::parse(text, nullptr, false);
  if (!root.is_object()) throw InputError(file.string(), "is not a JSON object (the scene format)");
  root["camera"] = camera;
  return root.dump(2);
}

Scene modelScene(const fs::path& modelFile, std::string& text, const AssetReader& readAsset,
                 const std::optional<std::string>& camera) {
  std::string ext = modelFile.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  json scene = {{"format", kSceneFormat},
                {"render", {{"resolution", {1280, 720}}, {"samples_per_pixel", 64}, {"max_bounces", 4}}},
                {"shapes", {{{"type", ext == ".obj" ? "obj" : "gltf"}, {"file", modelFile.filename().string()}}}}};
  if (camera) scene["camera"] = *camera;
  if (ext == ".obj") {
    // Faces without a usemtl material (or whose .mtl is missing) are a light grey diffuse.
    scene["materials"] = {{"default grey", {{"type", "lambertian"}, {"albedo", 0.7}}}};
    scene["shapes"][0]["fallback_material"] = "default grey";
  }
  // The scene file the model's JSON stands for sits beside the model, so its assets resolve there;
  // its errors name the model, the file the user gave (the scene's own fields, "shapes[0]", are
  // left out: the user never wrote them).
  const fs::path asFile = modelFile.parent_path() / (modelFile.filename().string() + ".scene.json");
  const auto parse = [&]() {
    try {
      return parseScene(text, asFile, readAsset);
    } catch (const InputError& e) {
      std::string what = e.what();
      const std::string written = asFile.string() + ": ";
      if (what.rfind(written, 0) != 0) throw;
      what.erase(0, written.size());
      for (const std::string field : {"shapes[0] ", "shapes[0].", "shapes[0]: "})
        if (what.rfind(field, 0) == 0) what.erase(0, field.size());
      throw InputError(modelFile.string(), what);
    }
  };
  text = scene.dump(2);
  Scene s = parse();
  bool lit = !s.lights.empty();
  for (const Material& m : s.materials) lit |= m.isEmissive();
  if (lit) return s;
  // A studio look that shows the shape: a key light from 45 degrees above and to the left of the
  // camera (irradiance 3: a white surface facing it has radiance 3 / pi ~ 1), so the faces turned
  // up, left and right differ, and a dim uniform fill (radiance 0.15), which is also the
  // background; key to fill about 6:1.
  const ThinLensCamera view = s.camera();
  const Vec3 towardKey = glm::normalize(-1.0f * view.right() + 1.0f * view.up() - 1.4f * view.forward());
  scene["environment"] = {{"radiance", {0.15, 0.15, 0.15}}};
  scene["lights"] = {{{"type", "directional"},
                      {"name", "studio key"},
                      {"direction", {towardKey.x, towardKey.y, towardKey.z}},
                      {"irradiance", {3.0, 3.0, 3.0}}}};
  text = scene.dump(2);
  s = parse();
  s.notes.push_back(
      "lights: the model has none; lit as in a studio: a directional key light from 45 degrees above "
      "the camera's left (irradiance 3) and a uniform grey environment (radiance 0.15) as fill and background");
  return s;
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
  if (s.tileSize < RenderSettings::kTilesOff) {
    throw InputError(where,
                     "tile_size: must be \"auto\", \"off\" or at least 1 pixel, got " + std::to_string(s.tileSize));
  } else if (s.tileSize > std::max(s.width, s.height)) {
    throw InputError(where, "tile_size: " + std::to_string(s.tileSize) + " is larger than the " +
                                std::to_string(s.width) + "x" + std::to_string(s.height) + " frame");
  }
  if (s.adaptive.enabled) {
    if (s.tileSize > 0)
      throw InputError(where,
                       "adaptive: adaptive sampling follows the error over the whole frame in passes; give "
                       "tile_size \"off\" or \"auto\"");
    if (s.lightTracing == LightTracingMode::kOn)
      throw InputError(where,
                       "adaptive: light paths splat over the whole frame at one sample count; adaptive "
                       "sampling gives blocks their own counts: give light_tracing \"auto\" or \"off\"");
    if (!(s.adaptive.uniform > 0.0 && s.adaptive.uniform <= 1.0) ||
        !(s.adaptive.floor > 0.0 && s.adaptive.floor <= 1.0))
      throw InputError(where, "adaptive: uniform and floor must be fractions in (0, 1]");
    if (s.adaptive.blockEdge < 0 || s.adaptive.blockEdge > std::max(s.width, s.height))
      throw InputError(where, "adaptive.block: must be a block edge in [1, " +
                                  std::to_string(std::max(s.width, s.height)) + "] cells");
  }
  if (s.tileSize > 0 && s.convergenceDriven())
    throw InputError(where,
                     "tile_size: a job with target_error or time_limit stops after whole passes over the "
                     "frame; give tile_size \"off\" or \"auto\"");
}

namespace {
// The value of `kinds` whose name is `name` (the inverse of a *Name function), into `kind`.
template <class Kind>
bool parseByName(const std::string& name, std::initializer_list<Kind> kinds, const char* (*nameOf)(Kind), Kind& kind) {
  for (Kind k : kinds)
    if (name == nameOf(k)) {
      kind = k;
      return true;
    }
  return false;
}
}  // namespace

const char* integratorName(IntegratorKind kind) {
  switch (kind) {
    case IntegratorKind::kNaive: return "naive";
    case IntegratorKind::kNee: return "nee";
    case IntegratorKind::kNeeMis: break;
  }
  return "nee_mis";
}

bool parseIntegratorName(const std::string& name, IntegratorKind& kind) {
  return parseByName(name, {IntegratorKind::kNaive, IntegratorKind::kNee, IntegratorKind::kNeeMis}, integratorName,
                     kind);
}

const char* samplerName(SamplerKind kind) {
  switch (kind) {
    case SamplerKind::kIndependent: return "independent";
    case SamplerKind::kStratified: return "stratified";
    case SamplerKind::kSobol: break;
  }
  return "sobol";
}

const char* rouletteName(RouletteRule rule) {
  switch (rule) {
    case RouletteRule::kOff: return "off";
    case RouletteRule::kMax: return "max";
    case RouletteRule::kThroughput: break;
  }
  return "throughput";
}

bool parseRouletteName(const std::string& name, RouletteRule& rule) {
  return parseByName(name, {RouletteRule::kOff, RouletteRule::kMax, RouletteRule::kThroughput}, rouletteName, rule);
}

bool parseSamplerName(const std::string& name, SamplerKind& kind) {
  return parseByName(name, {SamplerKind::kIndependent, SamplerKind::kStratified, SamplerKind::kSobol}, samplerName,
                     kind);
}

}  // namespace lensfarm
