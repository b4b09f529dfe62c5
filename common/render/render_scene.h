#pragma once
// Everything a render needs, built once per scene and shared read-only by all threads:
// the scene, its camera at the render resolution, the effects it calls for (scene/effects.h),
// the Embree scene and the light sampler.
#include <algorithm>
#include <cstdint>
#include <memory>
#include <vector>

#include "common/camera/camera.h"
#include "common/camera/thin_lens_camera.h"
#include "common/film/aov_layout.h"
#include "common/material/principled_model.h"
#include "common/medium/medium.h"
#include "common/render/light_emission.h"
#include "common/render/light_sampler.h"
#include "common/render/path_guiding.h"
#include "common/render/ray_caster.h"
#include "common/scene/effects.h"
#include "common/scene/scene.h"
#include "common/scene/scene_camera.h"

namespace lensfarm {

class RenderScene {
 public:
  // `general`: simulate every effect whatever the scene needs (the reference path the
  // specialised one is checked and benchmarked against).
  explicit RenderScene(const Scene& scene, bool general = false) : RenderScene(scene, general, declaredCamera(scene)) {}

 private:
  RenderScene(const Scene& scene, bool general, std::unique_ptr<const Camera> declared)
      : RenderScene(scene, general, analyzeEffects(scene, *declared), std::move(declared)) {}
  // `analyzed`: the scene's effect analysis, run once; a general render simulates every effect but
  // makes the choices that depend on the analysis as the specialised one does.
  RenderScene(const Scene& scene, bool general, const EffectSet& analyzed, std::unique_ptr<const Camera>&& declared)
      : scene_(scene),
        effects_(general ? EffectSet::all(scene) : analyzed),
        mirrorsReachable_(general ? analyzeEffects(scene, declared->paraxial()).specular : analyzed.specular),
        lightTracing_(analyzed.lightTracing),
        lightTracesTriangles_(analyzed.lightTracingTriangles),
        pathGuiding_(analyzed.pathGuiding),
        equiangular_(analyzed.equiangular),
        camera_(renderCamera(std::move(declared), effects_)),
        caster_(scene),
        lights_(scene, caster_, effects_.lightUseful, scene.render.integrator == IntegratorKind::kNaive,
                analyzed.lightTree, LightSampler::solidAngleReachFor(scene.render.triangleLightSampling)),
        hasEscapeLights_(!lights_.escapeLights().empty()),
        aovLayout_(scene.render.aovs) {
    // Materials with textures, and those of meshes with vertex normals, are shaded per point
    // (render/shading_point.h), by the one-path vertex code.
    shaded_.assign(scene.materials.size(), 0);
    for (size_t m = 0; m < scene.materials.size(); ++m) shaded_[m] = scene.materials[m].varies() ? 1 : 0;
    for (const auto* meshes : {&scene.meshes, &scene.prototypes})
      for (const TriangleMesh& mesh : *meshes)
        if (!mesh.normals.empty())
          for (uint32_t id : mesh.materialIds) shaded_[id] = 1;
    laneModels_.resize(scene.materials.size());
    for (size_t k = 0; k < scene.materials.size(); ++k) {
      const Material& m = scene.materials[k];
      const bool glossy = !m.varies() && m.laneModel(laneModels_[k]);
      materialRecords_.push_back({m.albedo(), m.isEmissive() ? ~0u : 0u, m.reflects() ? ~0u : 0u,
                                  (m.reflects() && !m.isLambertian()) || shaded_[k] ? ~0u : 0u, glossy ? ~0u : 0u,
                                  shaded_[k] ? ~0u : 0u, guided(m) && !shaded_[k] ? ~0u : 0u});
    }
    // The materials whose scattering the light tracer handles (render/light_tracer.h); a path
    // through any other belongs to the path tracer alone.
    if (lightTracing_) {
      std::vector<uint8_t> deltaTraced;
      for (size_t m = 0; m < scene.materials.size(); ++m) {
        lightTraced_.push_back(lightTraceable(scene.materials[m]) && !shaded_[m] ? 1 : 0);
        deltaTraced.push_back(lightTraced_[m] && scene.materials[m].isSpecular() ? 1 : 0);
      }
      particleTarget_ = targetSphere(scene, caster_, deltaTraced);
    }
    const ThinLensParams& lens = camera_->paraxial().params();
    pixelAngle_ = float(lens.sensorWidth / (double(scene.render.width) * lens.focalLength));
    // The media a shadow ray can leave (render/volume_integrator.cpp): the scene's own, and those
    // inside a material that lets rays through (an interface).
    if (scene.medium) mediaShadowRaysLeave_.push_back(scene.medium.get());
    for (const Material& m : scene.materials) {
      if (m.interior && m.passesThrough()) mediaShadowRaysLeave_.push_back(m.interior.get());
      if (m.exterior) mediaShadowRaysLeave_.push_back(m.exterior.get());  // (an outside is open)
    }
    if (equiangular_)
      for (const Medium* m : mediaShadowRaysLeave_)
        if (m->homogeneous() && m->scatters()) mediaEquiangular_.push_back(m->asHomogeneous());
    // Last: the training passes trace this scene's paths.
    if (pathGuiding_) guide_ = trainGuidingField(*this);
  }

 public:
  const Scene& scene() const { return scene_; }
  const RenderSettings& settings() const { return scene_.render; }
  // The camera traced (scene/scene_camera.h, renderCamera): the declared one, or a pinhole where
  // the declared thin lens's blur is invisible.
  const Camera& camera() const { return *camera_; }
  const EffectSet& effects() const { return effects_; }
  // Whether a camera path can meet a mirror (the analysis's answer even for a general scene, so
  // both paths make the same choices that depend on it; render/integrator.cpp).
  bool mirrorsReachable() const { return mirrorsReachable_; }
  // Whether light paths are traced beside the camera paths (render/light_tracer.h; the analysis's
  // answer even for a general scene, like mirrorsReachable), and whether the light tracer handles
  // scattering by material `id`.
  bool lightTracing() const { return lightTracing_; }
  bool lightTraced(uint32_t id) const { return lightTraced_[id] != 0; }
  // Whether emitting triangles emit light paths (EffectSet::lightTracingTriangles; the other lights
  // do whenever light paths are traced), and the sphere their particles are aimed at: every delta
  // surface the light tracer handles (render/light_emission.h).
  bool lightTracesTriangles() const { return lightTracesTriangles_; }
  const SceneSphere& particleTarget() const { return particleTarget_; }
  const RayCaster& caster() const { return caster_; }
  const LightSampler& lights() const { return lights_; }
  // Whether rays that leave the scene can reach a light (the environment, a sun with an angular
  // diameter): only then does a miss cost more than ending the path (render/integrator.cpp).
  bool hasEscapeLights() const { return hasEscapeLights_; }
  const Material& material(uint32_t id) const { return scene_.materials[id]; }
  // Whether hits on material `id` are shaded per point (render/shading_point.h): it has textures,
  // or a mesh with vertex normals uses it.
  bool shaded(uint32_t id) const { return shaded_[id] != 0; }
  // The angle one pixel subtends at the lens (for texture footprints, render/shading_point.h).
  float pixelAngle() const { return pixelAngle_; }
  // Where the AOVs the scene asks for sit in a sensor cell (film/aov_layout.h).
  const AovLayout& aovLayout() const { return aovLayout_; }
  // Whether a shadow ray from inside `medium` can get out of it: false where every surface that
  // bounds it scatters (a subsurface or glass mesh), so only a light inside could be reached.
  bool shadowRaysLeave(const Medium* medium) const {
    return std::find(mediaShadowRaysLeave_.begin(), mediaShadowRaysLeave_.end(), medium) != mediaShadowRaysLeave_.end();
  }
  // The medium's coefficients where equiangular sampling serves it (EffectSet::equiangular: a
  // homogeneous scattering medium shadow rays can leave, the effect on); else null.
  const HomogeneousMedium* equiangularIn(const Medium* medium) const {
    if (!medium || mediaEquiangular_.empty()) return nullptr;
    const HomogeneousMedium* h = medium->asHomogeneous();
    return std::find(mediaEquiangular_.begin(), mediaEquiangular_.end(), h) != mediaEquiangular_.end() ? h : nullptr;
  }
  // What the packet tracer's lane loops read of each material (render/integrator.cpp): its
  // Lambertian albedo and Material's predicates as masks (~0u where true, 0 where false);
  // `general`: a model beyond Lambertian, which the one-path vertex code shades unless `glossy`:
  // the lane loops shade it with its laneModels() record (Material::laneModel; not where it has
  // textures); `shaded`: hits on it are shaded per point (shaded()); `guided`: a Lambertian one whose
  // vertices path guiding guides (guided()).
  struct MaterialRecord {
    Spectrum albedo;
    uint32_t emissive, reflects, general, glossy, shaded, guided;
  };
  const std::vector<MaterialRecord>& materialRecords() const { return materialRecords_; }
  const std::vector<PrincipledModel>& laneModels() const { return laneModels_; }  // per material
  // The field that guides the camera paths' diffuse vertices (render/path_guiding.h), or null
  // where the analysis left path guiding off.
  const GuidingField* guide() const { return guide_.get(); }
  // Whether the paths' vertices on `m` are guided (render/path_guiding.h): its Lambertian lobe,
  // without textures, in a scene whose analysis turned guiding on (the analysis's answer even for a
  // general scene, like lightTracing).
  bool guided(const Material& m) const { return pathGuiding_ && m.isLambertian() && !m.varies(); }

 private:
  const Scene& scene_;
  EffectSet effects_;
  bool mirrorsReachable_;
  bool lightTracing_;
  bool lightTracesTriangles_;
  bool pathGuiding_;
  bool equiangular_;
  std::unique_ptr<const Camera> camera_;
  std::vector<uint8_t> lightTraced_;  // per material; empty without light tracing
  SceneSphere particleTarget_;
  RayCaster caster_;
  LightSampler lights_;
  bool hasEscapeLights_;
  AovLayout aovLayout_;
  std::vector<MaterialRecord> materialRecords_;
  std::vector<PrincipledModel> laneModels_;
  std::vector<uint8_t> shaded_;
  std::vector<const Medium*> mediaShadowRaysLeave_;
  std::vector<const HomogeneousMedium*> mediaEquiangular_;
  float pixelAngle_ = 0.0f;
  std::unique_ptr<const GuidingField> guide_;
};

}  // namespace lensfarm
