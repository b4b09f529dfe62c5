// `lensfarm compare IMAGE.exr REFERENCE.exr [--tolerance T]`: the error measures of
// film/error_metrics.h, so a user can judge a render (or a target-error job) against a converged
// one, and a verdict a script can test: exit 0 if the relative RMSE is at most T, 1 if it is more,
// 2 if the two cannot be compared (a file unreadable, sizes that differ, a value that is not
// finite, a reference whose mean is not positive).
#include <cmath>
#include <cstdio>
#include <string>

#include "client/commands.h"
#include "client/exit_codes.h"
#include "client/override_flags.h"
#include "common/film/error_metrics.h"
#include "common/film/image_io.h"
#include "common/util/error.h"

namespace lensfarm::cli {

namespace {

constexpr double kDefaultTolerance = 0.05;

// Throws InputError naming the file and the first pixel holding a NaN or an infinity.
void requireFinite(const Image& image, const std::string& path) {
  for (size_t k = 0; k < image.rgb.size(); ++k)
    if (!std::isfinite(image.rgb[k])) {
      const size_t pixel = k / 3;
      throw InputError(path, "pixel (" + std::to_string(pixel % size_t(image.width)) + ", " +
                                 std::to_string(pixel / size_t(image.width)) + ") is not a finite number");
    }
}

}  // namespace

Runner addCompareCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "compare", "Error of an EXR image against a reference EXR; exit 0 if the relative RMSE is within --tolerance");
  auto image = std::make_shared<std::string>(), reference = std::make_shared<std::string>();
  auto tolerance = std::make_shared<double>(kDefaultTolerance);
  cmd->add_option("image", *image, "The image to judge (.exr)")->required();
  cmd->add_option("reference", *reference, "A converged image of the same scene and size (.exr)")->required();
  cmd->add_option("--tolerance", *tolerance,
                  "The largest relative RMSE (RMSE / mean of the reference) at which the images agree: exit 0 at "
                  "or below it, 1 above")
      ->check(nonNegativeNumber(""))
      ->capture_default_str();
  return [image, reference, tolerance] {
    ImageMetadata imageMeta, referenceMeta;
    const Image a = readExr(*image, &imageMeta), b = readExr(*reference, &referenceMeta);
    if (a.width != b.width || a.height != b.height)
      throw InputError(*image, "is " + std::to_string(a.width) + "x" + std::to_string(a.height) + ", the reference " +
                                   std::to_string(b.width) + "x" + std::to_string(b.height));
    requireFinite(a, *image);
    requireFinite(b, *reference);
    // The relative RMSE divides by the reference's mean: a black reference has none to judge by.
    if (!(meanValue(b) > 0.0))
      throw InputError(*reference, "is black (its mean is 0): a relative error against it is undefined");
    const ImageError e = compareImages(a, b);
    std::printf("relative RMSE:     %.6g  (RMSE / mean of the reference)\n", e.relativeRmse);
    std::printf("RMSE:              %.6g\n", e.rmse);
    std::printf("relMSE:            %.6g  (mean of (I - R)^2 / (R^2 + 0.01))\n", e.relativeMse);
    std::printf("mean ratio:        %.6g  (mean I / mean R: bias)\n", e.meanRatio);
    std::printf("display RMSE:      %.6g  (8-bit sRGB previews, 0..1)\n", e.displayRmse);
    std::printf("samples per pixel: %llu vs %llu\n", (unsigned long long)imageMeta.samplesPerPixel,
                (unsigned long long)referenceMeta.samplesPerPixel);
    const bool agree = e.relativeRmse <= *tolerance;
    std::printf("verdict:           %s (relative RMSE %.6g %s tolerance %.6g)\n", agree ? "agree" : "differ",
                e.relativeRmse, agree ? "<=" : ">", *tolerance);
    return agree ? kOk : kImagesDiffer;
  };
}

}  // namespace lensfarm::cli
