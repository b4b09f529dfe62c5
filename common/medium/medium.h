#pragma once
// A participating medium as the renderer sees it (docs/media.md): homogeneous
// (medium/homogeneous_medium.h) or a density grid (medium/grid_medium.h), behind the three
// operations the volume path tracer needs (render/volume_integrator.h):
//  - sampleFreeFlight: where along a ray segment [0, tMax) the path's next real scattering event
//    lies, or that it passes the segment, with the throughput weight of that choice (absorption
//    folded in: an absorbed path returns a black weight);
//  - transmittance: exp(-int sigma_t) along a segment, or an unbiased estimate of it (shadow rays);
//  - phase: the Henyey-Greenstein phase function of the scattering.
//
// Random numbers. Tracking draws a varying count of numbers per segment, so they cannot come from
// the sampler's fixed dimensions; they come from a MediumRng, a counter-based stream keyed by the
// camera sample (pixel, sample index) and the path segment (pbrt-v4 hashes an RNG seed per ray
// for the same reason). A path's bits therefore still depend on its pixel and sample alone, never
// on the thread, the worker or the packet.
//
// Units: coefficients per RGB channel in 1 / scene units; distances t along a unit direction.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <variant>

#include "common/math/vec.h"
#include "common/medium/grid_medium.h"
#include "common/medium/homogeneous_medium.h"
#include "common/util/asset_loader.h"

namespace lensfarm {

class FieldReader;

// Uniform numbers in [0, 1) (24 bits), the i-th being a hash of (key, i): counter-based, so a
// segment's numbers are fixed by its key whatever else the path did.
class MediumRng {
 public:
  explicit MediumRng(uint64_t key) : key_(key) {}
  float operator()() {
    uint64_t z = key_ + 0x9e3779b97f4a7c15ull * ++counter_;  // SplitMix64 (Steele et al. 2014)
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return float(uint32_t(z >> 40)) * 0x1.0p-24f;
  }

 private:
  uint64_t key_;
  uint64_t counter_ = 0;
};

// A path's hero channel and its channel densities so far (HomogeneousMedium::sampleFreeFlight):
// one per camera path, across every medium it crosses.
struct SpectralMis {
  int hero = 0;
  Spectrum ratio{1.0f};
};

class Medium {
 public:
  Medium(std::string name, HomogeneousMedium m) : name_(std::move(name)), m_(std::move(m)) { classify(); }
  // A grid whose box is [worldLo, worldHi] in world space; it is traced in render space once
  // place() has moved it by the scene's origin (the scene loader does, after the camera).
  Medium(std::string name, GridMedium m, const DVec3& worldLo, const DVec3& worldHi)
      : name_(std::move(name)), m_(std::move(m)), worldLo_(worldLo), worldHi_(worldHi) {
    classify();
  }
  // Moves a grid's box to render space (p - origin, in double; scene/scene.h); nothing for a
  // homogeneous medium.
  void place(const DVec3& origin);

  const std::string& name() const { return name_; }
  const HenyeyGreenstein& phase() const;
  // Whether the medium ever scatters (false: absorption only, so a path through it is attenuated
  // deterministically and never stops inside).
  bool scatters() const { return scatters_; }
  bool homogeneous() const { return std::holds_alternative<HomogeneousMedium>(m_); }
  const HomogeneousMedium* asHomogeneous() const { return std::get_if<HomogeneousMedium>(&m_); }
  const GridMedium* asGrid() const { return std::get_if<GridMedium>(&m_); }

  // The next event along o + t dir (dir unit), t in [0, tMax) (tMax may be infinite):
  //  - homogeneous and scattering: chromatic free-flight sampling in the path's hero channel,
  //    weighted by spectral MIS over the whole path (`mis`; HomogeneousMedium::sampleFreeFlight);
  //  - absorption only: always a pass, weight exp(-sigma_t tMax) exactly (no noise);
  //  - a grid: spectral tracking (Kutz, Habel, Li & Novák 2017, "Spectral and Decomposition
  //    Tracking for Rendering Heterogeneous Volumes", §4, with history-aware probabilities): at
  //    each tentative collision of the majorant's Poisson process the event is absorption,
  //    scattering or a null collision with probabilities proportional to max_c(w_c sigma_x,c),
  //    w the path's throughput, and the throughput is multiplied by sigma_x / (sigma_maj P_x),
  //    which keeps every channel unbiased whatever the probabilities (they only need to be
  //    positive where sigma_x w is). Absorption ends the path (weight 0).
  // `throughput` is the path's before the segment (it steers the grid's probabilities).
  FreeFlight sampleFreeFlight(const Vec3& o, const Vec3& dir, float tMax, const Spectrum& throughput, MediumRng& rng,
                              SpectralMis& mis) const;
  // exp(-int_0^tMax sigma_t) along o + t dir: exact for a homogeneous medium, ratio tracking (an
  // unbiased estimate, Novák et al. 2014) for a grid.
  Spectrum transmittance(const Vec3& o, const Vec3& dir, float tMax, MediumRng& rng) const;

 private:
  void classify();
  std::string name_;
  std::variant<HomogeneousMedium, GridMedium> m_;
  DVec3 worldLo_{0.0}, worldHi_{0.0};
  bool scatters_ = true;
};

// Reads one entry of the scene's `media` (docs/scene-format.md, "Media"): `type` "homogeneous"
// (sigma_a and sigma_s, or attenuation_color and attenuation_distance with scattering_albedo; g)
// or "grid" (bounds in world space, resolution and density, or an OpenVDB `file` and its `grid`
// read through `load`; sigma_a, sigma_s, g; place() it before rendering). Errors name the field
// (InputError).
std::shared_ptr<Medium> parseMedium(const std::string& name, FieldReader& r, const AssetLoader& load);

// A per-channel coefficient: one number (grey) or three; finite. The sign is the validators'.
Spectrum readCoefficients(FieldReader& r, const std::string& key, const Spectrum& fallback);

}  // namespace lensfarm
