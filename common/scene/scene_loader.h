#pragma once
// Reads a scene file (JSON, docs/scene-format.md) and the OBJ meshes and OpenEXR environment map
// it references.
//
// Validation is strict: an unknown field, a wrong type, a non-finite number, a value out of
// range, a missing asset, a mesh that is not OBJ (scene/obj_check.h) or an impossible camera throws
// InputError whose message names the file and the field (e.g. "scenes/x.json:
// camera.focal_length: must be a finite number > 0").
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "common/scene/scene.h"

namespace lensfarm {

inline constexpr const char* kSceneFormat = "lensfarm-scene/1";

// Limits on render settings; a scene (or a command-line override) beyond them is refused.
inline constexpr int kMaxResolution = 16384;
inline constexpr uint64_t kMaxSamplesPerPixel = uint64_t(1) << 40;
inline constexpr int kMaxBounces = 1024;
// render.max_medium_bounces at most (scattering events in media per path; render/volume_integrator.h).
inline constexpr int kMaxMediumBounces = 65536;
inline constexpr double kMaxExposureEv = 64.0;  // exposure.ev (stops) is in [-64, 64]
// camera.sensor_width when angle_of_view is given without it: a 36 mm (full-frame) sensor in a
// scene in metres. Only the thin lens's blur depends on it (through f and the aperture f / N).
inline constexpr double kDefaultSensorWidth = 0.036;
// How far from the camera (per axis, in scene units) anything may lie: the bound on ray origins
// (Embree's, camera/thin_lens_camera.h), and squared distances of 1e36 stay finite in single
// precision (docs/numerics.md, "Limits the renderer guarantees").
inline constexpr double kMaxRenderDistance = kMaxRayOriginDistance;
inline constexpr uint64_t kMaxTriangles = uint64_t(1) << 26;  // 67 M: far beyond any scene we render
// Uses of instanced meshes (scene/scene.h, MeshInstance): 16 M, each about 200 bytes in Embree.
inline constexpr uint64_t kMaxInstances = uint64_t(1) << 24;

// Reads an asset (an OBJ file, an environment map) that a scene names by its path relative to the
// scene file; nothing if there is no such asset. The farm resolves assets from its content store
// this way.
using AssetReader = std::function<std::optional<std::string>(const std::string& relativePath)>;

// Reads assets from the file system, relative to `sceneFile`'s directory, inside it or inside one
// of the `allowed` folders (scene/asset_path.h); a path outside them throws AssetRefused, which
// the scene loader reports naming the field or the model file.
AssetReader fileAssetReader(const std::filesystem::path& sceneFile,
                            const std::vector<std::filesystem::path>& allowed = {});

// A scene file, or a model file (.gltf, .glb, .obj) rendered with modelScene's defaults.
// `frame`: the frame of an animated scene to evaluate its keyframes at (docs/scene-format.md,
// "Animation"; scene/keyframes.h); without one, the scene's first keyframe's frame. A scene
// without keyframes is the same at every frame.
Scene loadScene(const std::filesystem::path& file, std::optional<double> frame = std::nullopt);

// Whether `file` names a model rather than a scene (by its extension: .gltf, .glb, .obj).
bool isModelFile(const std::filesystem::path& file);
// The shape types that import a model file, one per file format (scene/imported_model.h): "obj",
// "gltf" and "usd"; and the type of a model file by its extension ("" for any other file).
bool isModelShapeType(const std::string& type);
std::string modelShapeTypeOf(const std::filesystem::path& file);
// The scene that renders a model file as it is (`lensfarm render model.glb`): the model as the
// only shape with its own materials, its first camera (or one framing it), its lights, 1280x720
// at 64 samples per pixel with 4 bounces; and, if the model has no lights, a studio light: a
// directional key light from above the camera's left and a dim grey environment as fill and
// background (Scene::notes says so). `text` receives the scene's JSON, which the
// farm ships as the job's scene.
// `camera`: the name of the model camera to use (default: its first).
Scene modelScene(const std::filesystem::path& modelFile, std::string& text, const AssetReader& readAsset = {},
                 const std::optional<std::string>& camera = std::nullopt);
// Scene text whose "camera" is replaced by the name of a model camera ("camera": "NAME"), or an
// InputError naming `file` if the text is not a JSON object.
std::string withModelCamera(const std::string& text, const std::filesystem::path& file, const std::string& camera);

// Parses scene text as if read from `file`; assets come from `readAsset` (by default the file
// system, relative to `file`). `frame` as for loadScene; Scene::hash is that of the text, the
// same for every frame.
Scene parseScene(const std::string& text, const std::filesystem::path& file, const AssetReader& readAsset = {},
                 std::optional<double> frame = std::nullopt);

// Checks render settings against the limits above (used after command-line overrides too).
// Throws InputError naming `where` and the field.
void validateRenderSettings(const RenderSettings& settings, const std::string& where);

}  // namespace lensfarm
