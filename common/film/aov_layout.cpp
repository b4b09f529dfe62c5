#include "common/film/aov_layout.h"

#include <algorithm>
#include <limits>

namespace lensfarm {

namespace {
constexpr const char* kNames[kAovCount] = {"albedo",  "normal",    "depth",      "variance",
                                           "samples", "object_id", "material_id"};

std::string trimmed(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t");
  if (a == std::string::npos) return "";
  return s.substr(a, s.find_last_not_of(" \t") - a + 1);
}
}  // namespace

const char* aovName(Aov a) { return kNames[int(a)]; }

bool parseAovList(const std::string& text, AovSet& out, std::string* bad) {
  AovSet set;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    const std::string name = trimmed(text.substr(start, comma - start));
    start = comma + 1;
    if (name.empty() && text.find_first_not_of(" \t,") == std::string::npos) break;  // "" or only commas: none
    bool known = false;
    for (int k = 0; k < kAovCount; ++k)
      if (name == kNames[k]) {
        set.add(Aov(k));
        known = true;
      }
    if (!known) {
      if (bad) *bad = name;
      return false;
    }
  }
  out = set;
  return true;
}

std::string aovListText(AovSet set) {
  std::string text;
  for (int k = 0; k < kAovCount; ++k)
    if (set.has(Aov(k))) text += (text.empty() ? "" : ",") + std::string(kNames[k]);
  return text;
}

std::string aovNames() {
  std::string text;
  for (int k = 0; k < kAovCount; ++k) text += (k ? ", " : "") + std::string(kNames[k]);
  return text;
}

AovLayout::AovLayout(AovSet s) : set(s) {
  const auto take = [&](Aov a, int n) {
    if (!s.has(a)) return -1;
    const int at = channels;
    channels += n;
    return at;
  };
  albedo = take(Aov::kAlbedo, 3);
  normal = take(Aov::kNormal, 3);
  depth = take(Aov::kDepth, 2);
  variance = take(Aov::kVariance, 3);
  objectId = take(Aov::kObjectId, 1);
  materialId = take(Aov::kMaterialId, 1);
}

void aovSumRange(const AovLayout& layout, int channel, uint32_t n, double& lo, double& hi) {
  const double most = double(n) * double(std::numeric_limits<float>::max());
  const auto in = [&](int at, int count) { return at >= 0 && channel >= at && channel < at + count; };
  lo = 0.0;
  hi = most;
  if (in(layout.normal, 3)) {
    lo = -double(n) * 1.001;
    hi = double(n) * 1.001;
  } else if (in(layout.depth, 1)) {
    lo = -most;
  } else if (layout.depth >= 0 && in(layout.depth + 1, 1)) {
    hi = double(n);
  } else if (in(layout.variance, 3)) {
    hi = most * double(std::numeric_limits<float>::max());
  } else if (in(layout.objectId, 1) || in(layout.materialId, 1)) {
    hi = 4294967296.0;
  }
}

std::vector<ImageLayer> aovLayers(const AovLayout& layout, int width, int height) {
  std::vector<ImageLayer> layers;
  const size_t pixels = size_t(width) * size_t(height);
  const auto add = [&](Aov a, const char* name, std::vector<std::string> channels) {
    if (!layout.set.has(a)) return;
    const size_t n = channels.size();
    layers.push_back(ImageLayer{name, std::move(channels), std::vector<float>(pixels * n, 0.0f)});
  };
  // In the order developAovPixel writes them.
  add(Aov::kAlbedo, "albedo", {"R", "G", "B"});
  add(Aov::kNormal, "normal", {"X", "Y", "Z"});
  add(Aov::kDepth, "", {"Z"});
  add(Aov::kVariance, "variance", {"R", "G", "B"});
  add(Aov::kSamples, "samples", {"count"});
  add(Aov::kObjectId, "object_id", {"id"});
  add(Aov::kMaterialId, "material_id", {"id"});
  return layers;
}

void developAovPixel(const AovLayout& layout, const double* sums, uint64_t n, size_t pixel,
                     std::vector<ImageLayer>& layers) {
  const double inv = n > 0 ? 1.0 / double(n) : 0.0;
  size_t layer = 0;
  const auto put = [&](std::initializer_list<double> values) {
    float* out = layers[layer++].values.data() + pixel * values.size();
    for (double v : values) *out++ = float(v);
  };
  if (layout.albedo >= 0) {
    const double* a = sums + layout.albedo;
    put({a[0] * inv, a[1] * inv, a[2] * inv});
  }
  if (layout.normal >= 0) {
    const double* v = sums + layout.normal;
    put({v[0] * inv, v[1] * inv, v[2] * inv});
  }
  if (layout.depth >= 0) {
    const double hits = sums[layout.depth + 1];
    put({hits > 0.0 ? sums[layout.depth] / hits : std::numeric_limits<double>::infinity()});
  }
  if (layout.variance >= 0) {
    // The variance of the mean of n samples: the sample variance (S2 - S1^2 / n) / (n - 1), over n.
    // Clamped at 0 where rounding makes the difference of two near-equal sums negative.
    double v[3] = {0.0, 0.0, 0.0};
    if (n >= 2)
      for (int c = 0; c < 3; ++c) {
        const double s1 = sums[c], s2 = sums[layout.variance + c];
        v[c] = std::max(0.0, (s2 - s1 * s1 * inv) / (double(n - 1) * double(n)));
      }
    put({v[0], v[1], v[2]});
  }
  if (layout.set.has(Aov::kSamples)) put({double(n)});
  if (layout.objectId >= 0) put({sums[layout.objectId]});
  if (layout.materialId >= 0) put({sums[layout.materialId]});
}

}  // namespace lensfarm
