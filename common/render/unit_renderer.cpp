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

uint64_t unitCount(uint64_t samplesPerPixel, uint32_t samplesPerUnit) {
  return (samplesPerPixel + samplesPerUnit - 1) / samplesPerUnit;
}

WorkUnit unitAt(uint64_t index, uint64_t samplesPerPixel, uint32_t samplesPerUnit) {
  const uint64_t first = index * samplesPerUnit;
  const uint64_t count = std::min<uint64_t>(samplesPerUnit, samplesPerPixel - std::min(first, samplesPerPixel));
  WorkUnit unit;
  unit.index = index;
  unit.firstSample = first;
  unit.sampleCount = uint32_t(count);
  return unit;
}

namespace {

// The cameras the pixel loop specialises on: no lens sample, the thin lens's, a real lens's, a
// real lens that disperses (every camera sample at its own wavelength: camera/spectral_response.h).
enum CameraKind { kPinhole, kThinLens, kRealLens, kRealLensSpectral };

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

// The pixel loop for one combination of effects, fixed at compile time.
template <int kCamera, bool kNee, bool kGeneral>
bool renderUnitWith(const RenderScene& rs, const WorkUnit& unit, SensorBuffer& out, PathStats& stats,
                    const std::atomic<bool>* cancel, RayGrouping grouping) {
  const ThinLensCamera& camera = rs.camera();
  const int width = camera.width(), height = camera.height();
  const float apertureWeight = camera.aperture().weight();
  const RenderSettings& settings = rs.settings();
  const SamplerSetup sampler{settings.sampler, settings.seed, settings.samplesPerPixel, unitSize(settings)};
  // The cells rendered: the unit's region, or the whole frame. Random numbers are keyed by the
  // frame's pixel index, so a cell's samples are the same bits in a tile and in the frame.
  const PixelRegion region = unit.region.empty() ? PixelRegion{0, 0, width, height} : unit.region;
  const AovLayout& aovs = rs.aovLayout();
  out = SensorBuffer(region.width, region.height, aovs.channels);
  const size_t stride = size_t(aovs.channels);
  tbb::combinable<PathStats> threadStats;
  std::atomic<bool> cancelled{false};
#if defined(__SSE__)
  const unsigned callerMode = _mm_getcsr();  // the calling thread runs chunks too (below)
#endif

  tbb::parallel_for(
      tbb::blocked_range<int>(region.y, region.y + region.height, 1), [&](const tbb::blocked_range<int>& rows) {
#if defined(__SSE__)
        // Embree's recommendation: denormals only slow traversal down. Every worker sets the same
        // mode, so results stay identical across threads.
        _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
        _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
#endif
        PathStats& local = threadStats.local();
        PathPacket packet;
        PathPacket liveLanes;  // a real lens's lanes whose rays got out of the lens
        Spectrum radiance[kPacketWidth];
        uint64_t pixelOf[kPacketWidth];  // the frame's pixel index (keys the random numbers)
        uint64_t cellOf[kPacketWidth];   // the cell of `out`
        int column[kPacketWidth];
        alignas(64) float u0[kPacketWidth], u1[kPacketWidth], lens0[kPacketWidth], lens1[kPacketWidth];
        uint64_t sampleOf[kPacketWidth];  // each lane's sample index
        for (int j = rows.begin(); j != rows.end(); ++j) {
          if (cancel && cancel->load(std::memory_order_relaxed)) {
            cancelled = true;
            return;
          }
          // The row's samples in pixel-major, sample-minor order, cut into packets of kPacketWidth:
          // with units of 16 samples a packet is one pixel's samples; smaller units put neighbouring
          // pixels together. Packets never span rows, so they are the same for any thread count.
          // An adaptive unit gives each block its own range (film/sample_map.h); the others, every
          // cell the unit's.
          uint64_t rowSamples = uint64_t(region.width) * unit.sampleCount;
          if (unit.samples) {
            rowSamples = 0;
            for (int i = region.x; i < region.x + region.width; ++i) rowSamples += unit.countAt(i, j);
          }
          int i = region.x;            // the next lane's pixel ...
          uint32_t sampleInPixel = 0;  // ... and its sample within the unit
          uint32_t pixelCount = unit.countAt(i, j);
          uint64_t pixelFirst = unit.firstAt(i, j);
          const uint64_t rowCell =
              uint64_t(j - region.y) * uint64_t(region.width) - uint64_t(region.x);  // + i: out's cell
          for (uint64_t first = 0; first < rowSamples; first += kPacketWidth) {
            packet.count = int(std::min<uint64_t>(kPacketWidth, rowSamples - first));
            for (int k = 0; k < packet.count; ++k) {
              while (pixelCount == 0) {  // (adaptive units only: a block with no samples this unit)
                ++i;
                pixelCount = unit.countAt(i, j);
                pixelFirst = unit.firstAt(i, j);
              }
              const uint64_t s =
                  unit.samples ? unit.samples->sampleIndex(pixelFirst + sampleInPixel) : pixelFirst + sampleInPixel;
              pixelOf[k] = uint64_t(j) * width + uint64_t(i);
              cellOf[k] = rowCell + uint64_t(i);
              packet.rng[k] = SampleStream(sampler, pixelOf[k], s);
              column[k] = i;
              sampleOf[k] = s;
              if (++sampleInPixel == pixelCount) {
                sampleInPixel = 0;
                if (++i < region.x + region.width) {
                  pixelCount = unit.countAt(i, j);
                  pixelFirst = unit.firstAt(i, j);
                }
              }
            }
            // The points in the sensor cells: one vector loop where the sampler has a lane form.
            const SampleStream::LaneKeys keys = SampleStream::keysOf(packet.rng);
            SampleStream::values2D(packet.rng, keys, packet.count, dims::kSensor, u0, u1);
            // All lanes' camera rays in one vector loop (lanes past the count trace a harmless ray of
            // cell 0). Without depth of field the lens is a pinhole: no lens sample, the same rays.
            for (int k = packet.count; k < kPacketWidth; ++k) column[k] = 0, u0[k] = u1[k] = 0.0f;
            if constexpr (kCamera == kRealLens || kCamera == kRealLensSpectral) {
              // Through every surface of a real lens, lane by lane: a ray the lens stops is a sample
              // of zero (a path, not traced); the others are traced as one packet of the live lanes
              // (each lane's radiance is tracePath's bits whatever the packet) and carry the lens's
              // irradiance weight (real_lens_camera.h). Through a lens that disperses, each lane is
              // traced at its own wavelength and counts in its band's channel alone
              // (camera/spectral_response.h); otherwise at the d line, with no wavelength work.
              SampleStream::values2D(packet.rng, keys, packet.count, dims::kLens, lens0, lens1);
              const RealLensCamera& real = *rs.realCamera();
              PathPacket& live = liveLanes;
              int laneOf[kPacketWidth];
              float weight[kPacketWidth];
              [[maybe_unused]] int channelOf[kPacketWidth];
              [[maybe_unused]] alignas(64) float uWavelength[kPacketWidth];
              if constexpr (kCamera == kRealLensSpectral)
                SampleStream::values1D(packet.rng, keys, packet.count, dims::kWavelength, uWavelength);
              live.count = 0;
              for (int k = 0; k < packet.count; ++k) {
                radiance[k] = Spectrum(0.0f);
                float w = 0.0f;
                double nm = LensSystem::kWavelengthD;
                if constexpr (kCamera == kRealLensSpectral) {
                  const float uPixel = SampleStream(sampler, pixelOf[k], 0).get1D(dims::kWavelength);
                  const spectral::WavelengthSample ws = spectral::sampleWavelength(sampleOf[k], uPixel, uWavelength[k]);
                  nm = ws.nm;
                  channelOf[live.count] = ws.channel;
                }
                const std::optional<CameraRay> ray =
                    real.generateRay(column[k], j, Vec2(u0[k], u1[k]), Vec2(lens0[k], lens1[k]), &w, nm);
                if (!ray) {
                  ++local.paths;
                  continue;
                }
                if (aovs.geometric()) addGeometricAovs(rs, aovs, *ray, sampleOf[k] == 0, &out.sums[stride * cellOf[k]]);
                laneOf[live.count] = k;
                weight[live.count] = w;
                live.cameraRays.set(live.count, *ray);
                live.rng[live.count] = packet.rng[k];
                ++live.count;
              }
              Spectrum traced[kPacketWidth];
              for (int k = live.count; k < kPacketWidth; ++k) live.cameraRays.set(k, live.cameraRays.ray(0));
              if (live.count > 0) traceLanes<kNee, kGeneral>(rs, live, traced, local, grouping);
              for (int k = 0; k < live.count; ++k) {
                if constexpr (kCamera == kRealLensSpectral) {
                  // The path's spectral radiance at its wavelength is its band's channel; the sensor
                  // reads it in that channel alone. A value not finite or negative is dropped below.
                  const float v = traced[k][channelOf[k]];
                  Spectrum l(0.0f);
                  l[channelOf[k]] = spectral::kBandWeight * v * weight[k];
                  radiance[laneOf[k]] = v >= 0.0f ? l : Spectrum(std::numeric_limits<float>::quiet_NaN());
                } else {
                  radiance[laneOf[k]] = traced[k] * weight[k];
                }
              }
            } else {
              if constexpr (kCamera == kThinLens) {
                SampleStream::values2D(packet.rng, keys, packet.count, dims::kLens, lens0, lens1);
                for (int k = packet.count; k < kPacketWidth; ++k) lens0[k] = lens1[k] = 0.0f;
                camera.generateRays(column, j, u0, u1, lens0, lens1, packet.cameraRays);
              } else {
                camera.generatePinholeRays(column, j, u0, u1, packet.cameraRays);
              }
              if (aovs.geometric()) {
                if (grouping == RayGrouping::kPackets) {
                  bool isFirst[kPacketWidth];
                  double* cells[kPacketWidth];
                  for (int k = 0; k < packet.count; ++k)
                    isFirst[k] = sampleOf[k] == 0, cells[k] = &out.sums[stride * cellOf[k]];
                  addGeometricAovs(rs, aovs, packet.cameraRays, packet.count, isFirst, cells);
                } else {
                  for (int k = 0; k < packet.count; ++k)
                    addGeometricAovs(rs, aovs, packet.cameraRays.ray(k), sampleOf[k] == 0,
                                     &out.sums[stride * cellOf[k]]);
                }
              }
              traceLanes<kNee, kGeneral>(rs, packet, radiance, local, grouping);
              // An aperture image passes its mean transmission (camera/aperture.h, "Exposure"); every
              // other aperture weighs 1 and skips this.
              if (apertureWeight != 1.0f)
                for (int k = 0; k < packet.count; ++k) radiance[k] *= apertureWeight;
            }
            // Each cell's sums start at zero and take its samples in sample order: the same double
            // sums whatever the packets.
            for (int k = 0; k < packet.count; ++k) {
              const Spectrum& l = radiance[k];
              if (!isFinite(l)) {
                ++local.dropped;  // counted as a sample of zero, never written (docs/architecture.md, "Invariants")
                continue;
              }
              double* cell = &out.sums[stride * cellOf[k]];
              cell[0] += l.r;
              cell[1] += l.g;
              cell[2] += l.b;
              if (aovs.variance >= 0) {  // sums of squares, for the variance AOV
                cell[aovs.variance] += double(l.r) * double(l.r);
                cell[aovs.variance + 1] += double(l.g) * double(l.g);
                cell[aovs.variance + 2] += double(l.b) * double(l.b);
              }
            }
          }
          for (int x = 0; x < region.width; ++x)
            out.samples[uint64_t(j - region.y) * uint64_t(region.width) + uint64_t(x)] = unit.countAt(region.x + x, j);
        }
      });
#if defined(__SSE__)
  _mm_setcsr(callerMode);  // flush-to-zero stays on the render threads, not on the caller's
#endif
  threadStats.combine_each([&](const PathStats& st) { stats += st; });
  return !cancelled;
}

}  // namespace

namespace {
bool renderPass(const RenderScene& rs, const WorkUnit& unit, SensorBuffer& out, PathStats& stats,
                const std::atomic<bool>* cancel, RayGrouping grouping) {
  // Pick the specialisation once per unit (scene/effects.h); the inner loops then carry no
  // branch for an effect the scene does not call for.
  const EffectSet& e = rs.effects();
  const int cameraKind = rs.realCamera()  ? (rs.realCamera()->spectral() ? kRealLensSpectral : kRealLens)
                         : e.depthOfField ? kThinLens
                                          : kPinhole;
  // (With the naive estimator the light sampler holds the delta lights alone, if any.)
  const bool nee = e.lightSampling && !rs.lights().empty();
  const bool general = e.generalMaterials;
  using Fn =
      bool (*)(const RenderScene&, const WorkUnit&, SensorBuffer&, PathStats&, const std::atomic<bool>*, RayGrouping);
  static constexpr Fn kTable[4][2][2] = {
      {{renderUnitWith<kPinhole, false, false>, renderUnitWith<kPinhole, false, true>},
       {renderUnitWith<kPinhole, true, false>, renderUnitWith<kPinhole, true, true>}},
      {{renderUnitWith<kThinLens, false, false>, renderUnitWith<kThinLens, false, true>},
       {renderUnitWith<kThinLens, true, false>, renderUnitWith<kThinLens, true, true>}},
      {{renderUnitWith<kRealLens, false, false>, renderUnitWith<kRealLens, false, true>},
       {renderUnitWith<kRealLens, true, false>, renderUnitWith<kRealLens, true, true>}},
      {{renderUnitWith<kRealLensSpectral, false, false>, renderUnitWith<kRealLensSpectral, false, true>},
       {renderUnitWith<kRealLensSpectral, true, false>, renderUnitWith<kRealLensSpectral, true, true>}}};
  if (!kTable[cameraKind][nee][general](rs, unit, out, stats, cancel, grouping)) return false;
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

uint64_t maxRaysPerPath(const RenderSettings& settings) {
  const uint64_t camera = uint64_t(volumePathSegmentLimit(settings)) * 2 * uint64_t(kMaxCrossings);
  const uint64_t light = uint64_t(pathSegmentLimit(settings.maxBounces)) * 2;
  return camera + light;
}

}  // namespace lensfarm
