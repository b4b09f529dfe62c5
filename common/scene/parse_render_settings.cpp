// The render settings: the scene's `render` (SceneParser::parseRender), their limits
// (validateRenderSettings), the samples of a unit of work, and the names of their choices.
#include <algorithm>
#include <bit>
#include <initializer_list>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "common/scene/scene_parser.h"
#include "common/scene/tile_size.h"
#include "common/util/error.h"
#include "common/util/field_reader.h"

namespace lensfarm {

void SceneParser::parseResolution(FieldReader& r) {
  RenderSettings& s = scene_.render;
  const json& res = r.raw("resolution");
  if (!res.is_array() || res.size() != 2 || !res[0].is_number_integer() || !res[1].is_number_integer())
    r.fail("render.resolution", "must be [width, height] in pixels");
  const int64_t w = res[0].get<int64_t>(), h = res[1].get<int64_t>();
  if (w < 1 || h < 1 || w > kMaxResolution || h > kMaxResolution)
    r.fail("render.resolution", "each side must be in [1, " + std::to_string(kMaxResolution) + "]");
  s.width = int(w);
  s.height = int(h);
}

namespace {
// A render setting named by one of `modes` (the first is the default), or one error naming
// render.<field> and listing them.
template <typename Mode>
Mode modeOf(FieldReader& r, const char* field, std::initializer_list<std::pair<const char*, Mode>> modes) {
  const std::string mode = r.string(field, modes.begin()->first);
  std::string expected;
  size_t k = 0;
  for (const auto& [name, value] : modes) {
    if (mode == name) return value;
    expected += (k == 0 ? "" : k + 1 == modes.size() ? " or " : ", ") + std::string(name);
    ++k;
  }
  r.fail(std::string("render.") + field, "unknown mode \"" + mode + "\" (expected " + expected + ")");
  return modes.begin()->second;
}

// "auto", "on" or "off" (default auto).
template <typename Mode>
Mode autoOnOff(FieldReader& r, const char* field) {
  return modeOf<Mode>(r, field, {{"auto", Mode::kAuto}, {"on", Mode::kOn}, {"off", Mode::kOff}});
}
}  // namespace

void SceneParser::parseIntegratorSettings(FieldReader& r) {
  RenderSettings& s = scene_.render;
  const std::string integrator = r.string("integrator", "nee_mis");
  if (!parseIntegratorName(integrator, s.integrator))
    r.fail("render.integrator", "unknown integrator \"" + integrator + "\" (expected nee_mis, nee or naive)");
  const std::string sampler = r.string("sampler", "sobol");
  if (!parseSamplerName(sampler, s.sampler))
    r.fail("render.sampler", "unknown sampler \"" + sampler + "\" (expected sobol, stratified or independent)");
  if (r.has("russian_roulette")) {
    // A bool, as in the older form (true: the max-throughput rule), or a rule's name.
    const json& rr = r.raw("russian_roulette");
    if (rr.is_boolean())
      s.roulette = rr.get<bool>() ? RouletteRule::kMax : RouletteRule::kOff;
    else if (!rr.is_string() || !parseRouletteName(rr.get<std::string>(), s.roulette))
      r.fail("render.russian_roulette", "must be \"off\", \"max\", \"throughput\", true or false, got " + rr.dump());
  }
  s.rouletteMinBounces = int(r.integer("roulette_min_bounces", 1, 0, kMaxBounces));
  s.lightTracing = autoOnOff<LightTracingMode>(r, "light_tracing");
  s.lightTracingRatio = r.number("light_tracing_ratio", 0.25, 1e-6, 64.0);
  s.lightTree = autoOnOff<LightTreeMode>(r, "light_tree");
  s.pathGuiding = autoOnOff<PathGuidingMode>(r, "path_guiding");
  s.mediumLightSampling = modeOf<MediumLightSampling>(r, "medium_light_sampling",
                                                      {{"auto", MediumLightSampling::kAuto},
                                                       {"equiangular", MediumLightSampling::kEquiangular},
                                                       {"distance", MediumLightSampling::kDistance}});
  s.triangleLightSampling = modeOf<TriangleLightSampling>(r, "triangle_light_sampling",
                                                          {{"auto", TriangleLightSampling::kAuto},
                                                           {"area", TriangleLightSampling::kArea},
                                                           {"solid_angle", TriangleLightSampling::kSolidAngle}});
}

void SceneParser::parseAovs(FieldReader& r) {
  RenderSettings& s = scene_.render;
  // A list of names (or one comma-separated string), docs/aovs.md.
  const json& list = r.raw("aovs");
  std::string text;
  if (list.is_string()) {
    text = list.get<std::string>();
  } else if (list.is_array()) {
    for (const json& name : list) {
      if (!name.is_string()) r.fail("render.aovs", "must be a list of AOV names, got " + name.dump() + " in it");
      text += (text.empty() ? "" : ",") + name.get<std::string>();
    }
  } else {
    r.fail("render.aovs", "must be a list of AOV names (" + aovNames() + "), got " + list.dump());
  }
  std::string bad;
  if (!parseAovList(text, s.aovs, &bad))
    r.fail("render.aovs", "unknown AOV \"" + bad + "\" (expected " + aovNames() + ")");
}

void SceneParser::parseAdaptive(FieldReader& r) {
  RenderSettings& s = scene_.render;
  const json& a = r.raw("adaptive");
  if (a.is_boolean()) {
    s.adaptive.enabled = a.get<bool>();
  } else if (a.is_object()) {
    FieldReader ar(a, "render.adaptive", fileName_);
    s.adaptive.enabled = true;
    s.adaptive.uniform = ar.number("uniform", s.adaptive.uniform, 1e-6, 1.0);
    s.adaptive.blockEdge = int(ar.integer("block", 0, 1, kMaxResolution));
    s.adaptive.floor = ar.number("floor", s.adaptive.floor, 1e-6, 1.0);
    ar.finish();
  } else {
    r.fail("render.adaptive", "must be true, false or an object {uniform, block, floor}, got " + a.dump());
  }
}

void SceneParser::parseExposure(FieldReader& r) {
  RenderSettings& s = scene_.render;
  FieldReader e(r.raw("exposure"), "render.exposure", fileName_);
  s.exposure.ev = e.number("ev", 0.0, -kMaxExposureEv, kMaxExposureEv);
  const std::string tm = e.string("tone_map", "reinhard");
  if (tm == "reinhard")
    s.exposure.toneMap = ToneMap::kReinhard;
  else if (tm == "clamp")
    s.exposure.toneMap = ToneMap::kClamp;
  else
    e.fail("render.exposure.tone_map", "unknown tone map \"" + tm + "\" (expected reinhard or clamp)");
  const std::string meter = e.string("meter", "lit");
  if (meter == "lit")
    s.exposure.meter = ExposureMeter::kLit;
  else if (meter == "mean")
    s.exposure.meter = ExposureMeter::kMean;
  else if (meter == "fixed")
    s.exposure.meter = ExposureMeter::kFixed;
  else
    e.fail("render.exposure.meter", "unknown meter \"" + meter + "\" (expected lit, mean or fixed)");
  e.finish();
}

void SceneParser::parseRender(FieldReader& top) {
  FieldReader r(top.raw("render"), "render", fileName_);
  RenderSettings& s = scene_.render;
  parseResolution(r);
  s.samplesPerPixel = r.integer("samples_per_pixel", 1, kMaxSamplesPerPixel);
  s.maxBounces = int(r.integer("max_bounces", 2, 0, kMaxBounces));
  s.maxMediumBounces = int(r.integer("max_medium_bounces", 256, 0, kMaxMediumBounces));
  s.seed = r.integer("seed", 0, 0, std::numeric_limits<uint64_t>::max());
  parseIntegratorSettings(r);
  if (r.has("aovs")) parseAovs(r);
  s.targetError = r.number("target_error", 0.0, 0.0, 0.999);
  s.timeLimitSeconds = r.number("time_limit", 0.0, 0.0, 1e9);
  s.mirrorBouncesCount = r.boolean("mirror_bounces_count", false);
  s.samplesPerUnit = uint32_t(r.integer("samples_per_unit", 0, 0, 1u << 20));
  if (r.has("tile_size")) {
    const json& t = r.raw("tile_size");
    const std::optional<int> code = tileSizeFromJson(t);
    if (!code) r.fail("render.tile_size", "must be " + tileSizeForms() + ", got " + t.dump());
    s.tileSize = *code;
  }
  if (r.has("adaptive")) parseAdaptive(r);
  if (r.has("exposure")) parseExposure(r);
  r.finish();
}

uint32_t unitSize(const RenderSettings& s) {
  if (s.samplesPerUnit > 0) return s.samplesPerUnit;
  const uint64_t pixels = std::max<uint64_t>(1, uint64_t(s.width) * uint64_t(s.height));
  if (s.convergenceDriven()) {
    // Small units, a power of two so that each is a whole net of the Sobol sampler: the stop
    // lands close to the target, and a deadline wastes little.
    const uint64_t fit = std::clamp<uint64_t>(kAutoUnitPaths / 4 / pixels, 1, kMaxConvergenceUnitSamples);
    return uint32_t(std::min<uint64_t>(std::bit_floor(fit), std::max<uint64_t>(1, s.samplesPerPixel)));
  }
  if (s.adaptive.enabled) {
    // Sixteen passes or more (farm/job_layout.h: a quarter uniform, then rounds), each a power
    // of two of at most kMaxConvergenceUnitSamples.
    const uint64_t fit = std::clamp<uint64_t>(std::min<uint64_t>(kAutoUnitPaths / 4 / pixels, s.samplesPerPixel / 16),
                                              1, kMaxConvergenceUnitSamples);
    return uint32_t(std::bit_floor(fit));
  }
  const uint64_t perUnit =
      std::clamp<uint64_t>((kAutoUnitPaths + pixels - 1) / pixels, 1, std::max<uint64_t>(1, s.samplesPerPixel));
  return uint32_t(std::min<uint64_t>(perUnit, 1u << 20));
}

void validateRenderSettings(const RenderSettings& s, const std::string& where) {
  if (s.width < 1 || s.height < 1 || s.width > kMaxResolution || s.height > kMaxResolution)
    throw InputError(where, "resolution: each side must be in [1, " + std::to_string(kMaxResolution) + "]");
  if (s.samplesPerPixel < 1 || s.samplesPerPixel > kMaxSamplesPerPixel)
    throw InputError(where, "samples_per_pixel: must be in [1, " + std::to_string(kMaxSamplesPerPixel) + "]");
  if (s.maxBounces < 0 || s.maxBounces > kMaxBounces)
    throw InputError(where, "max_bounces: must be in [0, " + std::to_string(kMaxBounces) + "]");
  if (!(s.targetError >= 0.0 && s.targetError < 1.0))
    throw InputError(where, "target_error: must be a relative RMSE in (0, 1), e.g. 0.01");
  if (!(s.timeLimitSeconds >= 0.0 && s.timeLimitSeconds <= 1e9))
    throw InputError(where, "time_limit: must be in [0, 1e9] seconds");
  if (s.tileSize < RenderSettings::kTilesOff) {
    throw InputError(where,
                     "tile_size: must be \"auto\", \"off\" or at least 1 pixel, got " + std::to_string(s.tileSize));
  } else if (s.tileSize > std::max(s.width, s.height)) {
    throw InputError(where, "tile_size: " + std::to_string(s.tileSize) + " is larger than the " +
                                std::to_string(s.width) + "x" + std::to_string(s.height) + " frame");
  }
  if (s.adaptive.enabled) {
    if (s.tileSize > 0)
      throw InputError(where,
                       "adaptive: adaptive sampling follows the error over the whole frame in passes; give "
                       "tile_size \"off\" or \"auto\"");
    if (s.lightTracing == LightTracingMode::kOn)
      throw InputError(where,
                       "adaptive: light paths splat over the whole frame at one sample count; adaptive "
                       "sampling gives blocks their own counts: give light_tracing \"auto\" or \"off\"");
    if (!(s.adaptive.uniform > 0.0 && s.adaptive.uniform <= 1.0) ||
        !(s.adaptive.floor > 0.0 && s.adaptive.floor <= 1.0))
      throw InputError(where, "adaptive: uniform and floor must be fractions in (0, 1]");
    if (s.adaptive.blockEdge < 0 || s.adaptive.blockEdge > std::max(s.width, s.height))
      throw InputError(where, "adaptive.block: must be a block edge in [1, " +
                                  std::to_string(std::max(s.width, s.height)) + "] cells");
  }
  if (s.tileSize > 0 && s.convergenceDriven())
    throw InputError(where,
                     "tile_size: a job with target_error or time_limit stops after whole passes over the "
                     "frame; give tile_size \"off\" or \"auto\"");
}

namespace {
// The value of `kinds` whose name is `name` (the inverse of a *Name function), into `kind`.
template <class Kind>
bool parseByName(const std::string& name, std::initializer_list<Kind> kinds, const char* (*nameOf)(Kind), Kind& kind) {
  for (Kind k : kinds)
    if (name == nameOf(k)) {
      kind = k;
      return true;
    }
  return false;
}
}  // namespace

const char* integratorName(IntegratorKind kind) {
  switch (kind) {
    case IntegratorKind::kNaive: return "naive";
    case IntegratorKind::kNee: return "nee";
    case IntegratorKind::kNeeMis: break;
  }
  return "nee_mis";
}

bool parseIntegratorName(const std::string& name, IntegratorKind& kind) {
  return parseByName(name, {IntegratorKind::kNaive, IntegratorKind::kNee, IntegratorKind::kNeeMis}, integratorName,
                     kind);
}

const char* samplerName(SamplerKind kind) {
  switch (kind) {
    case SamplerKind::kIndependent: return "independent";
    case SamplerKind::kStratified: return "stratified";
    case SamplerKind::kSobol: break;
  }
  return "sobol";
}

const char* rouletteName(RouletteRule rule) {
  switch (rule) {
    case RouletteRule::kOff: return "off";
    case RouletteRule::kMax: return "max";
    case RouletteRule::kThroughput: break;
  }
  return "throughput";
}

bool parseRouletteName(const std::string& name, RouletteRule& rule) {
  return parseByName(name, {RouletteRule::kOff, RouletteRule::kMax, RouletteRule::kThroughput}, rouletteName, rule);
}

bool parseSamplerName(const std::string& name, SamplerKind& kind) {
  return parseByName(name, {SamplerKind::kIndependent, SamplerKind::kStratified, SamplerKind::kSobol}, samplerName,
                     kind);
}

}  // namespace lensfarm
