#pragma once
// Arbitrary output variables (AOVs, docs/aovs.md): what a render writes beside the beauty, as
// named EXR layers (film/image.h). Conventions, written once here and in docs/aovs.md:
//  - albedo: the directional albedo rho(wo) = integral of f(wo, wi) |cos theta_i| dwi at the
//    camera path's first non-specular hit (exactly the albedo for a Lambertian surface; for other
//    models the mean weight of a fixed 4 x 4 x 16 stratified set of BSDF samples, deterministic),
//    times the weights of the delta lobes followed to reach it (a mirror's reflection, glass's
//    transmission, or its reflection at total internal reflection); 0 where the camera ray leaves
//    the scene or ends on a surface that does not reflect.
//  - normal: the world-space shading normal there, on the side the ray arrives from.
//  - depth (EXR "Z"): planar depth of the first hit, dot(p - camera position, optical axis), in
//    scene units; +inf for a pixel none of whose samples hit anything.
//  - variance: of the pixel's mean, per channel, from the sums of squared sample radiance.
//  - samples: the pixel's sample count.
//  - object_id / material_id: 1 + the index of the object (a mesh of the loaded scene in load
//    order, then the instances) / of the material (Scene::materials: the file's named materials
//    alphabetically, then the models') that sample 0 of the pixel hits first; 0: none.
//
// Sensor layout: every AOV is a set of extra doubles per sensor cell, summed sample by sample and
// unit by unit exactly like the beauty (a SensorBuffer of AovLayout::channels doubles a cell:
// beauty RGB first). Ids are added by sample 0 alone, so their sum is the id. Nothing here runs
// for a scene that asks for no AOV: the pixel loop checks one flag per packet.
#include <cstdint>
#include <string>
#include <vector>

#include "common/film/image.h"

namespace lensfarm {

enum class Aov : uint8_t { kAlbedo, kNormal, kDepth, kVariance, kSamples, kObjectId, kMaterialId };
inline constexpr int kAovCount = 7;

// A set of AOVs (a bit per Aov), in the canonical order above whatever order they were asked in.
struct AovSet {
  uint32_t bits = 0;
  bool has(Aov a) const { return (bits >> unsigned(a)) & 1u; }
  void add(Aov a) { bits |= 1u << unsigned(a); }
  bool empty() const { return bits == 0; }
  bool operator==(const AovSet& o) const { return bits == o.bits; }
  bool operator!=(const AovSet& o) const { return bits != o.bits; }
};

const char* aovName(Aov a);
// "albedo,normal,depth" (commas, optional spaces) into a set; false with `bad` set to the first
// unknown name. An empty text is the empty set.
bool parseAovList(const std::string& text, AovSet& out, std::string* bad);
// The set as text, in canonical order ("" for none): what parseAovList reads back.
std::string aovListText(AovSet set);
// Every name, for messages: "albedo, normal, depth, variance, samples, object_id, material_id".
std::string aovNames();

// Where each AOV's sums sit in a sensor cell; -1 for an AOV not asked for.
struct AovLayout {
  AovLayout() = default;
  explicit AovLayout(AovSet set);
  AovSet set;
  int channels = 3;  // doubles per cell, beauty RGB at 0..2
  int albedo = -1, normal = -1, depth = -1, variance = -1, objectId = -1, materialId = -1;
  // depth: [sum of depths, number of samples that hit]
  bool any() const { return channels > 3 || set.has(Aov::kSamples); }
  // Floats a pixel of the developed layers holds (aovLayers).
  int layerChannels() const {
    return (albedo >= 0 ? 3 : 0) + (normal >= 0 ? 3 : 0) + (depth >= 0 ? 1 : 0) + (variance >= 0 ? 3 : 0) +
           (set.has(Aov::kSamples) ? 1 : 0) + (objectId >= 0 ? 1 : 0) + (materialId >= 0 ? 1 : 0);
  }
  // Whether a camera-ray pass is needed (albedo, normal, depth or ids).
  bool geometric() const { return albedo >= 0 || normal >= 0 || depth >= 0 || objectId >= 0 || materialId >= 0; }
};

// The values sum `channel` (0..2: the beauty) of a cell can hold after n samples from the renderer
// (docs/farm.md, "Threat model"): [lo, hi]. Beauty, albedo: [0, n FLT_MAX]; normal: [-n, n] (unit
// vectors, with rounding room); depth: finite sums, hit counts in [0, n]; squares: [0, n FLT_MAX^2];
// ids: [0, 2^32] (one sample carries them).
void aovSumRange(const AovLayout& layout, int channel, uint32_t n, double& lo, double& hi);

// The layers the set asks for, named and sized for a width x height image, zero-filled.
std::vector<ImageLayer> aovLayers(const AovLayout& layout, int width, int height);
// Develops one pixel: `sums` (layout.channels doubles, beauty first) summed over n samples, into
// pixel `pixel` (row-major index) of the layers aovLayers made.
void developAovPixel(const AovLayout& layout, const double* sums, uint64_t n, size_t pixel,
                     std::vector<ImageLayer>& layers);

}  // namespace lensfarm
