#pragma once
// How much memory a job needs, estimated from its settings before anything frame-sized is
// allocated, and how much this machine allows (docs/farm.md, "Memory"). One place, used by the
// coordinator (Coordinator::submit refuses a job over --max-job-memory), by `lensfarm render`
// (refuses before tracing) and by the worker (refuses a lease it cannot hold).
//
// Every frame-sized buffer, in bytes per cell (a cell is a pixel; cells = width x height):
//
//   buffer                                   bytes/cell  held by, and for how long
//   Sensor sums (film/sensor.h)                  48       coordinator, per job, for its whole life:
//                                                         3 CompensatedSum = sum + compensation,
//                                                         2 doubles each. Sample counts are one
//                                                         number per sensor (units cover the frame).
//   ConvergenceTracker (film/convergence.h)      24       coordinator, per job, for its whole life:
//                                                         the even units' sums (the half-image of
//                                                         the error estimate), 3 doubles.
//   unit buffer (SensorBuffer)                   28       worker: the unit it traces (3 double sums
//                                                         + a uint32 count); coordinator: each upload
//                                                         being received and each unit waiting for
//                                                         an earlier one, at most unitsAheadWindow().
//   developed image (film/image.h)               12       coordinator, per download, snapshot or
//                                                         archiving, and `lensfarm render` when it
//                                                         writes: 3 floats.
//   encoded output                              <= 6      a PNG's 8-bit pixels and bytes. An EXR
//                                                         is written straight from the image, a few
//                                                         scanlines at a time: into its file, or for
//                                                         a download into a spool file streamed from
//                                                         disk; an archived image's file is streamed
//                                                         as it is.
//   checkpoint (state dir only)                  80       coordinator, while it saves a job: the
//                                                         serialized sensor (48 + 8 for the counts
//                                                         of the file format) and tracker (24).
//
// Nothing else in a render is frame-sized: the renderer's threads share the unit buffer (each
// pixel is summed by one task), and the scene (triangles and BVH) is counted by triangle.
#include <cstdint>
#include <string>
#include <vector>

#include "common/math/compensated_sum.h"
#include "common/scene/scene.h"
#include "common/util/byte_size.h"

namespace lensfarm {

// The table above, from the types themselves (tests/film/memory_test.cpp checks the types'
// allocations against these).
inline constexpr uint64_t kSensorBytesPerCell = 3 * sizeof(CompensatedSum);
inline constexpr uint64_t kTrackerBytesPerCell = 3 * sizeof(double);
inline constexpr uint64_t kUnitBufferBytesPerCell = 3 * sizeof(double) + sizeof(uint32_t);
inline constexpr uint64_t kImageBytesPerCell = 3 * sizeof(float);
inline constexpr uint64_t kPngBytesPerCell = 2 * 3;  // 8-bit sRGB pixels, and at most as many of PNG
inline constexpr uint64_t kCheckpointBytesPerCell = 3 * 2 * sizeof(double) + sizeof(uint64_t) + 3 * sizeof(double);
inline constexpr uint64_t kSceneBytesPerTriangle = 256;  // positions, normals, BVH (Embree) and build headroom
// One use of an instanced mesh (scene/scene.h, MeshInstance): the MeshInstance, Embree's instance
// geometry and its share of the top-level BVH, with build headroom (docs/performance.md).
inline constexpr uint64_t kSceneBytesPerInstance = 1024;

// What a job needs, item by item.
struct MemoryEstimate {
  struct Item {
    std::string what;
    uint64_t bytes = 0;
  };
  std::vector<Item> items;
  uint64_t total() const;
  // "sensor 12.9 GB + error-estimate half-image 6.4 GB + ...".
  std::string describe() const;
};

// Unit buffers the coordinator may hold for one job at once: fresh units are leased at most this
// many ahead of the summed prefix (Coordinator::tryLease), and never more than the job has.
uint64_t unitsAheadWindow(int width, int height, uint64_t maxBytesAhead);

// Bytes one image of the job takes while a download, snapshot or archiving uses it: the developed
// image with its AOV layers, and a PNG's pixels and bytes.
uint64_t imageMemory(const RenderSettings& settings);

// Bytes the coordinator needs for one job: its sensor and tracker, the unit buffers it may hold
// (unitsAheadWindow, at most the job's units), one image (imageMemory: the item "a download",
// last) and, with a state directory, one checkpoint. What the job holds for its life is the total
// less that last item; each download, snapshot or archiving reserves its image when it happens.
// `auditCopies`: the film copies the cross-worker audit keeps (docs/farm.md "Audit"; 0 without
// audit), each a sensor and a tracker, plus one audited unit's sums.
MemoryEstimate coordinatorJobMemory(const RenderSettings& settings, uint64_t maxBytesAhead, bool stateDir,
                                    uint64_t auditCopies = 0);

// The triangles a loaded scene holds in memory: its meshes' and its prototypes' (each once,
// however many instances draw it).
uint64_t storedTriangles(const Scene& scene);

// Bytes of a loaded scene beyond its stored triangles: textures (every mip level, each texture
// once), vertex attributes (normals, texture coordinates, tangents), instances, the
// environment map (its pixels and sampling distribution) and density grids (voxels and majorants).
uint64_t sceneDataBytes(const Scene& scene);

// Bytes a worker needs for a unit of the job: the unit buffer and the loaded scene (its triangles,
// and `sceneData` bytes of textures and attributes, sceneDataBytes).
MemoryEstimate workerJobMemory(const RenderSettings& settings, uint64_t triangles, uint64_t sceneData = 0);

// Bytes `lensfarm render` needs (coordinator and one worker in one process, results summed in
// order as they come): sensor, tracker, one unit buffer, the scene, and the image with its PNG
// when it writes (snapshots are written while a unit renders, so all at once; EXR files are
// written straight from the image).
MemoryEstimate localRenderMemory(const RenderSettings& settings, uint64_t triangles, uint64_t sceneData = 0);

// "a 16384x16384 render needs an estimated 31.7 GB of coordinator memory (sensor 12.9 GB + ...), more
// than the 17.4 GB allowed per job (--max-job-memory)": the refusal, naming the estimate and the limit.
std::string overBudgetMessage(const RenderSettings& settings, const MemoryEstimate& estimate, const std::string& whose,
                              uint64_t budget, const std::string& budgetSource);

// `lensfarm render`'s check, before it allocates anything frame-sized: InputError naming `where`
// (the flag or scene field that set the resolution) and the estimate, if it exceeds
// defaultJobMemoryBudget().
void refuseLocalRenderOverBudget(const RenderSettings& settings, uint64_t triangles, const std::string& where,
                                 uint64_t sceneData = 0);

}  // namespace lensfarm
