#pragma once
// A heterogeneous medium from a dense grid of densities (the simple form; OpenVDB files are read
// into it by medium/vdb_grid.h), with a coarse majorant grid traversed by a 3D DDA so that empty
// space is cheap (PBR 4th ed. §11.4.3 and §14.2.3, pbrt-v4's MajorantGrid / DDAMajorantIterator idea).
//
//  - The box [lo, hi] (axis-aligned, in the medium's space: scene units) holds nx x ny x nz density
//    values, stored x fastest: density[(z * ny + y) * nx + x]. Each value sits at its voxel's
//    centre; density(p) interpolates them trilinearly, clamped to the edge values inside the box,
//    and is 0 outside it.
//  - sigma_a(p) = density(p) sigma_a, sigma_s(p) = density(p) sigma_s (per channel, 1 / scene
//    units, as in medium/homogeneous_medium.h); one Henyey-Greenstein g for the whole grid.
//  - The majorant grid splits the box into mx x my x mz cells and stores, for each, the maximum of
//    the density values whose trilinear support overlaps it: trilinear interpolation is a convex
//    combination of its 8 values, so that maximum bounds density(p) over the cell.
//  - forEachMajorantSegment walks the majorant cells a ray crosses in order (Amanatides & Woo
//    1987, "A Fast Voxel Traversal Algorithm for Ray Tracing"), in double so that long rays do not
//    skip or repeat cells; cells of majorant 0 are visited but cost no tracking step.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

#include "common/math/vec.h"
#include "common/medium/homogeneous_medium.h"  // FreeFlight
#include "common/medium/majorant_tracking.h"
#include "common/medium/phase_function.h"

namespace lensfarm {

class GridMedium {
 public:
  GridMedium(const Vec3& lo, const Vec3& hi, const glm::ivec3& resolution, std::vector<float> density,
             const Spectrum& sigmaA, const Spectrum& sigmaS, float g,
             const glm::ivec3& majorantResolution = glm::ivec3(16));

  float density(const Vec3& p) const;
  Spectrum sigmaT(const Vec3& p) const { return density(p) * sigmaT_; }
  const Spectrum& sigmaTScale() const { return sigmaT_; }
  const Spectrum& sigmaAScale() const { return sigmaA_; }
  const Spectrum& sigmaSScale() const { return sigmaS_; }
  const HenyeyGreenstein& phase() const { return phase_; }
  const glm::ivec3& majorantResolution() const { return majorantRes_; }
  const glm::ivec3& resolution() const { return res_; }
  const std::vector<float>& densities() const { return density_; }
  float majorantDensity(const glm::ivec3& cell) const { return majorant_[index(cell, majorantRes_)]; }
  // The box of majorant cell `cell`.
  Vec3 majorantCellLo(const glm::ivec3& cell) const { return lo_ + (hi_ - lo_) * Vec3(cell) / Vec3(majorantRes_); }
  Vec3 majorantCellHi(const glm::ivec3& cell) const { return majorantCellLo(cell + glm::ivec3(1)); }

  // Calls visit(cell, t0, t1, maxDensity) for each majorant cell the ray o + t dir (dir need not
  // be unit; t is in its units) crosses over t in [0, tMax], in order of t, for pieces of
  // positive length; visit returns false to stop early.
  template <typename Visit>
  void forEachMajorantSegment(const Vec3& o, const Vec3& dir, float tMax, Visit&& visit) const;

  // Ratio tracking (per channel, with the largest channel's majorant) along o + t dir, t in
  // [0, tMax], dir unit: an unbiased estimate of exp(-int sigma_t) per channel.
  template <typename Uniform>
  Spectrum ratioTrackingTransmittance(const Vec3& o, const Vec3& dir, float tMax, Uniform&& uniform) const;
  // Delta tracking for one channel: 0 or 1, with expectation exp(-int sigma_t[channel]).
  template <typename Uniform>
  float deltaTrackingTransmittance(const Vec3& o, const Vec3& dir, float tMax, int channel, Uniform&& uniform) const;
  // Free-flight sampling by spectral tracking (medium/medium.h has the estimator): the first real
  // scattering event along o + t dir, t in [0, tMax], or a pass, with its throughput weight
  // (black: absorbed). `throughput` steers the event probabilities only.
  template <typename Uniform>
  FreeFlight sampleFreeFlight(const Vec3& o, const Vec3& dir, float tMax, const Spectrum& throughput,
                              Uniform&& uniform) const;

 private:
  static int index(const glm::ivec3& c, const glm::ivec3& res) { return (c.z * res.y + c.y) * res.x + c.x; }
  float voxel(int x, int y, int z) const { return density_[size_t(index(glm::ivec3(x, y, z), res_))]; }

  Vec3 lo_, hi_;
  glm::ivec3 res_;
  std::vector<float> density_;
  Spectrum sigmaA_, sigmaS_, sigmaT_;
  float maxSigmaT_;  // the largest channel of sigmaT_
  HenyeyGreenstein phase_;
  glm::ivec3 majorantRes_;
  std::vector<float> majorant_;
};

// Throws one InputError(where, field + "...: ...") for: a resolution below 1 per axis, a density
// array whose size is not nx ny nz, a negative or non-finite density, a box with hi <= lo on an
// axis, negative or non-finite sigma_a / sigma_s, g outside (-1, 1).
void validateGridMedium(const Vec3& lo, const Vec3& hi, const glm::ivec3& resolution, const std::vector<float>& density,
                        const Spectrum& sigmaA, const Spectrum& sigmaS, float g, const std::string& where,
                        const std::string& field);

template <typename Visit>
void GridMedium::forEachMajorantSegment(const Vec3& o, const Vec3& dir, float tMax, Visit&& visit) const {
  // The ray in majorant-grid coordinates, where cells are unit cubes [i, i + 1).
  const glm::dvec3 scale = glm::dvec3(majorantRes_) / glm::dvec3(hi_ - lo_);
  const glm::dvec3 go = (glm::dvec3(o) - glm::dvec3(lo_)) * scale, gd = glm::dvec3(dir) * scale;
  const glm::dvec3 res(majorantRes_);
  // Slab test against the grid [0, res].
  double tEnter = 0.0, tExit = double(tMax);
  for (int a = 0; a < 3; ++a) {
    if (gd[a] == 0.0) {
      if (go[a] < 0.0 || go[a] > res[a]) return;
      continue;
    }
    double tNear = (0.0 - go[a]) / gd[a], tFar = (res[a] - go[a]) / gd[a];
    if (tNear > tFar) std::swap(tNear, tFar);
    tEnter = std::max(tEnter, tNear);
    tExit = std::min(tExit, tFar);
  }
  if (!(tEnter < tExit)) return;
  const glm::dvec3 p0 = go + gd * tEnter;
  glm::ivec3 cell, step;
  for (int a = 0; a < 3; ++a) {
    cell[a] = std::clamp(int(std::floor(p0[a])), 0, majorantRes_[a] - 1);
    step[a] = gd[a] > 0.0 ? 1 : gd[a] < 0.0 ? -1 : 0;
  }
  // The t at which the ray leaves the current cell through axis a's far (in step's sense) face,
  // computed afresh from the cell index each time so that no error accumulates.
  const auto exitT = [&](int a) {
    if (step[a] == 0) return std::numeric_limits<double>::infinity();
    const double face = step[a] > 0 ? cell[a] + 1.0 : double(cell[a]);
    return (face - go[a]) / gd[a];
  };
  double t = tEnter;
  for (;;) {
    const double tx = exitT(0), ty = exitT(1), tz = exitT(2);
    const int axis = tx <= ty ? (tx <= tz ? 0 : 2) : (ty <= tz ? 1 : 2);
    const double tNext = std::min(std::min(tx, std::min(ty, tz)), tExit);
    if (tNext > t && !visit(cell, float(t), float(tNext), majorantDensity(cell))) return;
    if (tNext >= tExit) return;
    t = std::max(t, tNext);
    cell[axis] += step[axis];
    if (cell[axis] < 0 || cell[axis] >= majorantRes_[axis]) return;
  }
}

template <typename Uniform>
Spectrum GridMedium::ratioTrackingTransmittance(const Vec3& o, const Vec3& dir, float tMax, Uniform&& uniform) const {
  Spectrum tr(1.0f);
  forEachMajorantSegment(o, dir, tMax, [&](const glm::ivec3&, float t0, float t1, float maxDensity) {
    const auto sigmaT = [&](float t) { return this->sigmaT(o + t * dir); };
    tr *= ratioTrack<Spectrum>(t0, t1, maxDensity * maxSigmaT_, sigmaT, uniform);
    return true;
  });
  return tr;
}

template <typename Uniform>
float GridMedium::deltaTrackingTransmittance(const Vec3& o, const Vec3& dir, float tMax, int channel,
                                             Uniform&& uniform) const {
  bool passed = true;
  forEachMajorantSegment(o, dir, tMax, [&](const glm::ivec3&, float t0, float t1, float maxDensity) {
    const auto sigmaT = [&](float t) { return density(o + t * dir) * sigmaT_[channel]; };
    passed = deltaTrack(t0, t1, maxDensity * sigmaT_[channel], sigmaT, uniform) >= t1;
    return passed;  // the first real collision ends the walk
  });
  return passed ? 1.0f : 0.0f;
}

template <typename Uniform>
FreeFlight GridMedium::sampleFreeFlight(const Vec3& o, const Vec3& dir, float tMax, const Spectrum& throughput,
                                        Uniform&& uniform) const {
  FreeFlight out;
  out.weight = Spectrum(1.0f);
  out.t = tMax;
  const auto largest = [](const Spectrum& s) { return std::max(s.r, std::max(s.g, s.b)); };
  forEachMajorantSegment(o, dir, tMax, [&](const glm::ivec3&, float t0, float t1, float maxDensity) {
    const float sigmaMaj = maxDensity * maxSigmaT_;
    if (!(sigmaMaj > 0.0f)) return true;
    float t = t0;
    for (;;) {
      t -= std::log1p(-uniform()) / sigmaMaj;
      if (!(t < t1)) return true;  // on to the next majorant cell (the process is memoryless)
      const float d = density(o + t * dir);
      const Spectrum w = throughput * out.weight;
      // sigma_n = sigma_maj - sigma_t >= 0 in every channel: the majorant bounds the largest.
      const Spectrum sa = d * sigmaA_, ss = d * sigmaS_, sn = Spectrum(sigmaMaj) - d * sigmaT_;
      const float pa = largest(w * sa), ps = largest(w * ss), pn = largest(w * sn);
      const float sum = pa + ps + pn;
      if (!(sum > 0.0f)) {  // the path carries nothing any more
        out.weight = Spectrum(0.0f);
        out.scattered = false;
        return false;
      }
      const float xi = uniform() * sum;
      if (xi < pa) {  // absorbed: the path ends (no emission in the medium)
        out.weight = Spectrum(0.0f);
        return false;
      }
      if (xi < pa + ps) {  // a real scattering event
        out.weight *= ss * (sum / (sigmaMaj * ps));
        out.scattered = true;
        out.t = t;
        return false;
      }
      out.weight *= sn * (sum / (sigmaMaj * pn));  // a null collision: go on
    }
  });
  return out;
}

}  // namespace lensfarm
