// `lensfarm lens FILE`: a real lens's prescription checked the way a lens designer would
// (docs/optics.md): first-order properties, the field of view on a sensor, distortion, vignetting
// and spot size across the field, and optionally a cross-section drawing with traced rays.
#include <cmath>
#include <cstdio>
#include <string>

#include "camera/lens_analysis.h"
#include "camera/lens_system.h"
#include "commands.h"
#include "exit_codes.h"
#include "override_flags.h"
#include "film/image_io.h"
#include "util/file_contents.h"

namespace lensfarm::cli {

Runner addLensCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("lens", "Report a real lens's optics from its prescription (pbrt-v4 lens file)");
  struct Flags {
    std::string file, svg;
    double sensorWidth = 36.0, sensorHeight = 24.0, focus = INFINITY;
    int steps = 6;
  };
  auto f = std::make_shared<Flags>();
  cmd->add_option("file", f->file, "Lens file: one surface a line, radius thickness index aperture [abbe], in mm")
      ->required();
  cmd->add_option("--sensor-width", f->sensorWidth, "Sensor width for the field of view, mm")->check(positiveNumber("mm"));
  cmd->add_option("--sensor-height", f->sensorHeight, "Sensor height, mm")->check(positiveNumber("mm"));
  cmd->add_option("--focus", f->focus, "Object distance from the front vertex to focus at, mm (default: infinity)")
      ->check(positiveNumber("mm"));
  cmd->add_option("--field-steps", f->steps, "Field angles in the table, besides the axis")->check(CLI::Range(1, 100));
  cmd->add_option("--svg", f->svg, "Write a cross-section with traced rays to this SVG file");
  return [f] {
    const LensSystem lens = LensSystem::parsePbrt(readWholeFileOrThrow(f->file, f->file), f->file);
    const LensSystem::Paraxial p = lens.paraxial();
    std::printf("lens: %s (%zu surfaces, aperture stop at surface %zu)\n", f->file.c_str(), lens.surfaces().size(),
                lens.stopIndex() + 1);
    std::printf("paraxial, at the d line (587.56 nm), object at infinity; lengths in mm, z from the front vertex:\n");
    std::printf("  effective focal length  %10.4f\n", p.efl);
    std::printf("  back focal length       %10.4f   (last vertex to focus)\n", p.bfl);
    std::printf("  front focal length      %10.4f   (front focus to front vertex)\n", p.ffl);
    std::printf("  principal planes        %10.4f   (front), %.4f (rear)\n", p.frontPrincipalZ, p.rearPrincipalZ);
    std::printf("  f-number                %10.4f\n", p.fNumber);
    std::printf("  entrance pupil          %10.4f   diameter, at z = %.4f\n", p.entrancePupilDiameter, p.entrancePupilZ);
    std::printf("  exit pupil              %10.4f   diameter, at z = %.4f\n", p.exitPupilDiameter, p.exitPupilZ);
    std::printf("  Petzval sum             %10.6f   1/mm (Petzval radius %.1f)\n", p.petzvalSum,
                p.petzvalSum != 0.0 ? -1.0 / p.petzvalSum : INFINITY);
    std::printf("  total track             %10.4f   (front vertex to last vertex)\n", lens.totalTrack());
    if (std::isfinite(f->focus)) {
      const std::optional<double> image = lens.focusDistanceFromRear(f->focus);
      if (image)
        std::printf("  focused at %.1f: film %.4f behind the last vertex (%.4f farther than at infinity)\n", f->focus, *image,
                    *image - p.bfl);
      else
        std::printf("  focused at %.1f: no real image (inside the front focal length)\n", f->focus);
    }
    const double diagonal = std::hypot(f->sensorWidth, f->sensorHeight);
    const auto fov = [&](double size) { return 2.0 * std::atan(size / 2.0 / p.efl) * 180.0 / 3.14159265358979323846; };
    std::printf("field of view on a %g x %g sensor: %.2f x %.2f degrees, %.2f diagonal (paraxial)\n", f->sensorWidth,
                f->sensorHeight, fov(f->sensorWidth), fov(f->sensorHeight), fov(diagonal));
    if (lens.disperses()) {
      const double eflF = lens.paraxial(LensSystem::kWavelengthF).efl, eflC = lens.paraxial(LensSystem::kWavelengthC).efl;
      std::printf("colour: efl %.4f at F (486 nm), %.4f at C (656 nm): %.4f\n", eflF, eflC, eflF - eflC);
      // Lateral colour: the sensor's red and blue channel image heights (camera/spectral_response.h).
      for (const double share : {0.7, 1.0}) {
        const double angle = share * fov(diagonal) / 2.0;
        const LateralColour lc = lateralColour(lens, angle, INFINITY, lens.totalTrack() + p.bfl);
        std::printf("lateral colour at %.2f°: image height red %.4f, green %.4f, blue %.4f; red - blue %.2f um\n",
                    angle, lc.heightRed, lc.heightGreen, lc.heightBlue, 1000.0 * lc.lateral);
      }
    }
    // Across the half diagonal: distortion, vignetting (the share of a beam filling the entrance
    // pupil that gets through, no cos^4) and the spot at the paraxial focus.
    const std::vector<FieldPoint> field = analyzeField(lens, fov(diagonal) / 2.0, f->steps);
    std::printf("\n%8s %12s %12s %11s %12s %11s\n", "field", "image h", "paraxial h", "distortion", "transmitted",
                "RMS spot");
    for (const FieldPoint& fp : field)
      std::printf("%7.2f° %12.4f %12.4f %10.3f%% %11.1f%% %11.5f\n", fp.angleDegrees, fp.imageHeight, fp.paraxialHeight,
                  100.0 * fp.distortion, 100.0 * fp.transmitted, fp.rmsSpot);
    if (!f->svg.empty()) {
      writeBytesAtomically(f->svg, crossSectionSvg(lens, fov(diagonal) / 2.0 * 0.7));
      std::printf("\ncross-section: %s\n", f->svg.c_str());
    }
    return kOk;
  };
}

}  // namespace lensfarm::cli
