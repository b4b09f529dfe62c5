#pragma once
// How a job is cut into units (docs/farm.md "Tiles and passes"), fixed at submission and the
// same in every process: the coordinator leases, checks and folds units by it, and
// `lensfarm render` runs the same layout in one process.
//
// Two kinds of unit; neither changes a bit of the image:
//  - a pass: one range of samples (unitSize(settings) of them) over the whole frame. Units are
//    passes in order; the sensor sums them (Neumaier, film/sensor.h), so every snapshot covers the
//    whole frame and a job can stop at a target error or deadline after any pass. What a still of
//    modest size and a convergence-driven job use.
//  - a tile: a rectangle of the frame with every sample of the job, traced by one worker in the
//    same passes and summed pass by pass from zero with the same compensated sum
//    (render/unit_renderer.h, WorkUnit::passSamples). Its sums are therefore exactly the cells'
//    values the whole-frame passes would give, and a tile is final when it arrives: the coordinator
//    writes its mean into a float image and holds no sums. Units are frame-major, tiles in rows.
//    What big frames and animations use: each cell crosses the network once (bytes in = the
//    frame's sums, whatever the sample count) and the coordinator holds a float image, not a sensor.
//
// Frames: an animation's unit u renders frame frames.frameAt(u / unitsPerFrame()).
//
// An adaptive job (RenderSettings::adaptive, a still in passes) has unitsPerFrame() passes of P
// samples a pixel on average: the first `adaptiveStart` (even) are uniform passes, the rest come in
// rounds (each an even number of units, each round about half the units before it, so the film
// grows by half each round and a farm waits for a round's last unit about log(samples) times).
// A round's units trace what film/adaptive_allocation.h decides once every unit before the round
// is summed; until then they cannot be leased. The samples per pixel are rounded up so that the
// adaptive units are whole pairs.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/film/adaptive_allocation.h"
#include "common/film/work_unit.h"
#include "common/scene/frame_range.h"
#include "common/scene/scene.h"

namespace lensfarm {

struct JobLayout {
  int width = 0, height = 0;
  uint64_t samplesPerPixel = 0;
  uint32_t passSamples = 1;          // unitSize(settings): the samples of one pass
  int tileSize = 0;                  // 0: units are passes; N: units are tiles of N x N (edge tiles smaller)
  std::optional<FrameRange> frames;  // unset: a still
  int channels = 3;                  // sums per cell: the beauty's RGB and the AOVs' (film/aov_layout.h)
  // Adaptive sampling (above): 0 for a job without it.
  uint64_t adaptiveStart = 0;         // the uniform passes; rounds start here
  std::vector<uint64_t> roundStarts;  // each round's first unit (the first is adaptiveStart)
  int blockEdge = 0;
  double allocationFloor = 0.0;

  // The layout of a job with these (resolved) settings: RenderSettings::tileSize must not be
  // kTilesAuto (resolveTileSize decides that).
  static JobLayout of(const RenderSettings& settings, const std::optional<FrameRange>& frames);

  bool tiled() const { return tileSize > 0; }
  int tilesX() const { return tiled() ? (width + tileSize - 1) / tileSize : 1; }
  int tilesY() const { return tiled() ? (height + tileSize - 1) / tileSize : 1; }
  uint64_t frameCount() const { return frames ? frames->count() : 1; }
  uint64_t unitsPerFrame() const;
  uint64_t unitCount() const { return unitsPerFrame() * frameCount(); }
  // Which frame of the job (0-based) unit `u` belongs to, and its scene frame number.
  uint64_t frameIndexOf(uint64_t u) const { return u / unitsPerFrame(); }
  int64_t frameNumber(uint64_t frameIndex) const { return frames ? frames->frameAt(frameIndex) : 0; }
  // Unit `u` (u < unitCount()): its samples, region and frame.
  WorkUnit unit(uint64_t u) const;
  // The cells unit `u` covers (the whole frame for a pass).
  PixelRegion regionOf(uint64_t u) const;
  // The doubles a unit's upload carries (`channels` per cell of its region).
  uint64_t sumsOf(uint64_t u) const;

  bool adaptive() const { return adaptiveStart > 0; }
  // With a target error or deadline, the uniform passes are at most `uniform` x 4 x this (16 at
  // the default quarter).
  static constexpr double kMaxUniformPasses = 16.0;
  // The round unit `u` is in; -1 for a uniform pass (and every unit of a job without rounds).
  int roundOf(uint64_t u) const;
  // Round r's units: [roundStarts[r], roundEnd(r)).
  uint64_t roundEnd(size_t r) const { return r + 1 < roundStarts.size() ? roundStarts[r + 1] : unitCount(); }
  // What round r's allocation (film/adaptive_allocation.h) is asked for.
  AllocationRequest roundRequest(size_t r) const;
  // For logs: "adaptive: 4 uniform passes, then 3 rounds over blocks of 16 px"; "" without rounds.
  std::string adaptiveSummary() const;
};

// Resolves RenderSettings::kTilesAuto: passes for a job that stops at a target error or
// deadline or samples adaptively, and for a still whose sensor is small (at most kPassMaxCells cells); tiles
// otherwise — whole frames for an animation with at least two frames per worker, else tiles of
// kTileEdge (smaller, down to kMinTileEdge, until there are four tiles a worker). `workers` is
// the number of workers connected at submission (at least 1). Explicit values are returned as
// given, a tile edge larger than the frame clamped to it.
inline constexpr uint64_t kPassMaxCells = uint64_t(1) << 22;  // 4.2 Mpixel: a 2048 x 2048 sensor
inline constexpr int kTileEdge = 256, kMinTileEdge = 64;
int resolveTileSize(const RenderSettings& settings, const std::optional<FrameRange>& frames, uint32_t workers);

}  // namespace lensfarm
