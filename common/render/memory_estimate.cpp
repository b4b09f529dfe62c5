#include "render/memory_estimate.h"

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

#include "light/environment_light.h"
#include "medium/medium.h"
#include "render/unit_renderer.h"
#include "util/error.h"

namespace lensfarm {

namespace {
// The AOVs' share (film/aov_layout.h): their sums beside the beauty's in the film (`cells`) and in
// `held` unit buffers, their layers in the developed images and a download's EXR, and in a
// checkpoint; a worker's unit buffer alone when `workerCells` is given. Nothing without AOVs.
void addAovItems(MemoryEstimate& e, const RenderSettings& s, uint64_t cells, uint64_t held, bool stateDir,
                 uint64_t workerCells = 0) {
  const AovLayout layout(s.aovs);
  if (!layout.any()) return;
  const uint64_t sums = uint64_t(layout.channels - 3), floats = uint64_t(layout.layerChannels());
  if (workerCells > 0) {
    e.items.push_back({"AOV sums in the unit buffer", workerCells * sums * sizeof(double)});
    return;
  }
  e.items.push_back({"AOVs (" + aovListText(layout.set) + ")",
                     cells * (sums * (sizeof(CompensatedSum) + held * sizeof(double) +
                                      (stateDir ? 2 * sizeof(double) : 0)) +
                              floats * (kImageBytesPerCell + 2 * kExrBytesPerCell) / 3)});
}
}  // namespace

static_assert(sizeof(CompensatedSum) == 2 * sizeof(double), "a compensated sum is a sum and its compensation");

namespace {

uint64_t cellsOf(const RenderSettings& s) { return uint64_t(std::max(0, s.width)) * uint64_t(std::max(0, s.height)); }

uint64_t unitsOf(const RenderSettings& s) { return unitCount(std::max<uint64_t>(1, s.samplesPerPixel), unitSize(s)); }

// The number in a file such as memory.max ("max" or garbage: none).
uint64_t readLimit(const std::string& path) {
  std::ifstream in(path);
  std::string text;
  if (!(in >> text) || text.empty() || !std::isdigit(static_cast<unsigned char>(text[0]))) return 0;
  errno = 0;
  const unsigned long long v = std::strtoull(text.c_str(), nullptr, 10);
  return errno ? 0 : uint64_t(v);
}

// The cgroup's memory limit (0: none), v2 then v1, for this process's own cgroup and the root
// the container sees.
uint64_t cgroupLimit() {
  std::vector<std::string> candidates;
  std::ifstream self("/proc/self/cgroup");
  for (std::string line; std::getline(self, line);) {
    if (line.rfind("0::", 0) == 0) candidates.push_back("/sys/fs/cgroup" + line.substr(3) + "/memory.max");
    const size_t a = line.find(":memory:");
    if (a != std::string::npos)
      candidates.push_back("/sys/fs/cgroup/memory" + line.substr(a + 8) + "/memory.limit_in_bytes");
  }
  candidates.push_back("/sys/fs/cgroup/memory.max");
  candidates.push_back("/sys/fs/cgroup/memory/memory.limit_in_bytes");
  uint64_t limit = 0;
  for (const auto& c : candidates)
    if (const uint64_t v = readLimit(c); v > 0 && (limit == 0 || v < limit)) limit = v;
  return limit;
}

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

MemoryEstimate coordinatorJobMemory(const RenderSettings& s, uint64_t maxBytesAhead, bool stateDir,
                                    uint64_t auditCopies) {
  const uint64_t cells = cellsOf(s);
  MemoryEstimate e;
  if (s.tileSize > 0) {
    // Tiled (farm/job_layout.h): the frame's float image, tiles written as they arrive (no sums,
    // no tracker, no results waiting); an animation may hold a second frame while one completes;
    // audited tiles' sums are a tile each.
    e.items.push_back({"the frame's image (tiled: no sensor)", cells * kImageBytesPerCell});
    e.items.push_back({"a download", cells * (kImageBytesPerCell + 2 * kExrBytesPerCell)});
    addAovItems(e, s, cells, 0, false);
    return e;
  }
  const uint64_t held = std::min(unitsOf(s), unitsAheadWindow(s.width, s.height, maxBytesAhead));
  e.items.push_back({"sensor", cells * kSensorBytesPerCell});
  e.items.push_back({"error-estimate half-image", cells * kTrackerBytesPerCell});
  e.items.push_back({std::to_string(held) + (held == 1 ? " unit buffer" : " unit buffers in flight"),
                     held * cells * kUnitBufferBytesPerCell});
  e.items.push_back({"a download", cells * (kImageBytesPerCell + 2 * kExrBytesPerCell)});
  if (stateDir) e.items.push_back({"a checkpoint", cells * kCheckpointBytesPerCell});
  addAdaptiveItems(e, s, cells, auditCopies);
  addAovItems(e, s, cells, held, stateDir);
  if (auditCopies > 0)
    e.items.push_back({std::to_string(auditCopies) + " film copies and an audited unit (the audit)",
                       cells * (auditCopies * (kSensorBytesPerCell + kTrackerBytesPerCell) + kUnitBufferBytesPerCell)});
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
    if (const auto* environment = dynamic_cast<const EnvironmentLight*>(light.get())) bytes += environment->map().bytes();
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
  addAovItems(e, s, cells, 1, false);
  addAdaptiveItems(e, s, cells, 0);
  e.items.push_back({"scene", triangles * kSceneBytesPerTriangle});
  if (sceneData > 0) e.items.push_back({"textures, vertex attributes and instances", sceneData});
  return e;
}

std::string overBudgetMessage(const RenderSettings& s, const MemoryEstimate& estimate, const std::string& whose,
                              uint64_t budget, const std::string& budgetSource) {
  return "a " + std::to_string(s.width) + "x" + std::to_string(s.height) + " render needs an estimated " +
         formatBytes(estimate.total()) + " of " + (whose.empty() ? "" : whose + " ") + "memory (" +
         estimate.describe() + "), more than the " +
         formatBytes(budget) + " allowed per job (" + budgetSource + ")";
}

void refuseLocalRenderOverBudget(const RenderSettings& settings, uint64_t triangles, const std::string& where,
                                 uint64_t sceneData) {
  const MemoryEstimate estimate = localRenderMemory(settings, triangles, sceneData);
  const uint64_t budget = defaultJobMemoryBudget();
  if (estimate.total() > budget)
    throw InputError(where, overBudgetMessage(settings, estimate, "", budget, defaultJobMemoryBudgetSource()) +
                                "; lower the resolution, or set LENSFARM_MAX_JOB_MEMORY if this machine can hold it");
}

uint64_t machineMemoryBytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), pageSize = ::sysconf(_SC_PAGESIZE);
  uint64_t bytes = pages > 0 && pageSize > 0 ? uint64_t(pages) * uint64_t(pageSize) : 0;
  if (const uint64_t limit = cgroupLimit(); limit > 0 && (bytes == 0 || limit < bytes)) bytes = limit;
  return bytes > 0 ? bytes : std::numeric_limits<uint64_t>::max();
}

uint64_t defaultJobMemoryBudget() {
  if (const char* env = std::getenv("LENSFARM_MAX_JOB_MEMORY"); env && *env) {
    const uint64_t bytes = parseByteSize(env);
    if (bytes == 0)
      throw InputError("LENSFARM_MAX_JOB_MEMORY",
                       "expected a size such as 16G, 512MiB or 2000000000 (bytes), got \"" + std::string(env) + "\"");
    return bytes;
  }
  const uint64_t machine = machineMemoryBytes();
  return machine == std::numeric_limits<uint64_t>::max() ? machine : machine / 4 * 3;
}

std::string defaultJobMemoryBudgetSource() {
  if (const char* env = std::getenv("LENSFARM_MAX_JOB_MEMORY"); env && *env) return "LENSFARM_MAX_JOB_MEMORY";
  return "3/4 of this machine's " + formatBytes(machineMemoryBytes()) + " of memory";
}

uint64_t parseByteSize(const std::string& text) {
  size_t end = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &end);
  } catch (const std::exception&) {
    return 0;
  }
  if (!(value > 0.0) || !std::isfinite(value) || !std::isdigit(static_cast<unsigned char>(text[0]))) return 0;
  std::string unit;
  for (char c : text.substr(end))
    if (!std::isspace(static_cast<unsigned char>(c))) unit += char(std::toupper(static_cast<unsigned char>(c)));
  static const char* kPrefixes = "KMGT";
  double scale = 1.0;
  if (!unit.empty() && unit != "B") {
    const char* p = std::strchr(kPrefixes, unit[0]);
    if (!p || !*p) return 0;
    const std::string rest = unit.substr(1);
    const int power = int(p - kPrefixes) + 1;
    if (rest.empty() || rest == "IB")
      scale = std::pow(1024.0, power);
    else if (rest == "B")
      scale = std::pow(1000.0, power);
    else
      return 0;
  }
  const double bytes = value * scale;
  if (bytes < 1.0 || bytes >= 1.8e19) return 0;
  return uint64_t(bytes);
}

std::string formatBytes(uint64_t bytes) {
  static const char* kUnits[] = {"bytes", "kB", "MB", "GB", "TB", "PB", "EB"};
  double v = double(bytes);
  int u = 0;
  while (v >= 1000.0 && u < 6) v /= 1000.0, ++u;
  char buf[32];
  if (u == 0)
    std::snprintf(buf, sizeof buf, "%llu bytes", (unsigned long long)bytes);
  else
    std::snprintf(buf, sizeof buf, v < 10.0 ? "%.2f %s" : v < 100.0 ? "%.1f %s" : "%.0f %s", v, kUnits[u]);
  return buf;
}

}  // namespace lensfarm
