#include "override_flags.h"

#include "scene/scene_loader.h"

namespace lensfarm::cli {

void OverrideFlags::addTo(CLI::App* cmd) {
  cmd->add_option("--spp", spp, "Samples per pixel (overrides the scene)")
      ->check(CLI::Range(uint64_t(1), kMaxSamplesPerPixel));
  cmd->add_option("--resolution", resolution, "Image size WIDTHxHEIGHT (overrides the scene)");
  cmd->add_option("--max-bounces", maxBounces, "Bounce limit B (overrides the scene)")->check(CLI::Range(0, kMaxBounces));
  cmd->add_option("--seed", seed, "Random seed (overrides the scene)");
  cmd->add_option("--integrator", integrator, "nee_mis or naive (overrides the scene)")
      ->check(CLI::IsMember({"nee_mis", "naive"}));
  cmd->add_option("--ev", ev, "Exposure compensation in stops for PNG images (overrides the scene)")
      ->check(CLI::Range(-64.0, 64.0));
}

RenderOverrides OverrideFlags::toOverrides() const {
  RenderOverrides o;
  if (resolution) parseResolution(*resolution, o);
  o.samplesPerPixel = spp;
  o.maxBounces = maxBounces;
  o.seed = seed;
  if (integrator) o.integrator = *integrator == "naive" ? IntegratorKind::kNaive : IntegratorKind::kNeeMis;
  o.ev = ev;
  return o;
}

}  // namespace lensfarm::cli
