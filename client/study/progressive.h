#pragma once
// Progressive rendering for the accuracy study: one scene rendered unit after unit on this
// machine's cores, with the image, its live error estimate and the time taken reported at
// power-of-two sample counts. The same renderer as every job (render/unit_renderer.h); the
// time counts tracing and accumulation only (not scene loading or error measurement). The AOVs
// the scene asks for (render.aovs) are rendered and developed as the images' layers.
//
// An adaptive scene (render.adaptive, film/adaptive_allocation.h) is laid out as a farm job is
// (farm/job_layout.h): uniform passes, then rounds whose block maps are allocated from the film
// before each round, as the coordinator does, the allocations' time counted. Its samples per pixel
// are a mean, and an adaptive image of N spp is not a prefix of one of 2N spp: such a run has one
// checkpoint, at its end (maxSamples rounded up to whole pairs of passes).
#include <cstdint>
#include <filesystem>
#include <functional>

#include "common/film/convergence.h"
#include "common/film/image.h"
#include "common/render/integrator.h"
#include "common/scene/scene.h"

namespace lensfarm::study {

struct Checkpoint {
  uint64_t samplesPerPixel = 0;
  double seconds = 0.0;  // tracing time so far
  Image image;
  ErrorEstimate estimate;  // film/convergence.h, from the units so far
  PathStats stats;
};

struct ProgressiveRun {
  uint64_t firstCheckpoint = 16;  // samples per pixel; checkpoints double from here
  uint64_t maxSamples = 1 << 16;  // stop at this many samples per pixel ...
  double budgetSeconds = 1e30;    // ... or at the first checkpoint past this much time
  unsigned threads = 0;           // 0: every core
  bool everyUnit = false;         // a checkpoint after every unit instead (time to an error)
};

// Renders `scene` (its render settings as given; samplesPerUnit 0 means firstCheckpoint, or the
// farm's unit size, unitSize(), for an adaptive scene) and
// calls `onCheckpoint` at each checkpoint; rendering stops there when it returns false. Returns
// the last checkpoint.
Checkpoint renderProgressive(Scene scene, const ProgressiveRun& run,
                             const std::function<bool(const Checkpoint&)>& onCheckpoint = {});

// A converged image of `scene`: NEE + MIS with the Sobol sampler at `samplesPerPixel`, cached in
// `cacheDir` under a key of the scene's hash and settings, its AOVs included (the same study
// command reuses it).
// `estimate` receives the reference's own estimated error, the floor of every error measured
// against it.
Image referenceImage(Scene scene, uint64_t samplesPerPixel, const std::filesystem::path& cacheDir,
                     double* estimatedRelativeError, unsigned threads);

}  // namespace lensfarm::study
