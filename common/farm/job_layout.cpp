#include "common/farm/job_layout.h"

#include <algorithm>
#include <cmath>

namespace lensfarm {

JobLayout JobLayout::of(const RenderSettings& s, const std::optional<FrameRange>& frames) {
  JobLayout l;
  l.width = s.width;
  l.height = s.height;
  l.samplesPerPixel = s.samplesPerPixel;
  l.passSamples = unitSize(s);
  l.tileSize = s.tileSize > 0 ? std::min(s.tileSize, std::max(s.width, s.height)) : 0;
  l.frames = frames;
  l.channels = AovLayout(s.aovs).channels;
  if (s.adaptive.enabled && !l.tiled() && !frames) {
    uint64_t passes = lensfarm::unitCount(s.samplesPerPixel, l.passSamples);
    // `uniform` of the passes, an even number of them (at least 2: one in each half-image).
    const auto evenShare = [&](double of) {
      return std::max<uint64_t>(2, uint64_t(std::llround(of * s.adaptive.uniform / 2.0)) * 2);
    };
    uint64_t uniform = evenShare(double(passes));
    // A job that stops at a target error or deadline may never reach its sample cap: its rounds
    // begin after at most `uniform` x 4 x kMaxUniformPasses passes.
    if (s.convergenceDriven()) uniform = std::min(uniform, evenShare(4.0 * kMaxUniformPasses));
    if (passes > uniform) {  // else nothing is left to adapt: uniform passes alone
      if ((passes - uniform) % 2 != 0) ++passes;
      l.samplesPerPixel = passes * l.passSamples;
      l.adaptiveStart = uniform;
      for (uint64_t u = uniform; u < passes;) {
        l.roundStarts.push_back(u);
        const uint64_t size = std::max<uint64_t>(2, (u / 2 + 1) / 2 * 2);
        u += std::min(size, passes - u);
      }
      // Blocks of 16 cells, larger for a frame over 4096 of them (a lease carries a block's range).
      const uint64_t cells = uint64_t(s.width) * uint64_t(s.height);
      l.blockEdge = s.adaptive.blockEdge > 0 ? s.adaptive.blockEdge
                                             : std::max(16, int(std::ceil(std::sqrt(double(cells) / 4096.0))));
      l.allocationFloor = s.adaptive.floor;
    }
  }
  return l;
}

AllocationRequest JobLayout::roundRequest(size_t r) const {
  AllocationRequest request;
  request.start = roundStarts.at(r);
  request.units = uint32_t(roundEnd(r) - request.start);
  request.passSamples = passSamples;
  request.blockEdge = blockEdge;
  request.floor = allocationFloor;
  return request;
}

std::string JobLayout::adaptiveSummary() const {
  if (!adaptive()) return "";
  return "adaptive: " + std::to_string(adaptiveStart) + " uniform passes, then " + std::to_string(roundStarts.size()) +
         " round(s) over blocks of " + std::to_string(blockEdge) + " px";
}

int JobLayout::roundOf(uint64_t u) const {
  if (!adaptive() || u < adaptiveStart) return -1;
  return int(std::upper_bound(roundStarts.begin(), roundStarts.end(), u) - roundStarts.begin()) - 1;
}

uint64_t JobLayout::unitsPerFrame() const {
  return tiled() ? uint64_t(tilesX()) * uint64_t(tilesY()) : lensfarm::unitCount(samplesPerPixel, passSamples);
}

PixelRegion JobLayout::regionOf(uint64_t u) const {
  if (!tiled()) return PixelRegion{0, 0, width, height};
  const uint64_t t = u % unitsPerFrame();
  const int x = int(t % uint64_t(tilesX())) * tileSize, y = int(t / uint64_t(tilesX())) * tileSize;
  return PixelRegion{x, y, std::min(tileSize, width - x), std::min(tileSize, height - y)};
}

WorkUnit JobLayout::unit(uint64_t u) const {
  WorkUnit w;
  if (tiled()) {
    w = WorkUnit(u, 0, uint32_t(std::min<uint64_t>(samplesPerPixel, UINT32_MAX)));
    w.region = regionOf(u);
    w.passSamples = passSamples;
  } else {
    w = unitAt(u % unitsPerFrame(), samplesPerPixel, passSamples);
    w.index = u;
  }
  w.frame = frameNumber(frameIndexOf(u));
  return w;
}

uint64_t JobLayout::sumsOf(uint64_t u) const {
  const PixelRegion r = regionOf(u);
  return uint64_t(r.width) * uint64_t(r.height) * uint64_t(channels);
}

int resolveTileSize(const RenderSettings& s, const std::optional<FrameRange>& frames, uint32_t workers) {
  if (s.tileSize != RenderSettings::kTilesAuto)
    return s.tileSize > 0 ? std::min(s.tileSize, std::max(s.width, s.height)) : s.tileSize;
  const uint64_t cells = uint64_t(s.width) * uint64_t(s.height);
  if (s.convergenceDriven() || s.adaptive.enabled || (!frames && cells <= kPassMaxCells))
    return RenderSettings::kTilesOff;
  workers = std::max(1u, workers);
  const uint64_t frameCount = frames ? frames->count() : 1;
  if (frames && frameCount >= 2 * uint64_t(workers) && cells <= kPassMaxCells) return std::max(s.width, s.height);
  int edge = kTileEdge;
  const auto tiles = [&](int e) {
    return uint64_t((s.width + e - 1) / e) * uint64_t((s.height + e - 1) / e) * frameCount;
  };
  while (edge > kMinTileEdge && tiles(edge) < 4 * uint64_t(workers)) edge /= 2;
  return std::min(edge, std::max(s.width, s.height));
}

}  // namespace lensfarm
