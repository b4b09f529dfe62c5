#include "client/denoise_output.h"

#include <vector>

#include "common/util/error.h"

namespace lensfarm::cli {

AovSet denoiseGuideAovs() {
  AovSet s;
  s.add(Aov::kAlbedo);
  s.add(Aov::kNormal);
  s.add(Aov::kVariance);
  return s;
}

void requireDenoiseGuides(const Image& image, const std::string& source) {
  const std::vector<std::string> missing = missingDenoiseGuides(image);
  if (missing.empty()) return;
  std::string names;
  for (const std::string& n : missing) names += (names.empty() ? "" : ", ") + n;
  throw InputError(source, "has no " + names + " layer" + (missing.size() > 1 ? "s" : "") +
                               " to guide the denoiser: render it with --aov albedo,normal,variance (or give "
                               "--no-guides to lensfarm denoise to filter by colour alone)");
}

void denoiseForOutput(Image& image, ImageMetadata& metadata, const DenoiseOptions& options) {
  metadata.extra["denoised"] = "a-trous (Dammertz 2010), " + std::to_string(options.iterations) +
                               " iterations, guided by " + denoiseGuidesUsed(image, options);
  if (options.strength != 1.0) metadata.extra["denoiseStrength"] = std::to_string(options.strength);
  image = denoise(image, options);
}

}  // namespace lensfarm::cli
