#pragma once
// Path guiding (Müller, Gross & Novák 2017, "Practical Path Guiding for Efficient Light-Transport
// Simulation"; Vorba et al. 2019, "Path Guiding in Production"): before the image, camera paths are
// traced in training passes that record, at every diffuse vertex, the direction they scattered in
// and the radiance that came back along it. From those records a GuidingField learns, per region of
// space, a distribution over the sphere of directions proportional to the incident radiance; the
// image's paths then draw a share kGuidedShare of their diffuse directions from it and the rest
// from the cosine lobe, and weigh every sample by the mixture's density (one-sample MIS, Veach 1997
// §9.2.4), so the estimate stays unbiased whatever the field learned: where it is wrong, it only
// costs variance, and the cosine lobe keeps every direction the surface scatters to reachable.
//
// The field is a kd-tree over the records' bounds, split at the middle of a node's longest side
// while the node holds more than Shape::maxRecordsPerRegion records; each leaf with at least
// Shape::minRecordsPerRegion records and some radiance holds a histogram over the sphere in
// equal-area cylindrical coordinates (z = cos theta about world +z, and phi): zBins x phiBins bins
// of equal solid angle, each bin's weight the estimate sum(L / p) of the radiance its directions bring.
// A leaf with fewer records, or a point outside the bounds, is not guided (cosine lobe alone).
//
// Determinism (docs/architecture.md, "Invariants"): the training passes are a pure function of the
// scene and its seed. Their paths are traced in fixed chunks whose records are joined in chunk
// order, and the field is built from them sequentially, so every worker, thread count and retry
// learns the same field bit for bit and renders the same image; training streams are keyed apart
// from the image's samples (SampleStream seed), so the image's samples stay independent of them.
// Positions are taken relative to the records' bounds in double: the field is the same at 1e6 from
// the origin and at any scale.
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "common/math/vec.h"

namespace lensfarm {

class RenderScene;

class GuidingField {
 public:
  // How a field is learned: the directional histogram's bins (zBins x phiBins, equal solid angle),
  // the records above which a region is split, and those below which it does not guide.
  struct Shape {
    // On cornell-seed (docs/performance.md, "Path guiding"): 8 x 16 bins and regions of at most
    // 2048 records halved the relMSE at equal samples; 16 x 32 and 4096 lowered it 1.6 x, 16384 1.35 x.
    int zBins = 8, phiBins = 16;
    size_t maxRecordsPerRegion = 2048;
    size_t minRecordsPerRegion = 128;
    int bins() const { return zBins * phiBins; }
  };

  // One training sample: a direction scattered from surface point p, the density it was drawn
  // with (solid angle) and the luminance of the radiance the path brought back along it.
  struct Record {
    Vec3 p, wi;
    float pdf;
    float luminance;
  };

  GuidingField() = default;  // guides nowhere
  // The field learned from `records`, read in their order.
  static GuidingField learn(const std::vector<Record>& records, const Shape& shape);
  static GuidingField learn(const std::vector<Record>& records) { return learn(records, Shape()); }

  // The region whose distribution guides at p, or -1 where none does.
  int regionAt(const Vec3& p) const;
  // A direction drawn from region r's distribution, and its density (solid angle) for any direction.
  Vec3 sample(int region, Vec2 u) const;
  float pdf(int region, const Vec3& wi) const;

  const Shape& shape() const { return shape_; }
  size_t regionCount() const { return distributions_.size(); }
  size_t leafCount() const { return leaves_; }

  // The bin of a direction, and the direction at (z, phi) fractions of the sphere (both in [0, 1]).
  int binOf(const Vec3& wi) const;
  static Vec3 direction(double zFraction, double phiFraction);

 private:
  struct Node {
    int axis = -1;       // -1: a leaf
    double split = 0.0;  // inner: the plane's coordinate
    int child = -1;      // inner: the lower child (the upper is child + 1); leaf: its distribution or -1
  };
  struct Distribution {
    std::vector<float> probability;  // per bin, summing to 1
    std::vector<float> cdf;          // bins + 1 entries, from 0 to 1
  };
  Shape shape_;
  std::array<double, 3> lo_{}, hi_{};
  std::vector<Node> nodes_;
  std::vector<Distribution> distributions_;
  size_t leaves_ = 0;

  void build(int node, std::array<double, 3> lo, std::array<double, 3> hi, std::vector<uint32_t>& ids, size_t begin,
             size_t end, const std::vector<Record>& records, int depth);
};

// The share of a guided vertex's directions drawn from the field (Müller et al. 2017 use 1/2).
inline constexpr float kGuidedShare = 0.5f;

// The mixture's density: kGuidedShare of the field's, the rest the material's.
inline float guidedPdf(float fieldPdf, float materialPdf) {
  return kGuidedShare * fieldPdf + (1.0f - kGuidedShare) * materialPdf;
}

// What a training path records while it is traced (render/path_vertex.h): each guided vertex's
// point, direction and density, the path's throughput after it scattered there and the radiance
// the path had gathered by then; finish() turns them into records once the path has ended.
struct GuidingRecorder {
  struct Pending {
    Vec3 p, wi;
    float pdf;
    Spectrum throughput;
    Spectrum radianceBefore;
    bool settled;
  };
  std::vector<Pending> pending;

  void add(const Vec3& p, const Vec3& wi, float pdf, const Spectrum& throughput) {
    pending.push_back({p, wi, pdf, throughput, Spectrum(0.0f), false});
  }
  // The path's radiance once the vertex's own light sample is in: what comes after it arrived
  // along the vertex's scattered direction.
  void settle(const Spectrum& radiance) {
    for (auto it = pending.rbegin(); it != pending.rend() && !it->settled; ++it)
      it->radianceBefore = radiance, it->settled = true;
  }
  // The records of the ended path whose radiance was `radiance`, appended to `out`.
  void finish(const Spectrum& radiance, std::vector<GuidingField::Record>& out);
};

// The field learned by the training passes for `rs` (its effect analysis has pathGuiding on; the
// surface path tracer's paths, rs's own tracer): passes of 1, 2, 4 ... samples per pixel over an
// even grid of the frame's pixels, each pass guided by the field the pass before it learned (the
// budget: scene/effects.h, kGuidingTrainingPasses). Empty for a scene with no diffuse vertex.
std::unique_ptr<const GuidingField> trainGuidingField(const RenderScene& rs);

}  // namespace lensfarm
