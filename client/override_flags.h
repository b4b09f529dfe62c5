#pragma once
// The scene overrides that `render` and `submit` share: --spp, --resolution, --max-bounces,
// --seed, --integrator, --sampler, --russian-roulette, --target-error, --deadline, --ev.
#include <CLI/CLI.hpp>
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
  std::optional<std::string> deadline;
  std::optional<double> ev;

  void addTo(CLI::App* cmd);
  // Throws InputError naming the flag (e.g. a malformed --resolution).
  RenderOverrides toOverrides() const;
};

// "45", "90s", "1.5m", "2h", "250ms" in seconds; throws InputError naming `flag`.
double parseDuration(const std::string& text, const std::string& flag);

}  // namespace lensfarm::cli
