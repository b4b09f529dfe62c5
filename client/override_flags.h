#pragma once
// The scene overrides that `render` and `submit` share: --spp, --resolution, --max-bounces,
// --seed, --integrator, --sampler, --russian-roulette, --target-error, --deadline, --ev; and the
// number checks every `lensfarm` flag uses.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <optional>
#include <string>

#include "scene/render_overrides.h"

namespace lensfarm::cli {

struct OverrideFlags {
  std::optional<uint64_t> spp;
  std::optional<std::string> resolution;
  std::optional<int> maxBounces;
  std::optional<uint64_t> seed;
  std::optional<std::string> integrator;
  std::optional<std::string> sampler;
  std::optional<std::string> roulette;
  std::optional<double> targetError;
  std::optional<double> deadline;  // seconds
  std::optional<double> ev;
  // --camera NAME: a camera of the scene's models (glTF) instead of the scene's own; written into
  // the scene as "camera": NAME (makeLocalJob), so a farm renders the same.
  std::optional<std::string> camera;

  void addTo(CLI::App* cmd);
  // Throws InputError naming the flag (e.g. a malformed --resolution).
  RenderOverrides toOverrides() const;
};

// Checks of flag values whose failures read as one sentence with the limit and the value given,
// which CLI11 prefixes with the flag: "--time: must be more than 0 seconds, got 0". `unit` names
// what the number counts ("seconds"), or is empty.
CLI::Validator positiveNumber(const std::string& unit);     // a finite number > 0
CLI::Validator nonNegativeNumber(const std::string& unit);  // a finite number >= 0
CLI::Validator numberIn(double lo, double hi, const std::string& unit = "");
CLI::Validator wholeNumberIn(uint64_t lo, uint64_t hi);     // digits only: no sign, no fraction
// A transform: "45", "90s", "1.5m", "2h" or "250ms" becomes seconds in [lo, hi].
CLI::Validator durationIn(double lo, double hi);

}  // namespace lensfarm::cli
