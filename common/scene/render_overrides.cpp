#include "common/scene/render_overrides.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <regex>

#include "common/scene/scene_loader.h"
#include "common/scene/tile_size.h"
#include "common/util/error.h"

namespace lensfarm {

namespace {

using json = nlohmann::json;

[[noreturn]] void refuse(const std::string& name, const std::string& what) {
  throw InputError("overrides." + name, what);
}

// How a member's value is written as JSON and read back from JSON or from a flag's text (which
// the CLI has already checked against the row's kind).
template <class T>
struct Codec;

template <>
struct Codec<uint64_t> {
  static json out(uint64_t v) { return v; }
  static uint64_t in(const json& j, const std::string& name) {
    if (j.is_number_unsigned() || (j.is_number_integer() && j.get<int64_t>() >= 0)) return j.get<uint64_t>();
    refuse(name, "expected a whole number, got " + j.dump());
  }
  static uint64_t fromText(const std::string& text, const std::string&) { return std::stoull(text); }
};

// Ints (sizes, bounces, the tile code) hold any integer the proto can carry, clamped to +-2^30 so
// that the limits check (validateRenderSettings) names the value's excess rather than it wrapping.
template <>
struct Codec<int> {
  static json out(int v) { return v; }
  static int in(const json& j, const std::string& name) {
    constexpr int64_t kClamp = int64_t(1) << 30;
    if (j.is_number_unsigned()) return int(std::min<uint64_t>(j.get<uint64_t>(), uint64_t(kClamp)));
    if (j.is_number_integer()) return int(std::clamp<int64_t>(j.get<int64_t>(), -kClamp, kClamp));
    refuse(name, "expected a whole number, got " + j.dump());
  }
  static int fromText(const std::string& text, const std::string&) { return std::stoi(text); }
};

template <>
struct Codec<double> {
  static json out(double v) { return v; }
  static double in(const json& j, const std::string& name) {
    if (j.is_number()) return j.get<double>();
    refuse(name, "expected a number, got " + j.dump());
  }
  static double fromText(const std::string& text, const std::string&) { return std::stod(text); }
};

template <>
struct Codec<bool> {
  static json out(bool v) { return v; }
  static bool in(const json& j, const std::string& name) {
    if (j.is_boolean()) return j.get<bool>();
    refuse(name, "expected true or false, got " + j.dump());
  }
  static bool fromText(const std::string& text, const std::string&) { return text == "on"; }
};

// Enumerations travel by their names (integratorName, samplerName).
template <class Kind, const char* (*NameOf)(Kind), bool (*Parse)(const std::string&, Kind&)>
struct NamedCodec {
  static json out(Kind v) { return NameOf(v); }
  static Kind in(const json& j, const std::string& name, const char* what, const char* expected) {
    Kind kind;
    if (!j.is_string() || !Parse(j.get<std::string>(), kind))
      refuse(name, std::string("unknown ") + what + " " +
                       (j.is_string() ? "\"" + j.get<std::string>() + "\"" : j.dump()) + " (expected " + expected +
                       ")");
    return kind;
  }
};

template <>
struct Codec<IntegratorKind> : NamedCodec<IntegratorKind, integratorName, parseIntegratorName> {
  static IntegratorKind in(const json& j, const std::string& name) {
    return NamedCodec::in(j, name, "integrator", "nee_mis, nee or naive");
  }
  static IntegratorKind fromText(const std::string& text, const std::string& flag) { return in(text, flag); }
};

bool parseKernelName(const std::string& text, TraceKernel& kernel) {
  const std::optional<TraceKernel> k = kernelNamed(text);
  if (k) kernel = *k;
  return k.has_value();
}

template <>
struct Codec<TraceKernel> : NamedCodec<TraceKernel, kernelName, parseKernelName> {
  static TraceKernel in(const json& j, const std::string& name) {
    return NamedCodec::in(j, name, "traversal kernel", "sse2, avx2, avx512 or neon");
  }
  static TraceKernel fromText(const std::string& text, const std::string& flag) { return in(text, flag); }
};

template <>
struct Codec<SamplerKind> : NamedCodec<SamplerKind, samplerName, parseSamplerName> {
  static SamplerKind in(const json& j, const std::string& name) {
    return NamedCodec::in(j, name, "sampler", "sobol, stratified or independent");
  }
  static SamplerKind fromText(const std::string& text, const std::string& flag) { return in(text, flag); }
};

// An AOV set travels as its list ("albedo,normal"; "" for none).
template <>
struct Codec<AovSet> {
  static json out(AovSet v) { return aovListText(v); }
  static AovSet in(const json& j, const std::string& name) {
    AovSet set;
    std::string bad;
    if (!j.is_string()) refuse(name, "expected a list of AOV names, got " + j.dump());
    if (!parseAovList(j.get<std::string>(), set, &bad))
      refuse(name, "unknown AOV \"" + bad + "\" (expected " + aovNames() + ")");
    return set;
  }
  static AovSet fromText(const std::string& text, const std::string& flag) {
    RenderOverrides o;
    parseAovs({text}, o, flag);
    return *o.aovs;
  }
};

// One row over `member`: `apply(value, settings)` copies a set value into the settings.
template <class T, class Apply>
OverrideRow row(std::string name, std::string flag, OverrideKind kind, std::string help,
                std::optional<T> RenderOverrides::*member, Apply apply) {
  OverrideRow r;
  r.name = name;
  r.flag = std::move(flag);
  r.kind = kind;
  r.help = std::move(help);
  r.get = [member](const RenderOverrides& o) -> std::optional<json> {
    if (!(o.*member)) return std::nullopt;
    return Codec<T>::out(*(o.*member));
  };
  r.set = [member, name](RenderOverrides& o, const json& j) { o.*member = Codec<T>::in(j, name); };
  r.setText = [member](RenderOverrides& o, const std::string& text, const std::string& givenFlag) {
    o.*member = Codec<T>::fromText(text, givenFlag);
  };
  r.apply = [member, apply](const RenderOverrides& o, RenderSettings& s) {
    if (o.*member) apply(*(o.*member), s);
  };
  return r;
}

OverrideRow whole(OverrideRow r, uint64_t lo, uint64_t hi) {
  r.wholeLo = lo, r.wholeHi = hi;
  return r;
}

OverrideRow ranged(OverrideRow r, double lo, double hi, std::string unit = "") {
  r.lo = lo, r.hi = hi, r.unit = std::move(unit);
  return r;
}

OverrideRow named(OverrideRow r, std::vector<std::string> names) {
  r.names = std::move(names);
  return r;
}

std::vector<OverrideRow> makeTable() {
  using K = OverrideKind;
  using O = RenderOverrides;
  using S = RenderSettings;
  std::vector<OverrideRow> t;
  t.push_back(whole(row("samples_per_pixel", "--spp", K::kWhole, "Samples per pixel (overrides the scene)",
                        &O::samplesPerPixel, [](uint64_t v, S& s) { s.samplesPerPixel = v; }),
                    1, kMaxSamplesPerPixel));
  OverrideRow width = row("width", "--resolution", K::kText, "Image size WIDTHxHEIGHT (overrides the scene)", &O::width,
                          [](int v, S& s) { s.width = v; });
  width.valueName = "WIDTHxHEIGHT";
  width.setText = [](O& o, const std::string& text, const std::string& flag) { parseResolution(text, o, flag); };
  t.push_back(std::move(width));
  t.push_back(row("height", "", K::kText, "", &O::height, [](int v, S& s) { s.height = v; }));
  t.push_back(whole(row("max_bounces", "--max-bounces", K::kWhole, "Bounce limit B (overrides the scene)",
                        &O::maxBounces, [](int v, S& s) { s.maxBounces = v; }),
                    0, kMaxBounces));
  t.push_back(whole(row("seed", "--seed", K::kWhole, "Random seed (overrides the scene)", &O::seed,
                        [](uint64_t v, S& s) { s.seed = v; }),
                    0, UINT64_MAX));
  t.push_back(named(row("integrator", "--integrator", K::kName, "nee_mis, nee or naive (overrides the scene)",
                        &O::integrator, [](IntegratorKind v, S& s) { s.integrator = v; }),
                    {"nee_mis", "nee", "naive"}));
  t.push_back(named(row("sampler", "--sampler", K::kName, "sobol, stratified or independent (overrides the scene)",
                        &O::sampler, [](SamplerKind v, S& s) { s.sampler = v; }),
                    {"sobol", "stratified", "independent"}));
  // on keeps the scene's rule where it has one (else kRouletteOn); off turns roulette off.
  t.push_back(row("russian_roulette", "--russian-roulette", K::kOnOff,
                  "on (the scene's rule, or throughput where it has none) or off (overrides the scene)",
                  &O::russianRoulette, [](bool on, S& s) {
                    s.roulette = !on ? RouletteRule::kOff : s.roulette == RouletteRule::kOff ? kRouletteOn : s.roulette;
                  }));
  t.push_back(
      ranged(row("target_error", "--target-error", K::kNumber,
                 "Stop when the estimated relative RMSE of the image falls to this (e.g. 0.01); --spp becomes a cap",
                 &O::targetError, [](double v, S& s) { s.targetError = v; }),
             1e-6, 0.999));
  t.push_back(ranged(row("time_limit_seconds", "--deadline", K::kDuration,
                         "Stop this long after submission (e.g. 90s, 10m, 2h), with a whole number of units",
                         &O::timeLimitSeconds, [](double v, S& s) { s.timeLimitSeconds = v; }),
                     1e-3, 1e9));
  OverrideRow tiles =
      row("tile_size", "--tile-size", K::kText,
          "How the frame is cut into units: auto (default), off (every unit covers the whole frame) or a "
          "tile edge in pixels; never changes the image",
          &O::tileSize, [](int v, S& s) { s.tileSize = v; });
  tiles.valueName = "auto|off|N";
  tiles.setText = [](O& o, const std::string& text, const std::string& flag) { parseTileSize(text, o, flag); };
  t.push_back(std::move(tiles));
  OverrideRow aovs = row("aovs", "--aov", K::kText,
                         "Outputs beside the beauty, written as EXR layers: albedo, normal, depth, variance, samples, "
                         "object_id, material_id (comma-separated or repeated; replaces the scene's render.aovs)",
                         &O::aovs, [](AovSet v, S& s) { s.aovs = v; });
  aovs.repeatable = true;
  aovs.valueName = "LIST";
  t.push_back(std::move(aovs));
  t.push_back(
      row("adaptive", "--adaptive", K::kOnOff,
          "on: spend a quarter of the samples uniformly, then the rest where the estimated error is "
          "(docs/accuracy.md \"Adaptive sampling\"; --spp becomes the mean); off: uniform (overrides the scene)",
          &O::adaptive, [](bool on, S& s) { s.adaptive.enabled = on; }));
  t.push_back(named(row("kernel", "--kernel", K::kName,
                        "Embree's traversal kernel: sse2, avx2, avx512 or neon (default: the widest every worker "
                        "runs, docs/farm.md \"Mixed machines\"); the same kernel gives the same bits on any machine",
                        &O::kernel, [](TraceKernel v, S& s) { s.kernel = v; }),
                    kernelNames()));
  t.push_back(
      ranged(row("ev", "--ev", K::kNumber, "Exposure compensation in stops for PNG images (overrides the scene)",
                 &O::ev, [](double v, S& s) { s.exposure.ev = v; }),
             -kMaxExposureEv, kMaxExposureEv, "stops"));
  return t;
}

}  // namespace

const std::vector<OverrideRow>& overrideTable() {
  static const std::vector<OverrideRow> table = makeTable();
  return table;
}

json overridesToJson(const RenderOverrides& o) {
  json out = json::object();
  for (const OverrideRow& r : overrideTable())
    if (auto v = r.get(o)) out[r.name] = std::move(*v);
  return out;
}

RenderOverrides overridesFromJson(const json& object) {
  RenderOverrides o;
  for (const OverrideRow& r : overrideTable())
    if (object.contains(r.name)) r.set(o, object.at(r.name));
  return o;
}

void parseResolution(const std::string& text, RenderOverrides& o, const std::string& flag) {
  static const std::regex kWxH(R"(\s*(\d{1,6})\s*[xX]\s*(\d{1,6})\s*)");
  std::smatch m;
  if (!std::regex_match(text, m, kWxH))
    throw InputError(flag, "expected WIDTHxHEIGHT, e.g. 800x600, got \"" + text + "\"");
  o.width = std::stoi(m[1]);
  o.height = std::stoi(m[2]);
  if (*o.width < 1 || *o.height < 1 || *o.width > kMaxResolution || *o.height > kMaxResolution)
    throw InputError(flag, "each side must be in [1, " + std::to_string(kMaxResolution) + "], got \"" + text + "\"");
}

void parseTileSize(const std::string& text, RenderOverrides& o, const std::string& flag) {
  o.tileSize = tileSizeFromText(text);
  if (!o.tileSize) throw InputError(flag, "expected " + tileSizeForms() + ", got \"" + text + "\"");
}

void parseAovs(const std::vector<std::string>& lists, RenderOverrides& o, const std::string& flag) {
  AovSet all;
  for (const std::string& list : lists) {
    AovSet set;
    std::string bad;
    if (!parseAovList(list, set, &bad))
      throw InputError(flag, "unknown AOV \"" + bad + "\" (expected " + aovNames() + ")");
    all.bits |= set.bits;
  }
  o.aovs = all;
}

void applyOverrides(const RenderOverrides& o, RenderSettings& s, const std::string& where) {
  // A resolution is overridden whole: one side alone would pair with the scene's other side and
  // change the aspect ratio (a 64-wide override of a 512x512 scene would render 64x512).
  if (o.width.has_value() != o.height.has_value())
    throw InputError(where, o.width ? "overrides.width: given without overrides.height; give both or neither"
                                    : "overrides.height: given without overrides.width; give both or neither");
  if (o.ev && !(std::isfinite(*o.ev) && std::abs(*o.ev) <= kMaxExposureEv)) {
    char text[160];
    std::snprintf(text, sizeof text, "overrides.ev: must be a finite number of stops in [%g, %g], got %g",
                  -kMaxExposureEv, kMaxExposureEv, *o.ev);
    throw InputError(where, text);
  }
  for (const OverrideRow& r : overrideTable()) r.apply(o, s);
  validateRenderSettings(s, where);
}

}  // namespace lensfarm
