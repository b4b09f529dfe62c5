#pragma once
// A loaded, validated scene: what a render needs and nothing of the file it came from.
// The file format is docs/scene-format.md; scene/scene_loader.h reads it.
#include <cstdint>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/camera/real_lens_camera.h"
#include "common/camera/thin_lens_camera.h"
#include "common/film/aov_layout.h"
#include "common/film/exposure.h"
#include "common/light/light_source.h"
#include "common/material/material.h"
#include "common/math/vec.h"
#include "common/util/trace_kernel.h"

namespace lensfarm {

// Render space. The loader moves the whole scene so that the camera sits at the origin: a
// position p in the file (world space) is p - Scene::origin here, the difference taken in double
// before rounding to float. Near the camera, where a pixel resolves the finest detail, float
// then has its full precision wherever the scene lies in the world (docs/numerics.md, "Far from
// the origin").
//
// A triangle soup with one material per triangle. Positions are in render space. Triangles face
// the side of n = cross(v1 - v0, v2 - v0) (counter-clockwise, as in OBJ).
//
// Vertex attributes, optional, indexed like positions (an empty array: the mesh has none):
//  - normals: unit shading normals in render space, interpolated across a triangle (smooth
//    shading). The renderer never lets a shading normal carry light through the surface
//    (render/shading_point.h). A mesh without them is shaded with its geometric normals.
//  - uv[0], uv[1]: texture coordinates (glTF TEXCOORD_0 / TEXCOORD_1; texture/texture.h has the
//    convention).
//  - tangents: xyz a unit tangent along +u, w = +1 or -1 the handedness of the bitangent
//    (glTF TANGENT); without them normal maps use the triangle's own uv tangent.
struct TriangleMesh {
  std::string name;
  std::vector<Vec3> positions;
  std::vector<uint32_t> indices;      // 3 per triangle
  std::vector<uint32_t> materialIds;  // 1 per triangle, into Scene::materials
  std::vector<Vec3> normals;
  std::vector<Vec2> uv[2];
  std::vector<glm::vec4> tangents;
  bool visibleToCamera = true;  // false: camera rays pass through (the 2013 report's light, §4.4)
  size_t triangleCount() const { return materialIds.size(); }
  // A vertex attribute (normals, uv[k], tangents) at barycentrics (b1, b2) of triangle `tri`:
  // (1 - b1 - b2) a0 + b1 a1 + b2 a2, the weights of the hit point (render/ray_caster.h).
  template <typename T>
  T interpolate(const std::vector<T>& attribute, size_t tri, float b1, float b2) const {
    const uint32_t* idx = &indices[3 * tri];
    return (1.0f - b1 - b2) * attribute[idx[0]] + b1 * attribute[idx[1]] + b2 * attribute[idx[2]];
  }
  // Whether anything varies across a triangle (normals or texture coordinates).
  bool hasAttributes() const { return !normals.empty() || !uv[0].empty() || !uv[1].empty(); }
};

// A mesh drawn many times (a glTF mesh that several nodes use): stored once, in its own object
// space, in Scene::prototypes, and placed by each instance's transform. Embree traces it as an
// instance (render/ray_caster.h), so a thousand uses cost a thousand transforms, not a thousand
// copies. A prototype's materials never emit: the loader copies an emitting mesh per use, so that
// each copy is a light the light sampler can pick (docs/scene-format.md, "Instancing").
struct MeshInstance {
  uint32_t prototype = 0;  // into Scene::prototypes
  // Object space -> render space: the columns x, y, z and the translation, in float, exactly the
  // matrix Embree traces with (RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR has this layout).
  glm::mat4x3 toRender{1.0f};
  // Normals go by the cofactor of the linear part (its inverse transpose times det), negated
  // for a mirroring transform, then renormalised.
  glm::mat3 normalMatrix{1.0f};
  bool mirrors = false;  // det < 0: the winding, so the front face, and tangents' handedness flip
  bool visibleToCamera = true;
  std::string name;

  Vec3 point(const Vec3& p) const { return toRender * glm::vec4(p, 1.0f); }
  Vec3 vector(const Vec3& v) const { return glm::mat3(toRender) * v; }
};

enum class IntegratorKind {
  kNaive,   // the 2013 report's estimator: a path counts only when a scattered ray hits a light (§4.7)
  kNee,     // next-event estimation: one shadow ray per diffuse vertex, scattered hits ignored
  kNeeMis,  // next-event estimation and scattered hits, combined by MIS (power heuristic)
};

// How sample values are drawn (render/sampler.h).
enum class SamplerKind { kIndependent, kStratified, kSobol };

// Light tracing beside the path tracer (render/light_tracer.h): kAuto lets the effect analysis
// decide (scene/effects.h), kOn and kOff force it where the camera and layout allow it.
enum class LightTracingMode { kAuto, kOn, kOff };
// render.path_guiding (render/path_guiding.h): auto turns it on where a diffuse surface sees a light
// through a mirror or smooth glass (scene/effects.h).
enum class PathGuidingMode { kAuto, kOn, kOff };

// How next-event estimation chooses among the lights in the scene (render/light_tree.h): kAuto
// lets the effect analysis decide by their number (scene/effects.h), kOn always by a light tree,
// kOff by power alone.
enum class LightTreeMode { kAuto, kOn, kOff };

// How the volume path tracer finds the light scattered towards the camera in a medium
// (render/volume_integrator.cpp): kAuto adds equiangular sampling towards a light point, combined
// with free-flight sampling by MIS, wherever the effect analysis finds it applies and pays;
// kEquiangular adds it wherever it applies (also beside a light tree); kDistance keeps free-flight
// sampling alone (the study's baseline).
enum class MediumLightSampling { kAuto, kDistance, kEquiangular };

// How a light sample takes its point on an emitting triangle (render/light_sampler.h): kAuto by
// the solid angle the triangle covers where the shading point is near it and by area elsewhere;
// kArea by area everywhere (the study's baseline); kSolidAngle by solid angle everywhere.
enum class TriangleLightSampling { kAuto, kArea, kSolidAngle };

// Diffraction by the aperture (docs/scene-format.md, camera.diffraction; film/diffraction_psf.h): a
// point-spread function applied to the developed image, never to the sensor's sums.
struct DiffractionSettings {
  int wavelengthsPerChannel = 4;   // wavelengths averaged in each RGB channel's band
  double sceneUnitsPerMm = 0.001;  // a thin lens's scene unit in mm, for the wavelength (a real lens has its own)
};

// Russian roulette's rule (docs/scene-format.md, render.russian_roulette). A path that has made
// more than rouletteMinBounces counted bounces goes on with probability q and carries 1/q more:
//  - kMax (`true`, the original rule): q = min(1, max component of the throughput).
//  - kThroughput (Cycles' path_state_continuation_probability): q = min(1, sqrt(max component of
//    throughput x eta^2)), eta^2 the product of the refractions' radiance scalings (pbrt-v4's
//    etaScale), so a path inside glass is not ended for the 1/eta^2 that leaving it gives back;
//    and never for the ray after the last counted bounce, which only gathers emission.
enum class RouletteRule { kOff, kMax, kThroughput };
// The rule a scene without render.russian_roulette gets, and the one the override
// --russian-roulette on turns on in a scene that has roulette off: throughput, the best or tied-best
// error per second on every shipped scene (docs/performance.md, "Russian roulette by error per
// second"). A test that needs every path's value exact (a furnace) sets "off".
inline constexpr RouletteRule kDefaultRoulette = RouletteRule::kThroughput;
inline constexpr RouletteRule kRouletteOn = RouletteRule::kThroughput;

// Adaptive sampling (film/adaptive_allocation.h, docs/accuracy.md "Adaptive sampling"): off
// unless asked for. The job's samples per pixel become a mean: `uniform` of them over every pixel
// first, the rest in rounds that follow the error.
struct AdaptiveSettings {
  bool enabled = false;
  double uniform = 0.25;  // the fraction of the samples spent uniformly first, in (0, 1]
  int blockEdge = 0;      // cells of a block's edge; 0: automatic (16, more for frames over 4096 blocks)
  double floor = 0.125;   // a block's least share of a round, as a fraction of the mean, in (0, 1]
};

struct RenderSettings {
  int width = 0, height = 0;
  uint64_t samplesPerPixel = 0;
  int maxBounces = 2;  // B (2013 report §4.5)
  // Scattering events in participating media a path may make besides its B surface bounces
  // (render/volume_integrator.h): a random walk through milk or marble takes many.
  int maxMediumBounces = 256;
  uint64_t seed = 0;
  IntegratorKind integrator = IntegratorKind::kNeeMis;
  bool mirrorBouncesCount = false;  // 2013 report §4.5: mirror reflections do not count toward B
  uint32_t samplesPerUnit = 0;      // samples per pixel in one unit of work; 0 = automatic
  SamplerKind sampler = SamplerKind::kSobol;
  // Russian roulette (render/integrator.cpp, survivesRoulette): unbiased early termination of dim
  // paths, by `roulette`, from the counted bounce after the first `rouletteMinBounces` on.
  RouletteRule roulette = kDefaultRoulette;
  int rouletteMinBounces = 1;
  LightTracingMode lightTracing = LightTracingMode::kAuto;  // render/light_tracer.h
  MediumLightSampling mediumLightSampling = MediumLightSampling::kAuto;
  LightTreeMode lightTree = LightTreeMode::kAuto;
  TriangleLightSampling triangleLightSampling = TriangleLightSampling::kAuto;
  PathGuidingMode pathGuiding = PathGuidingMode::kAuto;  // render/path_guiding.h
  AovSet aovs;                                           // outputs beside the beauty (film/aov_layout.h, docs/aovs.md)
  double lightTracingRatio = 0.25;                       // light paths per camera path (pixel-sample) of a unit
  // Stopping rules besides samplesPerPixel (which is then a cap); 0 = not set. See docs/accuracy.md.
  double targetError = 0.0;       // stop when the estimated relative RMSE falls to this
  double timeLimitSeconds = 0.0;  // stop this long after submission, in whole units
  // How the frame is cut into units (farm/job_layout.h): kTilesAuto, kTilesOff (passes over the
  // whole frame) or N for N x N tiles, each a unit with all its samples. Never changes a bit of
  // the image, only how it is scheduled, uploaded and held.
  int tileSize = 0;
  static constexpr int kTilesAuto = 0, kTilesOff = -1;
  AdaptiveSettings adaptive;  // needs passes (tile_size "off" or "auto")
  // Embree's traversal kernel (util/trace_kernel.h): unset, the machine's widest. A farm job's is
  // pinned (docs/farm.md "Mixed machines"); it changes bits, never what is simulated.
  std::optional<TraceKernel> kernel;
  ExposureSettings exposure;

  bool convergenceDriven() const { return targetError > 0.0 || timeLimitSeconds > 0.0; }
};

// Samples per pixel in one unit of work. Automatic: about kAutoUnitPaths paths per unit (a few
// seconds on a small machine, so a farm's uploads stay small next to its tracing), and never
// more than the whole job. Jobs that stop at a target error or a deadline use units of at most
// a quarter of that and at most kMaxConvergenceUnitSamples samples per pixel (a power of two),
// so they stop close to their target and waste little at the deadline; adaptive jobs use units of
// at most a sixteenth of their samples, so that rounds have units to share out. A function of the
// settings only, so every process agrees on it.
inline constexpr uint64_t kAutoUnitPaths = uint64_t(1) << 23;
inline constexpr uint64_t kMaxConvergenceUnitSamples = 16;
uint32_t unitSize(const RenderSettings& settings);

// The frames of an animated scene's first and last keyframe (docs/scene-format.md, "Animation").
struct KeyframeRange {
  double first = 0.0, last = 0.0;
};

struct Scene {
  std::filesystem::path file;
  // SHA-256 of the scene JSON (canonical, as written: with its keyframes, so one hash for every
  // frame) and every asset it references. A frame of an animation is (hash, frame).
  std::string hash;
  std::map<std::string, std::string> assets;  // relative path -> SHA-256 of every asset read
  DVec3 origin{0.0};                          // render space's origin in world space: the camera's position in the file
  ThinLensParams cameraParams;                // in render space: position is the origin
  // A real lens (camera type "real_lens", camera/real_lens_camera.h); cameraParams are then its
  // frame and thin-lens equivalent (focal length and f-number), for the effect analysis.
  std::optional<RealLensParams> realLens;
  std::optional<DiffractionSettings> diffraction;  // camera.diffraction; none: the image as developed
  std::vector<Material> materials;
  // Participating media (docs/media.md): the one the camera and every surface's outside are in
  // (the top-level `medium`, a fog; null: vacuum), and every named medium of `media`, for reports.
  std::shared_ptr<const Medium> medium;
  MediumTable media;
  std::vector<TriangleMesh> meshes;
  // Meshes used many times, in object space, and their uses (MeshInstance above).
  std::vector<TriangleMesh> prototypes;
  std::vector<MeshInstance> instances;
  // Lights that are not emitting triangles, in render space (light/light_source.h): the point,
  // spot and directional entries of `lights` in file order, then the environment if there is one.
  std::vector<std::shared_ptr<const LightSource>> lights;
  RenderSettings render;
  uint64_t skippedDegenerateTriangles = 0;  // zero-area triangles dropped at load
  // What the loader mapped approximately, ignored or chose for the user (a model's camera, a
  // framing camera, glTF features it approximates): printed at the start of a render.
  std::vector<std::string> notes;
  // The aspect ratio (width / height) a model's camera was framed for (glTF's aspectRatio), 0
  // where none was said. Its vertical angle holds at any image size; the sides show more or less.
  double cameraFramedAspect = 0.0;
  // Animation (scene/keyframes.h): the first and last keyframe's frames, none for a still scene;
  // and the frame the scene was loaded at (the one asked for; else the first keyframe's, or 0).
  std::optional<KeyframeRange> keyframeRange;
  double frame = 0.0;
  bool animated() const { return keyframeRange.has_value(); }

  // The camera for the current render settings (resolution may be overridden after loading).
  ThinLensCamera camera() const { return ThinLensCamera(cameraParams, render.width, render.height); }
  // The real-lens camera for the current render settings, if the scene has one.
  std::optional<RealLensCamera> realLensCamera() const {
    if (!realLens) return std::nullopt;
    return RealLensCamera(cameraParams, *realLens, render.width, render.height);
  }
};

// The box of each instance as placed, in Scene::instances' order and render space: its
// prototype's box transformed, which holds the instance's surface.
inline std::vector<std::pair<DVec3, DVec3>> instanceBoxes(const Scene& scene) {
  std::vector<std::pair<Vec3, Vec3>> prototype;
  for (const TriangleMesh& mesh : scene.prototypes) prototype.push_back(boundsOf(mesh.positions));
  std::vector<std::pair<DVec3, DVec3>> out;
  for (const MeshInstance& instance : scene.instances) {
    const auto& [a, b] = prototype[instance.prototype];
    DVec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    for (int c = 0; c < 8 && a.x <= b.x; ++c) {
      const DVec3 p(instance.point(boxCorner(a, b, c)));
      lo = glm::min(lo, p), hi = glm::max(hi, p);
    }
    out.emplace_back(lo, hi);
  }
  return out;
}

const char* integratorName(IntegratorKind kind);
const char* samplerName(SamplerKind kind);
const char* rouletteName(RouletteRule rule);  // "off", "max", "throughput"
// The names above back to kinds; false for an unknown name.
bool parseIntegratorName(const std::string& name, IntegratorKind& kind);
bool parseSamplerName(const std::string& name, SamplerKind& kind);
bool parseRouletteName(const std::string& name, RouletteRule& rule);

}  // namespace lensfarm
