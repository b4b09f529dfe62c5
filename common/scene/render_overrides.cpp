#include "scene/render_overrides.h"

#include <cmath>
#include <cstdio>
#include <regex>

#include "scene/scene_loader.h"
#include "util/error.h"

namespace lensfarm {

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
  if (text == "auto") {
    o.tileSize = RenderSettings::kTilesAuto;
    return;
  }
  if (text == "off") {
    o.tileSize = RenderSettings::kTilesOff;
    return;
  }
  static const std::regex kEdge(R"(\d{1,6})");
  if (!std::regex_match(text, kEdge) || std::stoi(text) < 1 || std::stoi(text) > kMaxResolution)
    throw InputError(flag, "expected auto, off or a tile edge in pixels in [1, " + std::to_string(kMaxResolution) +
                               "], got \"" + text + "\"");
  o.tileSize = std::stoi(text);
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
    std::snprintf(text, sizeof text, "overrides.ev: must be a finite number of stops in [%g, %g], got %g", -kMaxExposureEv,
                  kMaxExposureEv, *o.ev);
    throw InputError(where, text);
  }
  if (o.width) s.width = *o.width;
  if (o.height) s.height = *o.height;
  if (o.samplesPerPixel) s.samplesPerPixel = *o.samplesPerPixel;
  if (o.maxBounces) s.maxBounces = *o.maxBounces;
  if (o.seed) s.seed = *o.seed;
  if (o.integrator) s.integrator = *o.integrator;
  if (o.sampler) s.sampler = *o.sampler;
  // on keeps the scene's rule where it has one (else kRouletteOn); off turns roulette off.
  if (o.russianRoulette)
    s.roulette = !*o.russianRoulette ? RouletteRule::kOff : s.roulette == RouletteRule::kOff ? kRouletteOn : s.roulette;
  if (o.targetError) s.targetError = *o.targetError;
  if (o.timeLimitSeconds) s.timeLimitSeconds = *o.timeLimitSeconds;
  if (o.ev) s.exposure.ev = *o.ev;
  if (o.tileSize) s.tileSize = *o.tileSize;
  if (o.aovs) s.aovs = *o.aovs;
  if (o.adaptive) s.adaptive.enabled = *o.adaptive;
  validateRenderSettings(s, where);
}

}  // namespace lensfarm
