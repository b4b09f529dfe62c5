// `lensfarm compare IMAGE.exr REFERENCE.exr`: the error measures of film/error_metrics.h, so a
// user can judge a render (or a target-error job) against a converged one.
#include <cstdio>

#include "commands.h"
#include "exit_codes.h"
#include "film/error_metrics.h"
#include "film/image_io.h"
#include "util/error.h"

namespace lensfarm::cli {

Runner addCompareCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("compare", "Error of an EXR image against a reference EXR (relative RMSE and more)");
  auto image = std::make_shared<std::string>(), reference = std::make_shared<std::string>();
  cmd->add_option("image", *image, "The image to judge (.exr)")->required();
  cmd->add_option("reference", *reference, "A converged image of the same scene and size (.exr)")->required();
  return [image, reference] {
    ImageMetadata imageMeta, referenceMeta;
    const Image a = readExr(*image, &imageMeta), b = readExr(*reference, &referenceMeta);
    if (a.width != b.width || a.height != b.height)
      throw InputError(*image, "is " + std::to_string(a.width) + "x" + std::to_string(a.height) + ", the reference " +
                                   std::to_string(b.width) + "x" + std::to_string(b.height));
    const ImageError e = compareImages(a, b);
    std::printf("relative RMSE:     %.6g  (RMSE / mean of the reference)\n", e.relativeRmse);
    std::printf("RMSE:              %.6g\n", e.rmse);
    std::printf("relMSE:            %.6g  (mean of (I - R)^2 / (R^2 + 0.01))\n", e.relativeMse);
    std::printf("mean ratio:        %.6g  (mean I / mean R: bias)\n", e.meanRatio);
    std::printf("display RMSE:      %.6g  (8-bit sRGB previews, 0..1)\n", e.displayRmse);
    std::printf("samples per pixel: %llu vs %llu\n", (unsigned long long)imageMeta.samplesPerPixel,
                (unsigned long long)referenceMeta.samplesPerPixel);
    return kOk;
  };
}

}  // namespace lensfarm::cli
