#pragma once
// Helpers of the light tests (point, spot, directional, environment): a white plane under a
// pinhole camera, one path traced through the centre of a sensor cell with the tracer the unit
// renderer would pick, and a whole render's mean per sensor cell.
#include <nlohmann/json.hpp>
#include <vector>

#include "common/render/integrator.h"
#include "common/render/render_scene.h"
#include "common/render/unit_renderer.h"

namespace lensfarm::test {

// A white (albedo 1) Lambertian plane y = 0, 200 units across, facing +y, seen from (0, 3, -4)
// by a 60-degree pinhole looking at the origin; `lights` as given; B = 1 unless changed.
inline nlohmann::json planeSceneJson(const nlohmann::json& lights, const char* integrator = "nee_mis") {
  nlohmann::json scene = nlohmann::json::parse(R"({
    "format": "lensfarm-scene/1",
    "camera": { "type": "pinhole", "position": [0, 3, -4], "look_at": [0, 0, 0], "angle_of_view": 60 },
    "materials": { "white": { "type": "lambertian", "albedo": 1 } },
    "shapes": [ { "type": "quad", "name": "plane", "corner": [-100, 0, -100], "edge1": [0, 0, 200],
                  "edge2": [200, 0, 0], "material": "white" } ],
    "render": { "resolution": [24, 24], "samples_per_pixel": 16, "max_bounces": 1, "seed": 5 }
  })");
  scene["lights"] = lights;
  scene["render"]["integrator"] = integrator;
  return scene;
}

// The path through the centre of sensor cell (i, j) for sample `sample`, traced one ray at a time
// with the specialisation renderUnit picks (render/unit_renderer.cpp).
inline Spectrum traceCellCentre(const RenderScene& rs, int i, int j, uint64_t sample, CameraRay* rayOut = nullptr) {
  const RenderSettings& s = rs.settings();
  const SamplerSetup setup{s.sampler, s.seed, s.samplesPerPixel, unitSize(s)};
  const CameraRay ray = rs.camera().paraxial().generateRay(i, j, Vec2(0.5f), Vec2(0.5f));
  if (rayOut) *rayOut = ray;
  const SampleStream rng(setup, uint64_t(j) * uint64_t(rs.camera().width()) + uint64_t(i), sample);
  const bool nee = rs.effects().lightSampling && !rs.lights().empty(), general = rs.effects().generalMaterials;
  PathStats stats;
  if (nee) return general ? tracePath<true, true>(rs, ray, rng, stats) : tracePath<true, false>(rs, ray, rng, stats);
  return general ? tracePath<false, true>(rs, ray, rng, stats) : tracePath<false, false>(rs, ray, rng, stats);
}

// Where a camera ray (in render space, scene/scene.h) meets the plane y = 0 of the world, in
// world coordinates (in double).
inline DVec3 onPlaneY0(const RenderScene& rs, const CameraRay& ray) {
  const DVec3 o = DVec3(ray.origin) + rs.scene().origin, d(ray.direction);
  return o - d * (o.y / d.y);
}

// Every sample of the scene in one unit, traced in packets; each sensor cell's mean.
inline std::vector<DVec3> cellMeans(const RenderScene& rs) {
  SensorBuffer buffer;
  PathStats stats;
  const uint64_t spp = rs.settings().samplesPerPixel;
  renderUnit(rs, WorkUnit{0, 0, uint32_t(spp)}, buffer, stats);
  std::vector<DVec3> means(buffer.cells());
  for (size_t k = 0; k < means.size(); ++k)
    means[k] = DVec3(buffer.sums[3 * k], buffer.sums[3 * k + 1], buffer.sums[3 * k + 2]) / double(buffer.samples[k]);
  return means;
}

}  // namespace lensfarm::test
