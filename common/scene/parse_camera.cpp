// SceneParser, the camera: the scene's (thin lens, pinhole or real lens), a model's, or one
// framing the models; its frame and lengths, the aperture, diffraction, and focus breathing.
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/camera/aperture_image.h"
#include "common/scene/lens_prescription.h"
#include "common/scene/scene_parser.h"
#include "common/util/error.h"
#include "common/util/field_reader.h"

namespace lensfarm {

double SceneParser::positive(FieldReader& r, const std::string& key) {
  const double x = r.number(key);
  if (!(x > 0.0)) r.fail(r.field(key), "must be > 0, got " + shortNumber(x));
  return x;
}

void SceneParser::parseCamera(FieldReader& top) {
  if (!top.has("camera") || top.raw("camera").is_string()) {
    json camera = top.has("camera") ? modelCamera(top.raw("camera").get<std::string>()) : modelCamera();
    FieldReader r(camera, cameraOrigin_, fileName_);
    parseCameraFields(r);
    return;
  }
  FieldReader r(top.raw("camera"), "camera", fileName_);
  parseCameraFields(r);
}

json SceneParser::modelCamera(const std::optional<std::string>& wanted) {
  if (wanted) {
    std::string names;
    for (const ModelImport& m : imports_)
      for (const json& c : m.model.cameras) {
        const std::string name = c.value("name", std::string());
        if (name == *wanted) return useModelCamera(m.field, m.shown, c, name);
        names += (names.empty() ? "\"" : ", \"") + name + "\"";
      }
    throw InputError(
        fileName_, "camera: no model camera named \"" + *wanted + "\" (" +
                       (names.empty() ? std::string("the models have no cameras") : "the models have " + names) + ")");
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
  notes_.push_back("camera: none in the scene or its models; framing them from the front: position " + showVec3(from) +
                   ", look_at " + showVec3(centre) + ", angle_of_view 40, fov_axis smaller");
  return json{{"type", "pinhole"},
              {"position", {from.x, from.y, from.z}},
              {"look_at", {centre.x, centre.y, centre.z}},
              {"angle_of_view", 40.0},
              {"fov_axis", "smaller"}};
}

json SceneParser::useModelCamera(const std::string& field, const std::string& shown, const json& modelCamera,
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

void SceneParser::parseDiffraction(FieldReader& r, const std::string& type) {
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
      d.fail(d.field("scene_units_per_mm"), "a real lens's scene unit is camera.scene_units_per_mm; leave it out here");
    settings.sceneUnitsPerMm = positive(d, "scene_units_per_mm");
  }
  d.finish();
  scene_.diffraction = settings;
}

void SceneParser::parseRealLens(FieldReader& r, double lookAtDistance) {
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
      r.fail(r.field("f_number"),
             "f/" + shortNumber(n) + " is wider than " + lens.name + " opens (f/" + shortNumber(design.fNumber) + ")");
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

double SceneParser::parseCameraFrame(FieldReader& r) {
  ThinLensParams& p = scene_.cameraParams;
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
  return glm::length(lookAt - position);
}

SceneParser::CameraLengths SceneParser::parseCameraLengths(FieldReader& r) {
  ThinLensParams& p = scene_.cameraParams;
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
  p.focalLength = hasF
                      ? positive(r, "focal_length")
                      : focalLengthFromAngleOfView(sensorExtent(p.sensorWidth, sceneSensorHeight(p), p.fovAxis), angle);
  return CameraLengths{hasF, hasAngle, hasWidth, angle};
}

void SceneParser::parseAperture(FieldReader& r, const std::string& type) {
  ThinLensParams& p = scene_.cameraParams;
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
}

void SceneParser::checkFocalLengthUnit(FieldReader& r, const std::string& type, const CameraLengths& lengths,
                                       double lookAtDistance) {
  const ThinLensParams& p = scene_.cameraParams;
  const auto [hasF, hasAngle, hasWidth, angle] = lengths;
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
                                         shortNumber(kDefaultSensorWidth) + " gives f = " + shortNumber(p.focalLength) +
                                         ", not shorter than " + distance +
                                         ": give sensor_width in the scene's unit, or a wider angle");
  }
}

void SceneParser::parseCameraFields(FieldReader& r) {
  ThinLensParams& p = scene_.cameraParams;
  const std::string type = r.string("type");
  if (type != "thin_lens" && type != "pinhole" && type != "real_lens")
    r.fail(r.field("type"), "unknown camera type \"" + type + "\" (expected thin_lens, pinhole or real_lens)");
  const double lookAtDistance = parseCameraFrame(r);
  if (type == "real_lens") return parseRealLens(r, lookAtDistance);
  const CameraLengths lengths = parseCameraLengths(r);
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
  parseAperture(r, type);
  parseDiffraction(r, type);
  if (scene_.diffraction && std::isinf(p.fNumber))
    r.fail(r.field("diffraction"), std::string("needs a lens aperture to diffract at: ") +
                                       (type == "pinhole" ? "a pinhole camera has none" : "f_number is infinity") +
                                       " (use a thin_lens with a finite f_number)");
  r.finish();
  checkFocalLengthUnit(r, type, lengths, lookAtDistance);
  try {
    const ThinLensCamera camera(p, scene_.render.width, scene_.render.height);
    if (type == "thin_lens") noteFocusBreathing(camera, lengths.hasAngle);
  } catch (const InputError& e) {
    // The camera names its own field; report it in the scene file's terms.
    const std::string msg = e.what();
    r.fail(r.field(e.where()), msg.substr(e.where().size() + 2));
  }
}

void SceneParser::noteFocusBreathing(const ThinLensCamera& camera, bool hasAngle) {
  const ThinLensParams& p = camera.params();
  const double extent = sensorExtent(p.sensorWidth, p.sensorHeight, p.fovAxis);
  const double atInfinity = angleOfViewDegrees(extent, p.focalLength),
               focused = angleOfViewDegrees(extent, camera.imageDistance());
  if (!(focused < atInfinity * (1.0 - 0.005))) return;
  notes_.push_back("camera: focused at " + shortNumber(p.focusDistance) + ", the thin lens sees " +
                   shortNumber(focused) + " degrees " + fovAxisName(p.fovAxis) + ", not the " +
                   shortNumber(atInfinity) +
                   (hasAngle ? " of its angle_of_view (which holds at infinity focus)" : " it sees at infinity focus") +
                   "; a pinhole sees its angle_of_view exactly");
}

double SceneParser::sceneSensorHeight(const ThinLensParams& p) const {
  return p.sensorHeight > 0.0 ? p.sensorHeight : p.sensorWidth * scene_.render.height / scene_.render.width;
}

FovAxis SceneParser::fovAxisNamed(FieldReader& r, const std::string& name) {
  for (const FovAxis axis :
       {FovAxis::kHorizontal, FovAxis::kVertical, FovAxis::kDiagonal, FovAxis::kSmaller, FovAxis::kLarger})
    if (name == fovAxisName(axis)) return axis;
  r.fail(r.field("fov_axis"),
         "unknown axis \"" + name + "\" (expected horizontal, vertical, diagonal, smaller or larger)");
}

}  // namespace lensfarm
