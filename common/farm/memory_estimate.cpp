#include "common/farm/memory_estimate.h"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <set>

#include "common/film/work_unit.h"
#include "common/light/environment_light.h"
#include "common/medium/medium.h"
#include "common/util/error.h"

namespace lensfarm {

namespace {
// The AOVs' share (film/aov_layout.h): their sums beside the beauty's in the film (`cells`) and in
// `held` unit buffers and in a checkpoint, and with `layers` their layers in the developed image
// (a coordinator's are in imageMemory); a worker's unit buffer alone when `workerCells` is given.
// Nothing without AOVs.
void addAovItems(MemoryEstimate& e, const RenderSettings& s, uint64_t cells, uint64_t held, bool stateDir,
                 uint64_t workerCells = 0, bool layers = false) {
  const AovLayout layout(s.aovs);
  if (!layout.any()) return;
  const uint64_t sums = uint64_t(layout.channels - 3), floats = uint64_t(layout.layerChannels());
  if (workerCells > 0) {
    e.items.push_back({"AOV sums in the unit buffer", workerCells * sums * sizeof(double)});
    return;
  }
  e.items.push_back(
      {"AOVs (" + aovListText(layout.set) + ")",
       cells * (sums * (sizeof(CompensatedSum) + held * sizeof(double) + (stateDir ? 2 * sizeof(double) : 0)) +
                (layers ? floats * sizeof(float) : 0))});
}
}  // namespace

static_assert(sizeof(CompensatedSum) == 2 * sizeof(double), "a compensated sum is a sum and its compensation");

namespace {

uint64_t cellsOf(const RenderSettings& s) { return uint64_t(std::max(0, s.width)) * uint64_t(std::max(0, s.height)); }

uint64_t unitsOf(const RenderSettings& s) { return unitCount(std::max<uint64_t>(1, s.samplesPerPixel), unitSize(s)); }

}  // namespace

uint64_t MemoryEstimate::total() const {
  uint64_t t = 0;
  for (const auto& i : items) t += i.bytes;
  return t;
}

std::string MemoryEstimate::describe() const {
  std::string out;
  for (const auto& i : items)
    if (i.bytes > 0) out += (out.empty() ? "" : " + ") + i.what + " " + formatBytes(i.bytes);
  return out;
}

uint64_t unitsAheadWindow(int width, int height, uint64_t maxBytesAhead) {
  const uint64_t unitBytes = uint64_t(std::max(0, width)) * uint64_t(std::max(0, height)) * 3 * sizeof(double);
  return std::max<uint64_t>(8, maxBytesAhead / std::max<uint64_t>(1, unitBytes));
}

namespace {
// Adaptive sampling gives cells their own counts: the sensor's and the tracker's even half's
// (8 bytes a cell each, film/sensor.h, film/convergence.h), in every film copy an audit keeps.
void addAdaptiveItems(MemoryEstimate& e, const RenderSettings& s, uint64_t cells, uint64_t auditCopies) {
  if (s.adaptive.enabled) e.items.push_back({"per-cell sample counts (adaptive)", cells * 16 * (1 + auditCopies)});
}
}  // namespace

uint64_t imageMemory(const RenderSettings& s) {
  const uint64_t cells = cellsOf(s);
  const AovLayout layout(s.aovs);
  const uint64_t layerFloats = layout.any() ? uint64_t(layout.layerChannels()) : 0;
  return cells * (kImageBytesPerCell + kPngBytesPerCell + layerFloats * sizeof(float));
}

MemoryEstimate coordinatorJobMemory(const RenderSettings& s, uint64_t maxBytesAhead, bool stateDir,
                                    uint64_t auditCopies) {
  const uint64_t cells = cellsOf(s);
  MemoryEstimate e;
  if (s.tileSize > 0) {
    // Tiled (farm/job_layout.h): the frame's float image, tiles written as they arrive (no sums,
    // no tracker, no results waiting); an animation may hold a second frame while one completes;
    // audited tiles' sums are a tile each.
    e.items.push_back({"the frame's image (tiled: no sensor)", cells * kImageBytesPerCell});
    addAovItems(e, s, cells, 0, false);
    e.items.push_back({"a download", imageMemory(s)});
    return e;
  }
  const uint64_t held = std::min(unitsOf(s), unitsAheadWindow(s.width, s.height, maxBytesAhead));
  e.items.push_back({"sensor", cells * kSensorBytesPerCell});
  e.items.push_back({"error-estimate half-image", cells * kTrackerBytesPerCell});
  e.items.push_back({std::to_string(held) + (held == 1 ? " unit buffer" : " unit buffers in flight"),
                     held * cells * kUnitBufferBytesPerCell});
  if (stateDir) e.items.push_back({"a checkpoint", cells * kCheckpointBytesPerCell});
  addAdaptiveItems(e, s, cells, auditCopies);
  addAovItems(e, s, cells, held, stateDir);
  if (auditCopies > 0)
    e.items.push_back({std::to_string(auditCopies) + " film copies and an audited unit (the audit)",
                       cells * (auditCopies * (kSensorBytesPerCell + kTrackerBytesPerCell) + kUnitBufferBytesPerCell)});
  e.items.push_back({"a download", imageMemory(s)});
  return e;
}

uint64_t sceneDataBytes(const Scene& scene) {
  uint64_t bytes = 0;
  std::set<const Texture*> seen;
  for (const Material& m : scene.materials) {
    const MaterialTextures* t = m.textures();
    if (!t) continue;
    for (const TextureRef* ref : {&t->baseColor, &t->metallicRoughness, &t->normal, &t->emissive})
      if (ref->texture && seen.insert(ref->texture.get()).second) bytes += ref->texture->bytes();
  }
  for (const auto* meshes : {&scene.meshes, &scene.prototypes})
    for (const TriangleMesh& mesh : *meshes)
      bytes += mesh.normals.size() * sizeof(Vec3) + (mesh.uv[0].size() + mesh.uv[1].size()) * sizeof(Vec2) +
               mesh.tangents.size() * sizeof(glm::vec4);
  for (const auto& light : scene.lights)
    if (const auto* environment = dynamic_cast<const EnvironmentLight*>(light.get()))
      bytes += environment->map().bytes();
  // Density grids (medium/grid_medium.h): their voxels and majorant cells, each grid once.
  for (const auto& [name, medium] : scene.media)
    if (const GridMedium* g = medium->asGrid()) {
      const glm::ivec3 m = g->majorantResolution();
      bytes += (g->densities().size() + size_t(m.x) * size_t(m.y) * size_t(m.z)) * sizeof(float);
    }
  return bytes + scene.instances.size() * kSceneBytesPerInstance;
}

uint64_t storedTriangles(const Scene& scene) {
  uint64_t n = 0;
  for (const auto* meshes : {&scene.meshes, &scene.prototypes})
    for (const TriangleMesh& mesh : *meshes) n += mesh.triangleCount();
  return n;
}

MemoryEstimate workerJobMemory(const RenderSettings& s, uint64_t triangles, uint64_t sceneData) {
  MemoryEstimate e;
  e.items.push_back({"unit buffer", cellsOf(s) * kUnitBufferBytesPerCell});
  addAovItems(e, s, 0, 0, false, cellsOf(s));
  e.items.push_back({"scene", triangles * kSceneBytesPerTriangle});
  if (sceneData > 0) e.items.push_back({"textures, vertex attributes and instances", sceneData});
  return e;
}

MemoryEstimate localRenderMemory(const RenderSettings& s, uint64_t triangles, uint64_t sceneData) {
  const uint64_t cells = cellsOf(s);
  MemoryEstimate e;
  e.items.push_back({"sensor", cells * kSensorBytesPerCell});
  e.items.push_back({"error-estimate half-image", cells * kTrackerBytesPerCell});
  e.items.push_back({"unit buffer", cells * kUnitBufferBytesPerCell});
  e.items.push_back({"output image", cells * (kImageBytesPerCell + kPngBytesPerCell)});
  addAovItems(e, s, cells, 1, false, 0, /*layers=*/true);
  addAdaptiveItems(e, s, cells, 0);
  e.items.push_back({"scene", triangles * kSceneBytesPerTriangle});
  if (sceneData > 0) e.items.push_back({"textures, vertex attributes and instances", sceneData});
  return e;
}

std::string overBudgetMessage(const RenderSettings& s, const MemoryEstimate& estimate, const std::string& whose,
                              uint64_t budget, const std::string& budgetSource) {
  return "a " + std::to_string(s.width) + "x" + std::to_string(s.height) + " render needs an estimated " +
         formatBytes(estimate.total()) + " of " + (whose.empty() ? "" : whose + " ") + "memory (" +
         estimate.describe() + "), more than the " + formatBytes(budget) + " allowed per job (" + budgetSource + ")";
}

void refuseLocalRenderOverBudget(const RenderSettings& settings, uint64_t triangles, const std::string& where,
                                 uint64_t sceneData) {
  const MemoryEstimate estimate = localRenderMemory(settings, triangles, sceneData);
  const uint64_t budget = defaultJobMemoryBudget();
  if (estimate.total() > budget)
    throw InputError(where, overBudgetMessage(settings, estimate, "", budget, defaultJobMemoryBudgetSource()) +
                                "; lower the resolution, or set LENSFARM_MAX_JOB_MEMORY if this machine can hold it");
}

}  // namespace lensfarm
