#pragma once
// Counter-based sample values: every value is a pure function of
//     (job seed, pixel, sample index, dimension),
// so a sample traces the same path on any worker, thread count or retry (docs/architecture.md, "Invariants"),
// and no state is carried from one sample or pixel to the next.
//
// Three samplers, chosen per job (render.sampler, docs/scene-format.md; compared in
// docs/accuracy.md):
//  - independent: every value is its own hash. Error falls as 1/sqrt(n).
//  - stratified: the samples of one unit of work (render/unit_renderer.h) are a correlated
//    multi-jittered pattern of that unit's size (Kensler 2013): one sample per row and column
//    stratum in each 2D dimension pair, shuffled independently per pixel and dimension. Units
//    are the only blocks a job is sure to finish whole, so every finished unit is a complete
//    stratified set; the pattern does not refine across units.
//  - sobol (the default): the first two dimensions of the Sobol sequence, Owen-scrambled with a
//    hash-based nested uniform scramble and index shuffle per pixel and dimension pair (Burley
//    2020, "Practical hash-based Owen scrambling"), in two independently scrambled replicates:
//    the even units and the odd units. Every power-of-two prefix of a replicate is stratified in
//    2D, so the image converges faster than 1/sqrt(n) where the integrand is smooth (edges of
//    soft shadows, the pixel footprint), and the two replicates stay independent, which the
//    live error estimate needs (film/convergence.h).
// All three return floats in [0, 1) with 24 random bits.
#include <algorithm>
#include <bit>
#include <cstdint>

#include "common/math/lanes.h"
#include "common/math/vec.h"
#include "common/scene/scene.h"  // SamplerKind

namespace lensfarm {

// Dimension layout of one camera path. Each path segment owns a fixed block of dimensions, so
// adding a lobe or a light never shifts the numbers of another segment. 2D values start at an
// even offset so a sampler can treat (d, d + 1) as one stratified pair.
namespace dims {
inline constexpr uint32_t kSensor = 0;  // 2D: point in the sensor cell
inline constexpr uint32_t kLens = 2;    // 2D: point on the lens disk
inline constexpr uint32_t kFirstSegment = 4;
inline constexpr uint32_t kPerSegment = 8;
inline constexpr uint32_t kLightPoint = 0;    // 2D, within a segment block
inline constexpr uint32_t kMaterial = 2;      // 2D
inline constexpr uint32_t kLightChoice = 4;   // 1D
inline constexpr uint32_t kRoulette = 5;      // 1D: Russian roulette
inline constexpr uint32_t kMaterialLobe = 6;  // 1D: a material's choice of lobe (material/bsdf.h)
inline constexpr uint32_t segment(uint32_t s) { return kFirstSegment + s * kPerSegment; }
// A light path's (render/light_tracer.h; its own streams, keyed by unit and particle): vertex v
// (0 on the light) owns segment(v). On the light: kLightChoice picks the light, kLightPoint the
// point, kEmitDirection (2D) the direction and kMaterialLobe the face of a two-sided light. At a
// later vertex: kLensPoint (2D) the lens point of its camera connection, then kMaterial and
// kMaterialLobe as a camera path's vertex.
inline constexpr uint32_t kEmitDirection = kMaterial;
inline constexpr uint32_t kLensPoint = kLightPoint;
// 1D: a spectral camera sample's wavelength (camera/spectral_response.h; only through a lens that
// disperses). Appended past every segment's block (a path has at most 2050 segments,
// render/integrator.h), so no other dimension moves: images without it keep their bits. Every
// sampler gives it independent values; the bands are stratified by the sample index instead.
inline constexpr uint32_t kWavelength = 0xfffffff0u;
// The key (SampleStream::streamKey) of a volume path's hero channel (render/volume_integrator.h).
inline constexpr uint32_t kHeroChannel = 0xfffffff1u;
}  // namespace dims

// The stratified and Sobol samplers stratify the dimensions where stratification pays: the pixel
// footprint, the lens, and the first vertex's light sample, direction and choices. Deeper
// dimensions see a nearly uniform integrand and take independent values (cheaper, no worse).
inline constexpr uint32_t kStratifiedDimensions = dims::segment(1);

// What a job's samples depend on besides the pixel and index.
struct SamplerSetup {
  SamplerKind kind = SamplerKind::kSobol;
  uint64_t seed = 0;
  uint64_t samplesPerPixel = 1;  // the job's total (stratified: the last unit may be short)
  uint32_t samplesPerUnit = 1;   // stratified: one pattern per unit
};

namespace detail {
// Bit-reversed direction numbers of Sobol dimension 1, XORed over each byte value of an index.
struct SobolTables {
  uint32_t byByte[4][256];
};
constexpr SobolTables makeSobolTables() {
  SobolTables t{};
  uint32_t r[32] = {1u};
  for (int k = 1; k < 32; ++k) r[k] = r[k - 1] ^ (r[k - 1] << 1);
  for (int b = 0; b < 4; ++b)
    for (uint32_t v = 0; v < 256; ++v)
      for (int j = 0; j < 8; ++j)
        if (v >> j & 1u) t.byByte[b][v] ^= r[8 * b + j];
  return t;
}
inline constexpr SobolTables kSobolTables = makeSobolTables();
}  // namespace detail

class SampleStream {
 public:
  SampleStream() = default;  // a placeholder, to be assigned before use (packet lanes)
  SampleStream(const SamplerSetup& setup, uint64_t pixel, uint64_t sampleIndex)
      : kind_(setup.kind),
        pixelKey_(mix(mix(setup.seed ^ 0x6a09e667f3bcc909ull) ^ pixel)),
        key_(mix(pixelKey_ ^ (sampleIndex * 0x9e3779b97f4a7c15ull))),
        index_(sampleIndex) {
    if (kind_ == SamplerKind::kSobol) {
      // Two independently scrambled replicates, even units and odd units, each its own
      // progressive Sobol sequence (randomised QMC with two replicates): the live error estimate
      // compares exactly these two halves (film/convergence.h), and for it to be unbiased they
      // must be independent.
      const uint64_t unit = sampleIndex / setup.samplesPerUnit;
      index_ = (unit >> 1) * setup.samplesPerUnit + sampleIndex % setup.samplesPerUnit;
      pixelKey_ = mix(pixelKey_ ^ ((unit & 1) * 0xa0761d6478bd642full));
    } else if (kind_ == SamplerKind::kStratified) {
      const uint64_t block = sampleIndex / setup.samplesPerUnit;
      const uint64_t first = block * setup.samplesPerUnit;
      local_ = uint32_t(sampleIndex - first);
      // (Adaptive units trace past the job's samples per pixel, in whole patterns.)
      blockSize_ = uint32_t(first >= setup.samplesPerPixel
                                ? setup.samplesPerUnit
                                : std::min<uint64_t>(setup.samplesPerUnit, setup.samplesPerPixel - first));
      pixelKey_ = mix(pixelKey_ ^ (block * 0xd6e8feb86659fd93ull));
    }
  }

  // A key unique to this stream's pixel and sample (and job seed), for counter-based streams of a
  // varying length keyed by it (medium/medium.h, MediumRng).
  uint64_t key() const { return key_; }
  // The key of such a stream for `dimension` (e.g. a path segment's).
  uint64_t streamKey(uint32_t dimension) const { return mix(key_ ^ (uint64_t(dimension) * 0xd1b54a32d192ed03ull)); }

  float get1D(uint32_t dimension) const {
    switch (kind_) {
      case SamplerKind::kSobol: {
        if (dimension >= kStratifiedDimensions) return independent(dimension);
        return sobolFirst(pixelKey_, sobolIndex(), dimension);
      }
      case SamplerKind::kStratified: {
        if (dimension >= kStratifiedDimensions) return independent(dimension);
        const uint32_t seed = dimensionSeed(dimension);
        const uint32_t stratum = permute(local_, blockSize_, seed);
        return (float(stratum) + jitter(seed ^ 0x967a889bu)) / float(blockSize_);
      }
      case SamplerKind::kIndependent: return independent(dimension);
    }
    return independent(dimension);
  }

  Vec2 get2D(uint32_t dimension) const {
    switch (kind_) {
      case SamplerKind::kSobol: {
        if (dimension >= kStratifiedDimensions) return Vec2(independent(dimension), independent(dimension + 1));
        return sobolPair(pixelKey_, sobolIndex(), dimension);
      }
      case SamplerKind::kStratified:
        if (dimension >= kStratifiedDimensions) return Vec2(independent(dimension), independent(dimension + 1));
        return correlatedMultiJitter(dimensionSeed(dimension));
      case SamplerKind::kIndependent: return Vec2(independent(dimension), independent(dimension + 1));
    }
    return Vec2(independent(dimension), independent(dimension + 1));
  }

  // The streams of a packet's lanes, for the lane forms below. `sobol`: lane 0's stream (and so
  // every lane in use: one job, one sampler) is a Sobol stream.
  struct LaneKeys {
    alignas(64) uint64_t key[kPacketWidth];
    alignas(64) uint64_t pixelKey[kPacketWidth];
    alignas(64) uint32_t index[kPacketWidth];
    bool sobol = false;
  };
  static LaneKeys keysOf(const SampleStream (&streams)[kPacketWidth]) {
    LaneKeys keys;
    for (int k = 0; k < kPacketWidth; ++k) {
      keys.key[k] = streams[k].key_;
      keys.pixelKey[k] = streams[k].pixelKey_;
      keys.index[k] = streams[k].sobolIndex();
    }
    keys.sobol = streams[0].kind_ == SamplerKind::kSobol;
    return keys;
  }
  // Whether the lane forms can give this dimension: the independent values every sampler takes
  // beyond kStratifiedDimensions, and the Sobol sampler's below.
  static bool hasLaneForm(const LaneKeys& keys, uint32_t dimension) {
    return dimension >= kStratifiedDimensions || keys.sobol;
  }
  // get1D(dimension) and get2D(dimension) of every lane's stream at once, where hasLaneForm:
  // one vector loop each (math/lanes.h), streams[k]'s values bit for bit (sampler.cpp).
  static void lanes1D(const LaneKeys& keys, uint32_t dimension, float (&values)[kPacketWidth]);
  static void lanes2D(const LaneKeys& keys, uint32_t dimension, float (&x)[kPacketWidth], float (&y)[kPacketWidth]);
  // get1D(dimension) and get2D(dimension) of streams[0, count): the lane form where there is one,
  // else stream by stream.
  static void values1D(const SampleStream (&streams)[kPacketWidth], const LaneKeys& keys, int count, uint32_t dimension,
                       float (&values)[kPacketWidth]) {
    if (hasLaneForm(keys, dimension)) {
      lanes1D(keys, dimension, values);
      return;
    }
    for (int k = 0; k < count; ++k) values[k] = streams[k].get1D(dimension);
  }
  static void values2D(const SampleStream (&streams)[kPacketWidth], const LaneKeys& keys, int count, uint32_t dimension,
                       float (&x)[kPacketWidth], float (&y)[kPacketWidth]) {
    if (hasLaneForm(keys, dimension)) {
      lanes2D(keys, dimension, x, y);
      return;
    }
    for (int k = 0; k < count; ++k) {
      const Vec2 v = streams[k].get2D(dimension);
      x[k] = v.x, y[k] = v.y;
    }
  }

  // The Sobol sampler's values of `dimension` (below kStratifiedDimensions), for a stream with
  // these keys. Owen scrambling of a Sobol coordinate works on its bit-reversed form, which for
  // the first dimension is the (shuffled) index itself.
  static float sobolFirst(uint64_t pixelKey, uint32_t index, uint32_t dimension) {
    const uint32_t seed = dimensionSeedOf(pixelKey, dimension);
    return sobolDimension0(owenScramble(index, seed), seed);
  }
  static Vec2 sobolPair(uint64_t pixelKey, uint32_t index, uint32_t dimension) {
    const uint32_t seed = dimensionSeedOf(pixelKey, dimension);
    const uint32_t i = owenScramble(index, seed);
    return Vec2(sobolDimension0(i, seed),
                toFloat(reverseBits(laineKarras(reversedSobolDimension1(i), seed * 0x02e5be93u + 3u))));
  }
  // The first coordinate of a pair for the scrambled index i: Sobol's first dimension is the
  // index bit-reversed, so its own scrambling works on i itself.
  static float sobolDimension0(uint32_t i, uint32_t seed) {
    return toFloat(reverseBits(laineKarras(i, seed * 0x68bc21ebu + 1u)));
  }

  static uint32_t reverseBits(uint32_t x) {
    x = (x << 16) | (x >> 16);
    x = ((x & 0x00ff00ffu) << 8) | ((x & 0xff00ff00u) >> 8);
    x = ((x & 0x0f0f0f0fu) << 4) | ((x & 0xf0f0f0f0u) >> 4);
    x = ((x & 0x33333333u) << 2) | ((x & 0xccccccccu) >> 2);
    return ((x & 0x55555555u) << 1) | ((x & 0xaaaaaaaau) >> 1);
  }

  static uint64_t mix(uint64_t z) {  // the SplitMix64 finaliser
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }

  // The second dimension of the Sobol sequence (primitive polynomial x + 1), bit-reversed:
  // direction numbers v_1 = 2^31, v_k = v_(k-1) xor (v_(k-1) >> 1) reversed are r_1 = 1,
  // r_k = r_(k-1) xor (r_(k-1) << 1), combined over the set bits of the index, a byte at a time.
  static uint32_t reversedSobolDimension1(uint32_t index) {
    return detail::kSobolTables.byByte[0][index & 0xffu] ^ detail::kSobolTables.byByte[1][(index >> 8) & 0xffu] ^
           detail::kSobolTables.byByte[2][(index >> 16) & 0xffu] ^ detail::kSobolTables.byByte[3][index >> 24];
  }

  // A hash in which every bit changes only itself and higher bits, a bijection for any seed
  // (Laine and Karras 2011; constants after Vegdahl 2021). On a bit-reversed value it flips every
  // digit depending on the digits above it, as Owen's random tree of permutations does.
  static uint32_t laineKarras(uint32_t x, uint32_t seed) {
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
  }
  // Nested uniform (Owen) scrambling of a 32-bit fixed-point value in [0, 1).
  static uint32_t owenScramble(uint32_t x, uint32_t seed) { return reverseBits(laineKarras(reverseBits(x), seed)); }

  // The value of `dimension` for a stream whose sample key is `key` (independent values).
  static float independentValue(uint64_t key, uint32_t dimension) {
    // The top 24 bits, converted from a 32-bit integer (exact either way; vector units convert
    // 32-bit integers, not 64-bit ones).
    return float(int32_t(mix(key ^ (uint64_t(dimension) * 0xd1b54a32d192ed03ull + 0x8cb92ba72f3d8dd7ull)) >> 40)) *
           0x1.0p-24f;
  }

 private:
  float independent(uint32_t dimension) const { return independentValue(key_, dimension); }
  // The top 24 bits in [0, 1), converted from a 32-bit signed integer (exact; vector units
  // convert signed 32-bit integers).
  static float toFloat(uint32_t x) { return float(int32_t(x >> 8)) * 0x1.0p-24f; }

  // A 32-bit seed per (pixel, dimension): decorrelates the padded dimension pairs.
  static uint32_t dimensionSeedOf(uint64_t pixelKey, uint32_t dimension) {
    return uint32_t(mix(pixelKey ^ (uint64_t(dimension >> 1) * 0xd1b54a32d192ed03ull + 0x8cb92ba72f3d8dd7ull)));
  }
  uint32_t dimensionSeed(uint32_t dimension) const { return dimensionSeedOf(pixelKey_, dimension); }
  // The sample index folded to 32 bits; Owen-scrambled with a dimension pair's seed it is a
  // random order of the sequence per pixel and dimension pair in which every power-of-two prefix
  // is still an aligned power-of-two block (a net).
  uint32_t sobolIndex() const { return uint32_t(index_) ^ uint32_t(index_ >> 32); }

  float jitter(uint32_t seed) const { return toFloat(uint32_t(mix(pixelKey_ ^ (uint64_t(seed) << 32 | local_)))); }

  // A random permutation of [0, n), evaluated at i: a bijective hash on the next power of two,
  // applied until the value falls below n (cycle walking; Kensler 2013).
  static uint32_t permute(uint32_t i, uint32_t n, uint32_t seed) {
    if (n <= 1) return 0;
    const uint32_t mask = std::bit_ceil(n) - 1;
    do {
      i ^= seed;
      i *= 0xe170893du;
      i ^= seed >> 16;
      i ^= (i & mask) >> 4;
      i ^= seed >> 8;
      i *= 0x0929eb3fu;
      i ^= seed >> 23;
      i ^= (i & mask) >> 1;
      i *= 1u | seed >> 27;
      i *= 0x6935fa69u;
      i ^= (i & mask) >> 11;
      i *= 0x74dcb303u;
      i ^= (i & mask) >> 2;
      i *= 0x9e501cc3u;
      i ^= (i & mask) >> 2;
      i *= 0xc860a3dfu;
      i &= mask;
      i ^= i >> 5;
    } while (i >= n);
    return (i + seed) % n;
  }

  // Correlated multi-jittered sample `local_` of a block of `blockSize_` (Kensler 2013): an
  // m x n grid with m ~ sqrt(N); each sample is alone in its grid column, its row, and in its
  // 1/N-wide slab of both axes.
  Vec2 correlatedMultiJitter(uint32_t seed) const {
    const uint32_t count = blockSize_;
    uint32_t m = 1;
    while ((m + 1) * (m + 1) <= count) ++m;
    const uint32_t n = (count + m - 1) / m;
    const uint32_t s = permute(local_, count, seed * 0x51633e2du);
    const uint32_t sx = permute(s % m, m, seed * 0x68bc21ebu);
    const uint32_t sy = permute(s / m, n, seed * 0x02e5be93u);
    const float jx = jitter(seed * 0x967a889bu), jy = jitter(seed * 0x368cc8b7u);
    const float x = (float(sx) + (float(sy) + jx) / float(n)) / float(m);
    const float y = (float(s) + jy) / float(count);
    return Vec2(std::min(x, 0x1.fffffep-1f), std::min(y, 0x1.fffffep-1f));
  }

  SamplerKind kind_ = SamplerKind::kIndependent;
  uint64_t pixelKey_ = 0;
  uint64_t key_ = 0;
  uint64_t index_ = 0;
  uint32_t local_ = 0, blockSize_ = 1;  // stratified: position in the unit's pattern, its size
};

}  // namespace lensfarm
