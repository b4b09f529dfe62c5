#include "farm/job_layout.h"

#include <algorithm>

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
  return l;
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
  if (s.tileSize != RenderSettings::kTilesAuto) return s.tileSize > 0 ? std::min(s.tileSize, std::max(s.width, s.height)) : s.tileSize;
  const uint64_t cells = uint64_t(s.width) * uint64_t(s.height);
  if (s.convergenceDriven() || (!frames && cells <= kPassMaxCells)) return RenderSettings::kTilesOff;
  workers = std::max(1u, workers);
  const uint64_t frameCount = frames ? frames->count() : 1;
  if (frames && frameCount >= 2 * uint64_t(workers) && cells <= kPassMaxCells) return std::max(s.width, s.height);
  int edge = kTileEdge;
  const auto tiles = [&](int e) { return uint64_t((s.width + e - 1) / e) * uint64_t((s.height + e - 1) / e) * frameCount; };
  while (edge > kMinTileEdge && tiles(edge) < 4 * uint64_t(workers)) edge /= 2;
  return std::min(edge, std::max(s.width, s.height));
}

}  // namespace lensfarm
