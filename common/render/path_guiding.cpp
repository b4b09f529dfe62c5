#include "common/render/path_guiding.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "common/render/integrator.h"
#include "common/render/render_scene.h"
#include "common/render/sampler.h"
#include "common/scene/effects.h"

namespace lensfarm {

namespace {
constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr int kMaxDepth = 48;  // ends the splitting of records that share one point
}  // namespace

int GuidingField::binOf(const Vec3& wi) const {
  const int kZBins = shape_.zBins, kPhiBins = shape_.phiBins;
  const double zFraction = (double(std::clamp(wi.z, -1.0f, 1.0f)) + 1.0) * 0.5;
  double phi = std::atan2(double(wi.y), double(wi.x));
  if (phi < 0.0) phi += kTwoPi;
  const int iz = std::clamp(int(zFraction * kZBins), 0, kZBins - 1);
  const int iphi = std::clamp(int(phi / kTwoPi * kPhiBins), 0, kPhiBins - 1);
  return iz * kPhiBins + iphi;
}

Vec3 GuidingField::direction(double zFraction, double phiFraction) {
  const double z = std::clamp(2.0 * zFraction - 1.0, -1.0, 1.0);
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = kTwoPi * phiFraction;
  return Vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z));
}

GuidingField GuidingField::learn(const std::vector<Record>& records, const Shape& shape) {
  GuidingField field;
  field.shape_ = shape;
  std::vector<uint32_t> ids;
  ids.reserve(records.size());
  for (uint32_t k = 0; k < records.size(); ++k) {
    const Record& r = records[k];
    if (r.pdf > 0.0f && std::isfinite(r.pdf) && r.luminance >= 0.0f && std::isfinite(r.luminance) &&
        std::isfinite(r.p.x) && std::isfinite(r.p.y) && std::isfinite(r.p.z))
      ids.push_back(k);
  }
  if (ids.empty()) return field;
  std::array<double, 3> lo{}, hi{};
  for (int a = 0; a < 3; ++a) lo[a] = hi[a] = double(records[ids[0]].p[a]);
  for (uint32_t id : ids)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], double(records[id].p[a]));
      hi[a] = std::max(hi[a], double(records[id].p[a]));
    }
  field.lo_ = lo, field.hi_ = hi;
  field.nodes_.emplace_back();
  field.build(0, lo, hi, ids, 0, ids.size(), records, 0);
  return field;
}

void GuidingField::build(int node, std::array<double, 3> lo, std::array<double, 3> hi, std::vector<uint32_t>& ids,
                         size_t begin, size_t end, const std::vector<Record>& records, int depth) {
  if (end - begin > shape_.maxRecordsPerRegion && depth < kMaxDepth) {
    int axis = 0;
    for (int a = 1; a < 3; ++a)
      if (hi[a] - lo[a] > hi[axis] - lo[axis]) axis = a;
    const double split = 0.5 * (lo[axis] + hi[axis]);
    const auto middle = std::stable_partition(ids.begin() + long(begin), ids.begin() + long(end),
                                              [&](uint32_t id) { return double(records[id].p[axis]) < split; });
    const size_t mid = size_t(middle - ids.begin());
    const int child = int(nodes_.size());
    nodes_[size_t(node)] = Node{axis, split, child};
    nodes_.emplace_back();
    nodes_.emplace_back();
    std::array<double, 3> lowerHi = hi, upperLo = lo;
    lowerHi[size_t(axis)] = split, upperLo[size_t(axis)] = split;
    build(child, lo, lowerHi, ids, begin, mid, records, depth + 1);
    build(child + 1, upperLo, hi, ids, mid, end, records, depth + 1);
    return;
  }
  ++leaves_;
  if (end - begin < shape_.minRecordsPerRegion) return;
  const int kBins = shape_.bins();
  // Each bin's share of the radiance arriving at the region: sum(L / p) over its records, an
  // estimate of the integral of L over the bin's directions (times the record count).
  std::vector<double> weight(size_t(kBins), 0.0);
  double total = 0.0;
  for (size_t k = begin; k < end; ++k) {
    const Record& r = records[ids[k]];
    const double w = double(r.luminance) / double(r.pdf);
    weight[size_t(binOf(r.wi))] += w;
    total += w;
  }
  if (!(total > 0.0) || !std::isfinite(total)) return;
  Distribution d;
  d.cdf.resize(size_t(kBins) + 1);
  d.probability.resize(size_t(kBins));
  double running = 0.0;
  d.cdf[0] = 0.0f;
  for (int b = 0; b < kBins; ++b) {
    running += weight[size_t(b)];
    d.cdf[size_t(b) + 1] = float(running / total);
  }
  d.cdf[size_t(kBins)] = 1.0f;
  // Each bin's probability is its width in the float cdf, so sample() draws exactly what pdf() says.
  for (int b = 0; b < kBins; ++b) d.probability[size_t(b)] = d.cdf[size_t(b) + 1] - d.cdf[size_t(b)];
  nodes_[size_t(node)].child = int(distributions_.size());
  distributions_.push_back(std::move(d));
}

int GuidingField::regionAt(const Vec3& p) const {
  if (nodes_.empty()) return -1;
  const double q[3] = {double(p.x), double(p.y), double(p.z)};
  for (int a = 0; a < 3; ++a)
    if (!(q[a] >= lo_[size_t(a)] && q[a] <= hi_[size_t(a)])) return -1;
  const Node* node = &nodes_[0];
  while (node->axis >= 0) node = &nodes_[size_t(node->child + (q[node->axis] >= node->split ? 1 : 0))];
  return node->child;
}

Vec3 GuidingField::sample(int region, Vec2 u) const {
  const int kBins = shape_.bins(), kZBins = shape_.zBins, kPhiBins = shape_.phiBins;
  const Distribution& d = distributions_[size_t(region)];
  // The last bin whose start is at most u.x: it has a positive width (u.x < 1 = cdf[kBins]).
  const auto it = std::upper_bound(d.cdf.begin(), d.cdf.end(), u.x);
  const int b = std::clamp(int(it - d.cdf.begin()) - 1, 0, kBins - 1);
  const float width = d.cdf[size_t(b) + 1] - d.cdf[size_t(b)];
  const double t = width > 0.0f ? std::clamp(double(u.x - d.cdf[size_t(b)]) / double(width), 0.0, 1.0) : 0.5;
  const int iz = b / kPhiBins, iphi = b % kPhiBins;
  return direction((iz + t) / kZBins, (iphi + double(u.y)) / kPhiBins);
}

float GuidingField::pdf(int region, const Vec3& wi) const {
  const Distribution& d = distributions_[size_t(region)];
  return d.probability[size_t(binOf(wi))] * float(shape_.bins() / (4.0 * std::numbers::pi));
}

void GuidingRecorder::finish(const Spectrum& radiance, std::vector<GuidingField::Record>& out) {
  for (const Pending& v : pending) {
    if (!v.settled) continue;
    const Spectrum gathered = radiance - v.radianceBefore;
    Spectrum incident(0.0f);
    for (int c = 0; c < 3; ++c)
      if (v.throughput[c] > 0.0f) incident[c] = gathered[c] / v.throughput[c];
    const float l = luminance(incident);
    if (std::isfinite(l)) out.push_back({v.p, v.wi, v.pdf, std::max(l, 0.0f)});
  }
  pending.clear();
}

namespace {

// One training pass: spp samples at each pixel of an even grid (`stride` apart) of the frame,
// guided by `guide`, recorded in row order of the grid.
std::vector<GuidingField::Record> trainingPass(const RenderScene& rs, const GuidingField* guide, int pass, uint32_t spp,
                                               int stride) {
  const RenderSettings& settings = rs.settings();
  const int width = settings.width, height = settings.height;
  const int columns = (width + stride - 1) / stride, rows = (height + stride - 1) / stride;
  // Streams of their own: another seed per pass, so the image's samples never repeat them.
  const SamplerSetup setup{SamplerKind::kIndependent, settings.seed ^ (0x243f6a8885a308d3ull + uint64_t(pass)), spp, 1};
  std::vector<std::vector<GuidingField::Record>> byRow(static_cast<size_t>(rows));
  tbb::parallel_for(tbb::blocked_range<int>(0, rows, 1), [&](const tbb::blocked_range<int>& range) {
    GuidingRecorder recorder;
    PathStats stats;
    for (int gj = range.begin(); gj < range.end(); ++gj) {
      const int j = std::min(height - 1, gj * stride + stride / 2);
      std::vector<GuidingField::Record>& out = byRow[size_t(gj)];
      for (int gi = 0; gi < columns; ++gi) {
        const int i = std::min(width - 1, gi * stride + stride / 2);
        const uint64_t pixel = uint64_t(j) * uint64_t(width) + uint64_t(i);
        for (uint32_t s = 0; s < spp; ++s) {
          const SampleStream rng(setup, pixel, s);
          CameraSampleLanes c;
          c.count = 1, c.row = j, c.column[0] = i;
          const Vec2 sensor = rng.get2D(dims::kSensor), lens = rng.get2D(dims::kLens);
          c.u0[0] = sensor.x, c.u1[0] = sensor.y, c.lens0[0] = lens.x, c.lens1[0] = lens.y;
          c.wavelengthNm[0] = 550.0;
          for (int k = 1; k < kPacketWidth; ++k)
            c.column[k] = i, c.u0[k] = c.u1[k] = c.lens0[k] = c.lens1[k] = 0.0f, c.wavelengthNm[k] = 550.0;
          CameraRayLanes rays;
          float weight[kPacketWidth];
          rs.camera().sampleRays(c, rays, weight);
          if (!(weight[0] > 0.0f)) continue;
          const Spectrum radiance = traceTrainingPath(rs, rays.ray(0), rng, guide, recorder, stats);
          recorder.finish(radiance, out);
        }
      }
    }
  });
  std::vector<GuidingField::Record> records;
  size_t total = 0;
  for (const auto& row : byRow) total += row.size();
  records.reserve(total);
  for (const auto& row : byRow) records.insert(records.end(), row.begin(), row.end());
  return records;
}

}  // namespace

std::unique_ptr<const GuidingField> trainGuidingField(const RenderScene& rs) {
  const RenderSettings& settings = rs.settings();
  const int stride = guidingTrainingStride(settings.width, settings.height);
  const GuidingField::Shape shape;
  auto field = std::make_unique<GuidingField>();
  for (int pass = 0; pass < kGuidingTrainingPasses; ++pass) {
    // Each pass learns from its own records alone, traced with the field of the pass before
    // (Müller et al. 2017, §5.2): later passes sample better and hold more samples.
    const auto records = trainingPass(rs, pass == 0 ? nullptr : field.get(), pass, 1u << pass, stride);
    *field = GuidingField::learn(records, shape);
  }
  return field;
}

}  // namespace lensfarm
