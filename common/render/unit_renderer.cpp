#include "common/render/unit_renderer.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>
#include <optional>
#include <stdexcept>

#include "common/camera/spectral_response.h"
#include "common/render/aov_tracer.h"
#include "common/render/integrator.h"
#include "common/render/light_tracer.h"
#include "common/render/volume_integrator.h"
#include "common/scene/scene_loader.h"  // kMaxBounces

#if defined(__SSE__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#endif

namespace lensfarm {

namespace {

// The wavelength dimension comes after every segment's block.
static_assert(dims::segment(uint32_t(pathSegmentLimit(kMaxBounces))) < dims::kWavelength);
static_assert(dims::segment(uint32_t(pathSegmentLimit(kMaxBounces) + kMaxMediumBounces + 64)) < dims::kWavelength);

// The radiance of a packet's lanes: the volume path tracer's where the scene has media or thin
// walls (one path at a time), else the packet tracer's, or the one-ray reference's (render/integrator.h).
template <bool kNee, bool kGeneral>
void traceLanes(const RenderScene& rs, const PathPacket& packet, Spectrum (&radiance)[kPacketWidth], PathStats& stats,
                RayGrouping grouping) {
  if (rs.effects().media || rs.effects().thinWalls) {
    for (int k = 0; k < packet.count; ++k)
      radiance[k] = traceVolumePath<kNee>(rs, packet.cameraRays.ray(k), packet.rng[k], stats);
  } else if (grouping == RayGrouping::kPackets) {
    tracePacket<kNee, kGeneral>(rs, packet, radiance, stats);
  } else {
    for (int k = 0; k < packet.count; ++k)
      radiance[k] = tracePath<kNee, kGeneral>(rs, packet.cameraRays.ray(k), packet.rng[k], stats);
  }
}

// One packet of the pixel loop: its lanes' samples, camera rays and weights (per thread).
struct PacketLanes {
  PathPacket packet;
  CameraSampleLanes camera;
  float weight[kPacketWidth];       // the camera's weight of each lane's ray (camera/camera.h)
  int channelOf[kPacketWidth];      // a spectral sample's band; -1: RGB
  uint64_t pixelOf[kPacketWidth];   // the frame's pixel index (keys the random numbers)
  uint64_t cellOf[kPacketWidth];    // the cell of the unit's sensor buffer
  uint64_t sampleOf[kPacketWidth];  // each lane's sample index
  Spectrum radiance[kPacketWidth];  // what each lane's sample adds to its cell
  PathPacket live;                  // the lanes whose rays the camera did not stop
};

// Where the next lane's sample lies in row j of a unit: its pixel, and its sample within the unit.
struct RowCursor {
  const WorkUnit& unit;
  int j, end;  // the row, and the region's end column
  int i;
  uint32_t sampleInPixel = 0;
  uint32_t pixelCount;
  uint64_t pixelFirst;

  RowCursor(const WorkUnit& u, int row, int begin, int endColumn)
      : unit(u),
        j(row),
        end(endColumn),
        i(begin),
        pixelCount(u.countAt(begin, row)),
        pixelFirst(u.firstAt(begin, row)) {}
  // The sample the next lane takes, moving on to the next pixel after its last.
  void next(uint64_t& pixelColumn, uint64_t& sample) {
    while (pixelCount == 0) {  // (adaptive units only: a block with no samples this unit)
      ++i;
      pixelCount = unit.countAt(i, j);
      pixelFirst = unit.firstAt(i, j);
    }
    sample = unit.samples ? unit.samples->sampleIndex(pixelFirst + sampleInPixel) : pixelFirst + sampleInPixel;
    pixelColumn = uint64_t(i);
    if (++sampleInPixel == pixelCount) {
      sampleInPixel = 0;
      if (++i < end) {
        pixelCount = unit.countAt(i, j);
        pixelFirst = unit.firstAt(i, j);
      }
    }
  }
};

// The camera samples of the packet's lanes: a point in each cell, a lens point where the camera
// reads one, and for a spectral camera a wavelength per lane, its sample in one band
// (camera/spectral_response.h). Lanes past the count take cell 0's harmless values.
void sampleCamera(const Camera& camera, const SamplerSetup& sampler, PacketLanes& l) {
  PathPacket& packet = l.packet;
  CameraSampleLanes& c = l.camera;
  c.count = packet.count;
  const SampleStream::LaneKeys keys = SampleStream::keysOf(packet.rng);
  SampleStream::values2D(packet.rng, keys, c.count, dims::kSensor, c.u0, c.u1);
  for (int k = c.count; k < kPacketWidth; ++k) c.column[k] = 0, c.u0[k] = c.u1[k] = 0.0f;
  if (camera.usesLensSample()) {
    SampleStream::values2D(packet.rng, keys, c.count, dims::kLens, c.lens0, c.lens1);
    for (int k = c.count; k < kPacketWidth; ++k) c.lens0[k] = c.lens1[k] = 0.0f;
  }
  for (int k = 0; k < kPacketWidth; ++k) l.channelOf[k] = -1;
  if (camera.spectral()) {
    alignas(64) float uWavelength[kPacketWidth];
    SampleStream::values1D(packet.rng, keys, c.count, dims::kWavelength, uWavelength);
    for (int k = 0; k < c.count; ++k) {
      const float uPixel = SampleStream(sampler, l.pixelOf[k], 0).get1D(dims::kWavelength);
      const spectral::WavelengthSample ws = spectral::sampleWavelength(l.sampleOf[k], uPixel, uWavelength[k]);
      c.wavelengthNm[k] = ws.nm;
      l.channelOf[k] = ws.channel;
    }
  }
}

// A lane's radiance as the sensor reads it: times the camera's weight; a spectral sample's in its
// band's channel alone (a value that is not >= 0 becomes NaN, dropped when accumulated).
Spectrum sensorReading(const Spectrum& traced, float weight, int channel) {
  if (channel < 0) return weight != 1.0f ? traced * weight : traced;
  const float v = traced[channel];
  Spectrum l(0.0f);
  l[channel] = spectral::kBandWeight * v * weight;
  return v >= 0.0f ? l : Spectrum(std::numeric_limits<float>::quiet_NaN());
}

// The geometric AOVs of the packet's camera rays, a packet at a time where rays are grouped.
void addPacketAovs(const RenderScene& rs, PacketLanes& l, SensorBuffer& out, RayGrouping grouping) {
  const AovLayout& aovs = rs.aovLayout();
  const size_t stride = size_t(aovs.channels);
  const PathPacket& packet = l.packet;
  if (grouping == RayGrouping::kPackets) {
    bool isFirst[kPacketWidth];
    double* cells[kPacketWidth];
    for (int k = 0; k < packet.count; ++k) isFirst[k] = l.sampleOf[k] == 0, cells[k] = &out.sums[stride * l.cellOf[k]];
    addGeometricAovs(rs, aovs, packet.cameraRays, packet.count, isFirst, cells);
  } else {
    for (int k = 0; k < packet.count; ++k)
      addGeometricAovs(rs, aovs, packet.cameraRays.ray(k), l.sampleOf[k] == 0, &out.sums[stride * l.cellOf[k]]);
  }
}

// Each lane's radiance: its camera ray traced, read by the sensor. A camera that stops rays (a
// real lens) has a stopped lane count as a path with a sample of zero, untraced, and its live
// lanes gathered into a packet of their own (each lane's radiance is the same bits whatever the
// packet), their AOVs added one ray at a time.
template <bool kNee, bool kGeneral>
void traceCameraRays(const RenderScene& rs, PacketLanes& l, SensorBuffer& out, PathStats& stats, RayGrouping grouping) {
  const Camera& camera = rs.camera();
  const AovLayout& aovs = rs.aovLayout();
  camera.sampleRays(l.camera, l.packet.cameraRays, l.weight);
  if (!camera.stopsRays()) {
    if (aovs.geometric()) addPacketAovs(rs, l, out, grouping);
    traceLanes<kNee, kGeneral>(rs, l.packet, l.radiance, stats, grouping);
    for (int k = 0; k < l.packet.count; ++k) l.radiance[k] = sensorReading(l.radiance[k], l.weight[k], l.channelOf[k]);
    return;
  }
  PathPacket& live = l.live;
  int laneOf[kPacketWidth];
  live.count = 0;
  for (int k = 0; k < l.packet.count; ++k) {
    l.radiance[k] = Spectrum(0.0f);
    if (!(l.weight[k] > 0.0f)) {
      ++stats.paths;
      continue;
    }
    const CameraRay ray = l.packet.cameraRays.ray(k);
    if (aovs.geometric())
      addGeometricAovs(rs, aovs, ray, l.sampleOf[k] == 0, &out.sums[size_t(aovs.channels) * l.cellOf[k]]);
    laneOf[live.count] = k;
    live.cameraRays.set(live.count, ray);
    live.rng[live.count] = l.packet.rng[k];
    ++live.count;
  }
  if (live.count == 0) return;
  Spectrum traced[kPacketWidth];
  for (int k = live.count; k < kPacketWidth; ++k) live.cameraRays.set(k, live.cameraRays.ray(0));
  traceLanes<kNee, kGeneral>(rs, live, traced, stats, grouping);
  for (int k = 0; k < live.count; ++k) {
    const int lane = laneOf[k];
    l.radiance[lane] = sensorReading(traced[k], l.weight[lane], l.channelOf[lane]);
  }
}

// Each lane's reading into its cell's sums. Each cell's sums start at zero and take its samples in
// sample order: the same double sums whatever the packets.
void accumulate(const AovLayout& aovs, const PacketLanes& l, SensorBuffer& out, PathStats& stats) {
  const size_t stride = size_t(aovs.channels);
  for (int k = 0; k < l.packet.count; ++k) {
    const Spectrum& r = l.radiance[k];
    if (!isFinite(r)) {
      ++stats.dropped;  // counted as a sample of zero, never written (docs/architecture.md, "Invariants")
      continue;
    }
    double* cell = &out.sums[stride * l.cellOf[k]];
    cell[0] += r.r;
    cell[1] += r.g;
    cell[2] += r.b;
    if (aovs.variance >= 0) {  // sums of squares, for the variance AOV
      cell[aovs.variance] += double(r.r) * double(r.r);
      cell[aovs.variance + 1] += double(r.g) * double(r.g);
      cell[aovs.variance + 2] += double(r.b) * double(r.b);
    }
  }
}

// What every row of one unit's pixel loop shares.
struct PixelLoop {
  const RenderScene& rs;
  const WorkUnit& unit;
  SamplerSetup sampler;
  PixelRegion region;  // the cells rendered
  int width;           // the frame's
};

// Row j of the unit: its samples in pixel-major, sample-minor order, cut into packets of
// kPacketWidth (with units of 16 samples a packet is one pixel's samples; smaller units put
// neighbouring pixels together). Packets never span rows, so they are the same for any thread
// count. An adaptive unit gives each block its own range (film/sample_map.h); the others, every
// cell the unit's.
template <bool kNee, bool kGeneral>
void renderRow(const PixelLoop& p, int j, PacketLanes& l, SensorBuffer& out, PathStats& stats, RayGrouping grouping) {
  const WorkUnit& unit = p.unit;
  const PixelRegion& region = p.region;
  uint64_t rowSamples = uint64_t(region.width) * unit.sampleCount;
  if (unit.samples) {
    rowSamples = 0;
    for (int i = region.x; i < region.x + region.width; ++i) rowSamples += unit.countAt(i, j);
  }
  RowCursor cursor(unit, j, region.x, region.x + region.width);
  const uint64_t rowCell = uint64_t(j - region.y) * uint64_t(region.width) - uint64_t(region.x);  // + i: out's cell
  l.camera.row = j;
  for (uint64_t first = 0; first < rowSamples; first += kPacketWidth) {
    l.packet.count = int(std::min<uint64_t>(kPacketWidth, rowSamples - first));
    for (int k = 0; k < l.packet.count; ++k) {
      uint64_t i, s;
      cursor.next(i, s);
      l.pixelOf[k] = uint64_t(j) * uint64_t(p.width) + i;
      l.cellOf[k] = rowCell + i;
      l.packet.rng[k] = SampleStream(p.sampler, l.pixelOf[k], s);
      l.camera.column[k] = int(i);
      l.sampleOf[k] = s;
    }
    sampleCamera(p.rs.camera(), p.sampler, l);
    traceCameraRays<kNee, kGeneral>(p.rs, l, out, stats, grouping);
    accumulate(p.rs.aovLayout(), l, out, stats);
  }
  for (int x = 0; x < region.width; ++x)
    out.samples[uint64_t(j - region.y) * uint64_t(region.width) + uint64_t(x)] = unit.countAt(region.x + x, j);
}

// The pixel loop for one combination of effects, fixed at compile time.
template <bool kNee, bool kGeneral>
bool renderUnitWith(const RenderScene& rs, const WorkUnit& unit, SensorBuffer& out, PathStats& stats,
                    const std::atomic<bool>* cancel, RayGrouping grouping) {
  const int width = rs.camera().width(), height = rs.camera().height();
  const RenderSettings& settings = rs.settings();
  // The cells rendered: the unit's region, or the whole frame. Random numbers are keyed by the
  // frame's pixel index, so a cell's samples are the same bits in a tile and in the frame.
  const PixelLoop loop{rs, unit,
                       SamplerSetup{settings.sampler, settings.seed, settings.samplesPerPixel, unitSize(settings)},
                       unit.region.empty() ? PixelRegion{0, 0, width, height} : unit.region, width};
  out = SensorBuffer(loop.region.width, loop.region.height, rs.aovLayout().channels);
  tbb::combinable<PathStats> threadStats;
  std::atomic<bool> cancelled{false};
#if defined(__SSE__)
  const unsigned callerMode = _mm_getcsr();  // the calling thread runs chunks too (below)
#endif
  tbb::parallel_for(tbb::blocked_range<int>(loop.region.y, loop.region.y + loop.region.height, 1),
                    [&](const tbb::blocked_range<int>& rows) {
#if defined(__SSE__)
                      // Embree's recommendation: denormals only slow traversal down. Every worker sets
                      // the same mode, so results stay identical across threads.
                      _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
                      _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
#endif
                      PathStats& local = threadStats.local();
                      PacketLanes lanes;
                      for (int j = rows.begin(); j != rows.end(); ++j) {
                        if (cancel && cancel->load(std::memory_order_relaxed)) {
                          cancelled = true;
                          return;
                        }
                        renderRow<kNee, kGeneral>(loop, j, lanes, out, local, grouping);
                      }
                    });
#if defined(__SSE__)
  _mm_setcsr(callerMode);  // flush-to-zero stays on the render threads, not on the caller's
#endif
  threadStats.combine_each([&](const PathStats& st) { stats += st; });
  return !cancelled;
}

bool renderPass(const RenderScene& rs, const WorkUnit& unit, SensorBuffer& out, PathStats& stats,
                const std::atomic<bool>* cancel, RayGrouping grouping) {
  // Pick the specialisation once per unit (scene/effects.h); the inner loops then carry no
  // branch for an effect the scene does not call for. The camera (camera/camera.h) is asked once
  // per packet for all its lanes' rays.
  const EffectSet& e = rs.effects();
  // (With the naive estimator the light sampler holds the delta lights alone, if any.)
  const bool nee = e.lightSampling && !rs.lights().empty();
  const bool general = e.generalMaterials;
  using Fn =
      bool (*)(const RenderScene&, const WorkUnit&, SensorBuffer&, PathStats&, const std::atomic<bool>*, RayGrouping);
  static constexpr Fn kTable[2][2] = {{renderUnitWith<false, false>, renderUnitWith<false, true>},
                                      {renderUnitWith<true, false>, renderUnitWith<true, true>}};
  if (!kTable[nee][general](rs, unit, out, stats, cancel, grouping)) return false;
  // The light paths that the path tracer leaves to the light tracer (render/light_tracer.h).
  return !rs.lightTracing() || traceLightPaths(rs, unit, out, stats, cancel);
}

}  // namespace

bool renderUnit(const RenderScene& rs, const WorkUnit& unit, SensorBuffer& out, PathStats& stats,
                const std::atomic<bool>* cancel, RayGrouping grouping) {
  // A light path splats anywhere in the frame: light tracing needs whole-frame units (the effect
  // analysis turns it off for tiled layouts, scene/effects.h).
  if (rs.lightTracing() && (!unit.region.empty() || unit.samples))
    throw std::invalid_argument(
        "light tracing renders whole-frame units of one sample range only "
        "(render.light_tracing off for tiles and adaptive sampling)");
  if (unit.samples) {
    if (!unit.region.empty() || unit.passSamples != 0)
      throw std::invalid_argument("an adaptive unit covers the whole frame in one pass");
    const std::string why = unit.samples->whyNotFor(rs.camera().width(), rs.camera().height());
    if (!why.empty()) throw std::invalid_argument("adaptive unit " + std::to_string(unit.index) + ": " + why);
  }
  if (unit.passSamples == 0 || unit.passSamples >= unit.sampleCount)
    return renderPass(rs, unit, out, stats, cancel, grouping);
  // A tile unit: pass after pass, folded by a Sensor of the tile's size exactly as the job's
  // sensor folds whole-frame passes (Neumaier, from zero), so the value uploaded is the bits the
  // sensor would develop.
  SensorBuffer pass;
  std::optional<Sensor> sums;
  uint64_t done = 0;
  while (done < unit.sampleCount) {
    WorkUnit p = unit;
    p.firstSample = unit.firstSample + done;
    p.sampleCount = uint32_t(std::min<uint64_t>(unit.passSamples, unit.sampleCount - done));
    p.passSamples = 0;
    if (!renderPass(rs, p, pass, stats, cancel, grouping)) return false;
    if (!sums) sums.emplace(pass.width, pass.height, pass.channels);
    sums->add(pass, p.sampleCount);
    done += p.sampleCount;
  }
  out = SensorBuffer(pass.width, pass.height, pass.channels);
  for (size_t k = 0; k < out.sums.size(); ++k) out.sums[k] = sums->sum(k);
  std::fill(out.samples.begin(), out.samples.end(), unit.sampleCount);
  return true;
}

}  // namespace lensfarm
