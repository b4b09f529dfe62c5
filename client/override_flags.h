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
  std::optional<double> deadline;  // seconds
  std::optional<double> ev;

  void addTo(CLI::App* cmd);
  // Throws InputError naming the flag (e.g. a malformed --resolution).
  RenderOverrides toOverrides() const;
};

}  // namespace lensfarm::cli
