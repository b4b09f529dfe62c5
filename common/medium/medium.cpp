#include "common/medium/medium.h"

#include <cmath>
#include <limits>

#include "common/medium/vdb_grid.h"
#include "common/util/error.h"
#include "common/util/field_reader.h"

namespace lensfarm {

void Medium::classify() {
  if (const HomogeneousMedium* h = asHomogeneous())
    scatters_ = !isBlack(h->sigmaS());
  else
    scatters_ = !isBlack(asGrid()->sigmaSScale());
}

void Medium::place(const DVec3& origin) {
  const GridMedium* g = asGrid();
  if (!g) return;
  m_ = GridMedium(Vec3(worldLo_ - origin), Vec3(worldHi_ - origin), g->resolution(), g->densities(), g->sigmaAScale(),
                  g->sigmaSScale(), g->phase().g(), g->majorantResolution());
}

const HenyeyGreenstein& Medium::phase() const {
  if (const HomogeneousMedium* h = asHomogeneous()) return h->phase();
  return asGrid()->phase();
}

FreeFlight Medium::sampleFreeFlight(const Vec3& o, const Vec3& dir, float tMax, const Spectrum& throughput,
                                    MediumRng& rng, SpectralMis& mis) const {
  if (const HomogeneousMedium* h = asHomogeneous()) {
    if (!scatters_) {
      FreeFlight pass;
      pass.t = tMax;
      pass.weight = h->transmittance(tMax);
      return pass;
    }
    return h->sampleFreeFlight(tMax, mis.hero, rng(), mis.ratio);
  }
  const GridMedium& g = *asGrid();
  if (!scatters_) {
    FreeFlight pass;
    pass.t = tMax;
    pass.weight = g.ratioTrackingTransmittance(o, dir, tMax, rng);
    return pass;
  }
  return g.sampleFreeFlight(o, dir, tMax, throughput, rng);
}

Spectrum Medium::transmittance(const Vec3& o, const Vec3& dir, float tMax, MediumRng& rng) const {
  if (const HomogeneousMedium* h = asHomogeneous()) return h->transmittance(tMax);
  return asGrid()->ratioTrackingTransmittance(o, dir, tMax, rng);
}

Spectrum readCoefficients(FieldReader& r, const std::string& key, const Spectrum& fallback) {
  if (!r.has(key)) return fallback;
  const json& v = r.raw(key);
  const double big = std::numeric_limits<double>::max();
  if (v.is_number()) return Spectrum(float(r.checkNumber(v, r.field(key), -big, big)));
  if (!v.is_array() || v.size() != 3) r.fail(r.field(key), "must be an array of 3 numbers, or one number for grey");
  Spectrum s;
  for (int c = 0; c < 3; ++c)
    s[c] = float(r.checkNumber(v[c], r.field(key) + "[" + std::to_string(c) + "]", -big, big));
  return s;
}

namespace {

std::shared_ptr<Medium> parseHomogeneous(const std::string& name, FieldReader& r) {
  const float g = float(r.number("g", 0.0, -std::numeric_limits<double>::max(), std::numeric_limits<double>::max()));
  const std::string& file = r.file();
  const std::string where = r.path();
  if (r.has("attenuation_color") || r.has("attenuation_distance")) {
    if (r.has("sigma_a") || r.has("sigma_s"))
      r.fail(r.field("attenuation_color"),
             "give either sigma_a and sigma_s or attenuation_color and "
             "attenuation_distance, not both");
    const Spectrum color = readCoefficients(r, "attenuation_color", Spectrum(1.0f));
    const float distance = float(r.number("attenuation_distance", std::numeric_limits<double>::infinity(),
                                          -std::numeric_limits<double>::max(), std::numeric_limits<double>::max()));
    const Spectrum albedo = readCoefficients(r, "scattering_albedo", Spectrum(0.0f));
    validateAttenuation(color, distance, albedo, g, file, where);
    return std::make_shared<Medium>(name, HomogeneousMedium::fromAttenuation(color, distance, albedo, g));
  }
  if (r.has("scattering_albedo"))
    r.fail(r.field("scattering_albedo"),
           "goes with attenuation_color and attenuation_distance; with sigma_a and "
           "sigma_s the albedo is sigma_s / (sigma_a + sigma_s)");
  const Spectrum sigmaA = readCoefficients(r, "sigma_a", Spectrum(0.0f));
  const Spectrum sigmaS = readCoefficients(r, "sigma_s", Spectrum(0.0f));
  validateHomogeneousMedium(sigmaA, sigmaS, g, file, where);
  return std::make_shared<Medium>(name, HomogeneousMedium(sigmaA, sigmaS, g));
}

std::shared_ptr<Medium> parseGrid(const std::string& name, FieldReader& r, const AssetLoader& load) {
  const float g = float(r.number("g", 0.0, -std::numeric_limits<double>::max(), std::numeric_limits<double>::max()));
  const Spectrum sigmaA = readCoefficients(r, "sigma_a", Spectrum(0.0f));
  const Spectrum sigmaS = readCoefficients(r, "sigma_s", Spectrum(0.0f));
  DenseGrid grid;
  if (r.has("file")) {
    // An OpenVDB file: its grid's box and voxels (medium/vdb_grid.h).
    for (const char* inline_ : {"bounds", "resolution", "density"})
      if (r.has(inline_))
        r.fail(r.field(inline_), "comes from the file: give either file or bounds, resolution and density");
    const LoadedAsset vdb = load(r, "file", "OpenVDB file");
    grid = readVdbGrid(vdb.bytes, r.string("grid", "density"), vdb.shown, r.file(), r.field("file"));
  } else {
    if (r.has("grid")) r.fail(r.field("grid"), "names a grid of an OpenVDB `file`");
    const json& bounds = r.raw("bounds");
    if (!bounds.is_array() || bounds.size() != 2)
      r.fail(r.field("bounds"), "must be [[x0, y0, z0], [x1, y1, z1]], the grid's box in world space");
    grid.lo = r.toDVec3(bounds[0], r.field("bounds") + "[0]");
    grid.hi = r.toDVec3(bounds[1], r.field("bounds") + "[1]");
    const json& res = r.raw("resolution");
    if (!res.is_array() || res.size() != 3) r.fail(r.field("resolution"), "must be [nx, ny, nz], each >= 1");
    for (int a = 0; a < 3; ++a) {
      const std::string at = r.field("resolution") + "[" + std::to_string(a) + "]";
      const double n = r.checkNumber(res[a], at, 1, 4096);
      if (double(int(n)) != n) r.fail(at, "must be a whole number");
      grid.resolution[a] = int(n);
    }
    const json& d = r.raw("density");
    if (!d.is_array()) r.fail(r.field("density"), "must be an array of nx * ny * nz numbers, x fastest");
    grid.density.reserve(d.size());
    for (size_t i = 0; i < d.size(); ++i) {
      if (!d[i].is_number()) r.fail(r.field("density") + "[" + std::to_string(i) + "]", "must be a number");
      grid.density.push_back(float(d[i].get<double>()));
    }
  }
  const DVec3 lo = grid.lo, hi = grid.hi;
  const glm::ivec3 resolution = grid.resolution;
  std::vector<float> density = std::move(grid.density);
  // The box is checked in double, in world space: a small grid far from the origin has lo < hi
  // only there. Until place() moves it to render space the grid sits at the origin.
  for (int a = 0; a < 3; ++a)
    if (!(hi[a] > lo[a]))
      r.fail(r.field(r.has("file") ? "file" : "bounds"), "the grid's box needs lo < hi on every axis");
  const Vec3 size(hi - lo);
  validateGridMedium(Vec3(0.0f), size, resolution, density, sigmaA, sigmaS, g, r.file(), r.path());
  return std::make_shared<Medium>(name, GridMedium(Vec3(0.0f), size, resolution, std::move(density), sigmaA, sigmaS, g),
                                  lo, hi);
}

}  // namespace

std::shared_ptr<Medium> parseMedium(const std::string& name, FieldReader& r, const AssetLoader& load) {
  const std::string type = r.string("type", "homogeneous");
  std::shared_ptr<Medium> m;
  if (type == "homogeneous")
    m = parseHomogeneous(name, r);
  else if (type == "grid")
    m = parseGrid(name, r, load);
  else
    r.fail(r.field("type"), "unknown medium type \"" + type + "\" (expected homogeneous or grid)");
  r.finish();
  return m;
}

}  // namespace lensfarm
