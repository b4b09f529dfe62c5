#pragma once
// SceneParser: reads a scene file's JSON (docs/scene-format.md) into a Scene, the reader behind
// parseScene (scene/scene_loader.h). Internal to common/scene; nothing outside it includes this.
//
// One class, its sections in their own files:
//   scene_loader.cpp           the top-level flow (constructor, parse()) and the public entry points
//   parse_render_settings.cpp  render: resolution, samples, integrator, tile size, exposure...
//   parse_materials.cpp        media and materials, and the lookup of a material by name
//   parse_camera.cpp           the camera: thin lens, pinhole, real lens, a model's camera or one
//                              framing the models, diffraction
//   parse_models.cpp           model files (OBJ, glTF) a shape names: import, prototypes and instances
//   parse_shapes.cpp           shapes (quads, inline triangles) and meshes moved to render space
//   parse_lights.cpp           lights, the models' lights and the environment
//   parse_assets.cpp           files the scene names, read, hashed and recorded as assets
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/medium/medium.h"
#include "common/scene/imported_model.h"
#include "common/scene/scene.h"
#include "common/scene/scene_loader.h"
#include "common/scene/transform.h"
#include "common/util/asset_loader.h"
#include "common/util/field_reader.h"
#include "common/util/hash.h"

namespace lensfarm {

class SceneParser {
 public:
  // `root` is evaluated at `frame` in place (scene/keyframes.h) after it is hashed.
  SceneParser(json& root, const std::filesystem::path& file, AssetReader readAsset, std::optional<double> frame);
  Scene parse();

 private:
  // A number as the messages show it (as a stream writes it: 6 significant digits), and a point as
  // [x, y, z] (scene_loader.cpp).
  static std::string shortNumber(double x);
  static std::string showVec3(const DVec3& v);

  // ---- render (parse_render_settings.cpp)

  void parseRender(FieldReader& top);
  // render.resolution: [width, height], each side in [1, kMaxResolution].
  void parseResolution(FieldReader& r);
  // The path tracer's choices: integrator, sampler, Russian roulette and light tracing.
  void parseIntegratorSettings(FieldReader& r);
  // render.aovs: the extra images (docs/aovs.md), a list of names or one comma-separated string.
  void parseAovs(FieldReader& r);
  // render.adaptive: true, false or {uniform, block, floor}.
  void parseAdaptive(FieldReader& r);
  // render.exposure: ev, tone_map and meter.
  void parseExposure(FieldReader& r);

  // ---- media and materials (parse_materials.cpp)

  // `media` (docs/scene-format.md, "Media"): named media, read before the materials that put
  // them inside their meshes.
  void parseMedia(FieldReader& top);

  // Grids move to render space with the rest of the scene; then the scene's own `medium`.
  void placeMedia(FieldReader& top);
  void parseMaterials(FieldReader& top);
  uint32_t materialRef(FieldReader& r, const std::string& key);
  uint32_t lookupMaterial(FieldReader& r, const std::string& field, const std::string& name);

  // ---- camera (parse_camera.cpp)

  // A number that must be > 0 (camera lengths).
  static double positive(FieldReader& r, const std::string& key);
  void parseCamera(FieldReader& top);

  // Without a "camera" in the scene: the first camera of the first model that has one, else one
  // that frames every model: a pinhole whose 40-degree view along the image's shorter side holds
  // every corner of their bounds (with a 10 % margin), from the front, +z, and a little above,
  // so the whole model shows at any aspect ratio; named in the scene's notes.
  // With `wanted` (the scene's "camera": "NAME"), the model camera of that name, or an error listing
  // the cameras the models have.
  json modelCamera(const std::optional<std::string>& wanted = std::nullopt);

  // A model's camera as the scene's, with a note naming it, and the aspect ratio it was framed for
  // (Scene::cameraFramedAspect).
  json useModelCamera(const std::string& field, const std::string& shown, const json& modelCamera,
                      const std::string& name);

  // camera.diffraction (film/diffraction_psf.h): true, false, or an object with `wavelengths` (per
  // colour channel) and, for a thin lens, `scene_units_per_mm` (a real lens has its own).
  void parseDiffraction(FieldReader& r, const std::string& type);

  // A camera with a real lens (camera/real_lens_camera.h): the frame is read already; the lens
  // file, the sensor, the focus and the stop. cameraParams become the lens's thin-lens
  // equivalent, for the effect analysis and `lensfarm dof`.
  void parseRealLens(FieldReader& r, double lookAtDistance);
  void parseCameraFields(FieldReader& r);

  // Which of focal_length, angle_of_view and sensor_width were given, and the angle in degrees (0: none).
  struct CameraLengths {
    bool hasF, hasAngle, hasWidth;
    double angle;
  };
  // position, look_at and up: the camera at render space's origin, its view and up defined; the distance to look_at.
  double parseCameraFrame(FieldReader& r);
  // The sensor (sensor_width, sensor_height) and the focal length, given or from angle_of_view.
  CameraLengths parseCameraLengths(FieldReader& r);
  // A thin lens's aperture shape (blades, rotation, curvature, image) and the f-number (a pinhole's: infinity).
  void parseAperture(FieldReader& r, const std::string& type);
  // An f not shorter than the distance to look_at is a unit slip (mm in a scene in metres): fails naming the length.
  void checkFocalLengthUnit(FieldReader& r, const std::string& type, const CameraLengths& lengths,
                            double lookAtDistance);

  // A thin lens focused near moves its sensor back (S2 > f) and sees a narrower angle than at
  // infinity focus, as a real lens "breathes": say so when the difference shows (0.5 %).
  void noteFocusBreathing(const ThinLensCamera& camera, bool hasAngle);

  // The sensor height the camera will have at the scene's resolution (0 in the scene: square cells).
  double sceneSensorHeight(const ThinLensParams& p) const;
  static FovAxis fovAxisNamed(FieldReader& r, const std::string& name);

  // ---- models (parse_models.cpp)

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
  void importModels(FieldReader& top);

  // Files a model refers to, relative to the model file, read through the scene's asset reader
  // and recorded as assets. A missing MTL library is an empty one (noted): an OBJ exported with
  // materials still loads when the scene gives its materials.
  ModelFileReader modelFileReader(const std::string& modelRel, ModelImport& m);

  // The shape's transform on every mesh, camera and light of a model (still in world space).
  static void transformModel(ModelImport& m, const Transform& t);

  // A model's meshes that several nodes use (ImportedModel::prototypes), their materials mapped
  // by `material`: each is stored once in object space and placed by instances (scene/scene.h),
  // unless one of its materials emits or the shape sets "instancing": false; then each use is a
  // copy, moved into `copies` in world space.
  template <typename MapMaterial>
  void addPrototypes(FieldReader& r, ModelImport& m, bool instancing, bool visibleToCamera, MapMaterial material,
                     std::vector<MeshInput>& copies);

  // One use of prototype `prototype`, placed in render space by `instance.world` (its world
  // transform): the matrix composed in double with the move to render space, then rounded.
  // `box`: the prototype's, in its own space.
  void addInstance(FieldReader& r, uint32_t prototype, const std::pair<Vec3, Vec3>& box, const ModelInstance& instance,
                   bool visibleToCamera, const std::string& shown);

  // The shape of a model: its meshes as one, with its materials mapped (the shape's overrides,
  // then the model's own).
  void addImportedShape(FieldReader& r, MeshInput& out, size_t shapeIndex);

  // How a model shape's triangles get their materials (parse_models.cpp).
  struct ShapeMaterials;
  // The shape's material, fallback_material and overrides; the model's own materials join the scene's.
  ShapeMaterials readShapeMaterials(FieldReader& r, ModelImport& m);
  // A triangle's scene material: its OBJ group's override, else the shape's, the model's own, the fallback.
  uint32_t triangleMaterial(FieldReader& r, const ModelImport& m, ShapeMaterials& s, uint32_t id, size_t triangle);
  // The model's meshes appended into `out` as one, each freed; the copies (from part firstCopy on) keep their ids.
  void mergeShapeMeshes(FieldReader& r, ModelImport& m, ShapeMaterials& s, size_t firstCopy, MeshInput& out);

  // ---- shapes and render space (parse_shapes.cpp)

  void parseShapes(FieldReader& top);
  static void addQuad(MeshInput& in, DVec3 corner, DVec3 e1, DVec3 e2, uint32_t material);
  void readInlineTriangles(FieldReader& r, MeshInput& in);
  static void applyTransform(MeshInput& in, const Transform& t);

  // A world position in render space: relative to the camera, in float. The difference is
  // taken in double, so a scene placed anywhere renders as it does at the origin
  // (docs/numerics.md, "Far from the origin"); what must stay finite in float (squared
  // distances) bounds how far from the camera anything may be.
  Vec3 toRenderSpace(const DVec3& world, const std::string& field) const;

  // Moves a shape into render space, drops zero-area triangles (they have no normal and can
  // never be hit meaningfully) and returns how many triangles were kept.
  // In place: a big mesh is never copied.
  size_t addMesh(MeshInput in, const std::string& field);

  // Drops the triangles of zero area as the renderer will see the float vertices
  // (math/triangle.h), at any size, and counts them in the scene; returns how many are kept.
  size_t dropDegenerateTriangles(TriangleMesh& mesh);

  // Vertex normals made unit length (after transforms) and tangents likewise; normals that only
  // repeat each triangle's geometric normal (a faceted mesh exported with normals) are dropped,
  // so such a mesh renders exactly, and as fast, as one without them.
  static void finishAttributes(TriangleMesh& mesh);

  // ---- lights and environment (parse_lights.cpp)

  void parseLights(FieldReader& top);

  // The lights the models bring (KHR_lights_punctual), after the scene's own.
  void addModelLights();
  void parseLightEntry(const json& entry, const std::string& path);

  // A quad light far smaller than its distance from the camera has its float corners rounded by a
  // good part of its size (a 1e-6 quad 2 from the camera: ~10 % of its area), which changes its
  // power. Its radiance is scaled by the written area over the float one, so that the power is
  // what the scene says; a light whose float area is within 1e-4 of the written one keeps its
  // radiance (and every scene of ordinary proportions its bits).
  static void holdQuadPower(const TriangleMesh& placed, double writtenArea, Material& material);

  // The optional top-level "environment" (light/environment_light.h), after the lights.
  void parseEnvironment(FieldReader& top);

  // ---- assets (parse_assets.cpp)

  // A file named by field `key` of r, relative to the scene file, read through the asset reader
  // and added to the scene's hash and assets (so the farm ships it to workers), or one error
  // naming the field and the path.
  // A path the asset root refuses (scene/asset_path.h) is named with the reason.
  LoadedAsset readAssetFile(FieldReader& r, const std::string& key, const std::string& kind);

  // Why a file could not be read, with the path it was looked for at.
  static std::string missingFile(const std::filesystem::path& path);

  // An asset into the scene's hash, and its own hash into the scene's assets: two passes over the
  // bytes (a big model's take a while), side by side.
  void addAssetHash(const std::string& rel, const std::string& content);

  json& root_;
  std::filesystem::path file_;
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

}  // namespace lensfarm
