#pragma once
// What a scene calls for, decided once when it is loaded, so that the renderer simulates only
// those effects (the user's third promise). Each decision carries its reason, for the summary
// of `lensfarm render`, `lensfarm status` and the EXR header.
//
//  - depth of field: off when the aperture is closed, or when its blur over the whole scene's
//    depth range stays below half a sensor cell (the lens is then sampled as a pinhole). The
//    second changes what the scene asks for (at a preview resolution, typically): its decision
//    is marked changesScene, says from which resolution on the lens is simulated, and is one of
//    warnings();
//  - specular materials: off when no delta material (mirror, rippled mirror, smooth glass or
//    metal) can be met; materials beyond Lambertian (the general vertex code): off when none can;
//  - participating media: on when the scene has a `medium` or a used material has one inside
//    (docs/media.md); off, the surface tracers run, with no medium code in them;
//  - thin walls: on when a used material lets light straight through with a tint (a pane, glTF
//    transmission without a volume): then, too, the volume path tracer runs, and shadow rays
//    cross those walls attenuated by them instead of stopping;
//  - next-event estimation: off with the naive estimator, or when no light can light anything;
//  - lights that face away from every surface and from the camera (or only into the inside of
//    the closed mesh they lie on, with nothing there) are dropped from sampling and reported as
//    warnings: they emit nothing into the scene;
//  - light tree: on past kLightTreeAutoLights lights in the scene (emitting triangles, points and
//    spots), or as render.light_tree forces; listed where it is on, forced, or there are more than 8;
//  - the lights that are not triangles (point, spot, directional, the environment) are listed,
//    e.g. "environment: on (sky.exr 2048x1024)"; with the naive estimator, light samples are
//    taken of the delta lights alone (render/integrator.h).
#include <string>
#include <vector>

#include "common/camera/camera.h"
#include "common/camera/thin_lens_camera.h"
#include "common/scene/scene.h"

namespace lensfarm {

struct EffectDecision {
  std::string effect;
  bool simulated;
  std::string reason;
  // The scene asks for this effect and the picture differs without it, but it is not simulated
  // (depth of field whose blur is below half a cell at this resolution): a change of what the
  // user asked for, printed as a warning at the start of a render (EffectSet::warnings).
  bool changesScene = false;
};

// Path guiding's training budget (render/path_guiding.h): kGuidingTrainingPasses passes of 1, 2, 4
// ... samples per pixel over an even grid of at most kGuidingTrainingPixels of the frame's pixels,
// every guidingTrainingStride-th pixel in each direction.
inline constexpr int kGuidingTrainingPasses = 4;
inline constexpr uint64_t kGuidingTrainingPixels = uint64_t(1) << 15;
int guidingTrainingStride(int width, int height);
uint64_t guidingTrainingPaths(int width, int height);  // over all the passes

// The number of lights in the scene above which `render.light_tree: "auto"` turns the light tree
// on (docs/performance.md, "Many lights").
inline constexpr uint64_t kLightTreeAutoLights = 64;

struct EffectSet {
  bool depthOfField = true;
  bool specular = true;          // a delta material (mirror, smooth glass or metal) can be met
  bool generalMaterials = true;  // a material beyond Lambertian can be met (render/integrator.h)
  bool lightSampling = true;
  // A path can be inside a participating medium (a fog, a medium inside a mesh, subsurface
  // scattering): camera paths are traced by the volume path tracer (render/volume_integrator.h).
  bool media = false;
  // Equiangular sampling (render/volume_integrator.cpp): on where a path can be in a homogeneous
  // scattering medium that shadow rays can leave, lit by a light at points (an emitting
  // triangle, a point or spot light), with light sampling and render.medium_light_sampling "auto".
  bool equiangular = false;
  // A used material is a thin wall that lets light straight through with a tint (BsdfTraits::
  // thinWall: a window pane, glTF glass without a volume): camera paths are traced by the volume
  // path tracer, whose shadow rays cross such walls attenuated and whose paths cross them as null
  // events; light tracing is off (its connections could not cross them).
  bool thinWalls = false;
  // Light tracing beside the path tracer (render/light_tracer.h), where it can run (a thin-lens
  // camera, an NEE estimator, whole-frame units, no media or thin walls). `auto` turns it on where
  // a diffuse surface sees a light other than an emitting surface (a point, spot, sun or the
  // environment) through a mirror or smooth glass: a delta light's caustics no camera path reaches,
  // an infinite light's it reaches only by chance. Emitting triangles emit particles only with
  // "on" (lightTracingTriangles): where the scene has mirrorCaustics (a diffuse surface can see an
  // emitting triangle through a mirror, a caustic next-event estimation cannot sample) the
  // binary-weighted light tracer was measured not to pay at equal time (docs/performance.md).
  bool lightTracing = false;
  bool lightTracingTriangles = false;
  // Next-event estimation chooses the lights in the scene with a light tree (render/light_tree.h):
  // `auto` where there are more than kLightTreeAutoLights of them (emitting triangles, point and
  // spot lights), where choosing by power alone spends most samples on lights that cannot matter.
  bool lightTree = false;
  // Path guiding (render/path_guiding.h): camera paths learn, in training passes before the image,
  // where the light arriving at the diffuse surfaces comes from, and draw half of their directions
  // there. It serves where a diffuse surface sees a light through a mirror or smooth glass (the
  // caustic paths next-event estimation cannot sample) and the surface path tracer runs; `auto`
  // lists it there, off: on cornell-seed it reaches an equal relMSE sooner but an equal relative
  // RMSE (what target-error jobs stop on) later, and through glass it does not pay at all
  // (docs/performance.md, "Path guiding"). "on" forces it.
  bool pathGuiding = false;
  bool mirrorCaustics = false;
  std::vector<bool> lightUseful;  // per material index: false for emitters that light nothing
  std::vector<EffectDecision> decisions;
  // Problems of the scene itself that the render cannot mend, e.g. `light "lamp" faces away from
  // every surface and the camera: it emits nothing into the scene (flip its winding or set
  // two_sided)`: part of warnings().
  std::vector<std::string> sceneWarnings;

  // "depth of field: on (blur up to 3.2 px); specular: off (no mirror) ..." for logs and headers.
  std::string summary() const;
  // sceneWarnings, then one line per decision that changes what the scene asks for, e.g. "depth of field is not
  // simulated: the scene's f/16 lens is traced as a pinhole at 400x400 px: ...; from 466x466 px
  // on it is simulated". Empty when the render simulates everything the scene calls for.
  std::vector<std::string> warnings() const;
  // Everything on: what the general path simulates.
  static EffectSet all(const Scene& scene);
};

// `camera`: the scene's declared camera (scene/scene_camera.h, declaredCamera), or its paraxial
// thin lens (Scene::camera()) where the lens's own figures are not wanted: with a real lens, the
// reason then says what share of camera rays the lens lets through (a 16 x 16 x 4 x 4 grid: 4096 rays).
EffectSet analyzeEffects(const Scene& scene, const Camera& camera);

// Whether the light tracer handles scattering by `m` (render/light_tracer.h): a Lambertian
// material without textures, a mirror or a rippled mirror (their adjoints are known there).
bool lightTraceable(const Material& m);

// Largest blur-circle diameter on the sensor, in sensor cells, of any point of the scene's
// bounding box in front of the lens (0 for a pinhole).
double maxBlurInCells(const Scene& scene, const ThinLensCamera& camera);

}  // namespace lensfarm
