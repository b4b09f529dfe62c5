// `lensfarm denoise IN.exr -o OUT.exr [--png PREVIEW.png] [--strength S] [--no-guides]`: the
// à-trous denoiser of film/denoiser.h as a separate step (docs/aovs.md "Denoising"). OUT holds the
// denoised beauty, every layer of IN, and IN's beauty as the layer "noisy"; its header keeps IN's
// lensfarm/ attributes and adds lensfarm/denoised. Exit 2, with one line naming the file or flag,
// for an unreadable IN, an IN without the guide layers (unless --no-guides), or an OUT that is not
// an .exr; nothing is written then.
#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "client/commands.h"
#include "client/denoise_output.h"
#include "client/exit_codes.h"
#include "client/override_flags.h"
#include "common/film/denoiser.h"
#include "common/film/image_io.h"
#include "common/util/error.h"

namespace lensfarm::cli {

namespace {

bool hasExtension(const std::string& path, const std::string& extension) {
  std::string e = std::filesystem::path(path).extension().string();
  for (char& c : e) c = char(std::tolower(static_cast<unsigned char>(c)));
  return e == extension;
}

}  // namespace

Runner addDenoiseCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "denoise",
      "Denoise an EXR render guided by its albedo, normal and variance layers (--aov albedo,normal,variance)");
  auto input = std::make_shared<std::string>(), output = std::make_shared<std::string>();
  auto png = std::make_shared<std::string>();
  auto options = std::make_shared<DenoiseOptions>();
  auto noGuides = std::make_shared<bool>(false);
  cmd->add_option("input", *input, "The render to denoise (.exr, with albedo, normal and variance layers)")->required();
  cmd->add_option("-o,--output", *output, "The denoised image (.exr); the input's beauty is kept in its layer 'noisy'")
      ->required();
  cmd->add_option("--png", *png, "Also write a tone-mapped preview of the denoised image (.png)");
  cmd->add_option("--strength", options->strength,
                  "Scales the colour weight's width: more smooths more and blurs more low-contrast edges")
      ->check(positiveNumber(""))
      ->capture_default_str();
  cmd->add_flag("--no-guides", *noGuides,
                "Filter without the albedo and normal layers: the colour weight alone, with the variance layer if "
                "there is one (else a variance estimated from each pixel's 3x3 neighbourhood)");
  return [input, output, png, options, noGuides] {
    if (!hasExtension(*output, ".exr"))
      throw InputError(*output, "the denoised image must be an .exr file (use --png for a preview)");
    if (!png->empty() && !hasExtension(*png, ".png")) throw InputError(*png, "the --png preview must be a .png file");
    ImageMetadata metadata;
    const Image noisy = readExr(*input, &metadata);
    options->useGuides = !*noGuides;
    if (options->useGuides) requireDenoiseGuides(noisy, *input);
    const auto start = std::chrono::steady_clock::now();
    Image denoised = noisy;
    denoiseForOutput(denoised, metadata, *options);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    writeExr(*output, denoised, metadata);
    if (!png->empty()) writePng(*png, denoised, ExposureSettings{});
    std::printf("denoised %s (%dx%d, guided by %s) in %.2f s -> %s%s%s\n", input->c_str(), noisy.width, noisy.height,
                denoiseGuidesUsed(noisy, *options).c_str(), seconds, output->c_str(), png->empty() ? "" : ", ",
                png->c_str());
    return kOk;
  };
}

}  // namespace lensfarm::cli
