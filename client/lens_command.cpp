// `lensfarm lens FILE`: a real lens's prescription checked the way a lens designer would
// (docs/optics.md): first-order properties, the field of view on a sensor, distortion, vignetting
// and spot size across the field, and optionally a cross-section drawing with traced rays.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "client/commands.h"
#include "client/exit_codes.h"
#include "client/override_flags.h"
#include "common/camera/lens_analysis.h"
#include "common/camera/lens_plots.h"
#include "common/camera/lens_system.h"
#include "common/film/image_io.h"
#include "common/scene/lens_prescription.h"
#include "common/util/error.h"
#include "common/util/file_contents.h"

namespace lensfarm::cli {

namespace {

// The lens command's flags.
struct LensFlags {
  std::string file, svg, plots;
  double sensorWidth = 36.0, sensorHeight = 24.0, focus = INFINITY;
  int steps = 6;
};

// The angle, in degrees, that `size` mm across the sensor sees through focal length `efl` (paraxial).
double fieldOfView(double size, double efl) {
  return 2.0 * std::atan(size / 2.0 / efl) * 180.0 / 3.14159265358979323846;
}

// Prints the lens file's surfaces, names and paraxial (first-order) properties.
void printParaxial(const LensPrescription& prescription, const std::string& file, const LensSystem::Paraxial& p) {
  const LensSystem& lens = prescription.system;
  std::printf("lens: %s (%zu surfaces, aperture stop at surface %zu)\n", file.c_str(), lens.surfaces().size(),
              lens.stopIndex() + 1);
  if (!prescription.name.empty()) std::printf("name: %s\n", prescription.name.c_str());
  if (!prescription.source.empty()) std::printf("source: %s\n", prescription.source.c_str());
  size_t aspheres = 0;
  for (const LensSurface& s : lens.surfaces()) aspheres += s.spherical() ? 0 : 1;
  if (aspheres > 0) std::printf("aspheric surfaces: %zu (paraxial figures use their vertex curvature)\n", aspheres);
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
}

// Prints the film distance for focusing at object distance `distance`: paraxial, then exact.
void printFocus(const LensSystem& lens, const LensSystem::Paraxial& p, double distance) {
  // Focusing by moving the lens group: the thick-lens (paraxial) film distance, then the
  // exact one where the axial point's RMS spot is least (LensSystem::exactFocus).
  const std::optional<LensSystem::ExactFocus> focus = lens.exactFocus(distance);
  if (focus) {
    std::printf("  focused at %.1f: film %.4f behind the last vertex paraxially (%.4f farther than at infinity),\n",
                distance, focus->paraxial, focus->paraxial - p.bfl);
    std::printf(
        "    exactly (least RMS spot of the axial point, %d rays) %.4f: RMS spot %.5f there, %.5f at the "
        "paraxial film\n",
        focus->rays, focus->exact, focus->exactRms, focus->paraxialRms);
  } else {
    std::printf("  focused at %.1f: no real image (inside the front focal length)\n", distance);
  }
}

// Prints a dispersing lens's axial colour (efl at F and C) and lateral colour across the field.
void printColour(const LensSystem& lens, const LensSystem::Paraxial& p, double diagonal) {
  const double eflF = lens.paraxial(LensSystem::kWavelengthF).efl, eflC = lens.paraxial(LensSystem::kWavelengthC).efl;
  std::printf("colour: efl %.4f at F (486 nm), %.4f at C (656 nm): %.4f\n", eflF, eflC, eflF - eflC);
  // Lateral colour: the sensor's red and blue channel image heights (camera/spectral_response.h).
  for (const double share : {0.7, 1.0}) {
    const double angle = share * fieldOfView(diagonal, p.efl) / 2.0;
    const LateralColour lc = lateralColour(lens, angle, INFINITY, lens.totalTrack() + p.bfl);
    std::printf("lateral colour at %.2f°: image height red %.4f, green %.4f, blue %.4f; red - blue %.2f um\n", angle,
                lc.heightRed, lc.heightGreen, lc.heightBlue, 1000.0 * lc.lateral);
  }
}

// Prints the field table: distortion, transmitted share, relative illumination and RMS spot.
void printFieldTable(const std::vector<FieldPoint>& field, const std::vector<IlluminationPoint>& illumination) {
  std::printf("\n%8s %12s %12s %11s %12s %11s %11s\n", "field", "image h", "paraxial h", "distortion", "transmitted",
              "rel. illum.", "RMS spot");
  for (size_t i = 0; i < field.size(); ++i) {
    const FieldPoint& fp = field[i];
    std::printf("%7.2f° %12.4f %12.4f %10.3f%% %11.1f%% %10.1f%% %11.5f\n", fp.angleDegrees, fp.imageHeight,
                fp.paraxialHeight, 100.0 * fp.distortion, 100.0 * fp.transmitted, 100.0 * illumination[i].relative,
                fp.rmsSpot);
  }
}

// Writes the SVG plots (cross-section, distortion, illumination, spots) into directory `plots`.
void writePlots(const LensSystem& lens, const std::vector<FieldPoint>& field, double maxField, int steps,
                const std::string& plots) {
  std::error_code error;
  std::filesystem::create_directories(plots, error);
  if (error) throw InputError(plots, "cannot create the plots directory: " + error.message());
  const std::filesystem::path dir(plots);
  std::vector<double> angles;
  for (double t : {0.0, 0.5, 0.7, 1.0}) angles.push_back(maxField * t);
  writeBytesAtomically((dir / "cross-section.svg").string(), crossSectionSvg(lens, maxField * 0.7));
  writeBytesAtomically((dir / "distortion.svg").string(), distortionSvg(field));
  writeBytesAtomically((dir / "illumination.svg").string(),
                       illuminationSvg(relativeIllumination(lens, maxField, std::max(steps, 16))));
  writeBytesAtomically((dir / "spots.svg").string(), spotDiagramsSvg(lens, angles));
  std::printf("\nplots: %s/{cross-section,distortion,illumination,spots}.svg\n", plots.c_str());
}

}  // namespace

Runner addLensCommand(CLI::App& app) {
  auto* cmd =
      app.add_subcommand("lens", "Report a real lens's optics from its prescription (pbrt-v4 lens file or JSON)");
  auto f = std::make_shared<LensFlags>();
  cmd->add_option(
         "file", f->file,
         "Lens file: pbrt-v4 tabular (one surface a line, radius thickness index aperture [abbe], in mm) or a JSON "
         "prescription (docs/scene-format.md)")
      ->required();
  cmd->add_option("--sensor-width", f->sensorWidth, "Sensor width for the field of view, mm")
      ->check(positiveNumber("mm"));
  cmd->add_option("--sensor-height", f->sensorHeight, "Sensor height, mm")->check(positiveNumber("mm"));
  cmd->add_option("--focus", f->focus, "Object distance from the front vertex to focus at, mm (default: infinity)")
      ->check(positiveNumber("mm"));
  cmd->add_option("--field-steps", f->steps, "Field angles in the table, besides the axis")->check(CLI::Range(1, 100));
  cmd->add_option("--svg", f->svg, "Write a cross-section with traced rays to this SVG file");
  cmd->add_option("--plots", f->plots,
                  "Write SVG plots to this directory: cross-section.svg, distortion.svg, illumination.svg, spots.svg");
  return [f] {
    const LensPrescription prescription = readLensFile(readWholeFileOrThrow(f->file, f->file), f->file);
    const LensSystem& lens = prescription.system;
    const LensSystem::Paraxial p = lens.paraxial();
    printParaxial(prescription, f->file, p);
    if (std::isfinite(f->focus)) printFocus(lens, p, f->focus);
    const double diagonal = std::hypot(f->sensorWidth, f->sensorHeight);
    std::printf("field of view on a %g x %g sensor: %.2f x %.2f degrees, %.2f diagonal (paraxial)\n", f->sensorWidth,
                f->sensorHeight, fieldOfView(f->sensorWidth, p.efl), fieldOfView(f->sensorHeight, p.efl),
                fieldOfView(diagonal, p.efl));
    if (lens.disperses()) printColour(lens, p, diagonal);
    // Across the half diagonal: distortion, vignetting (the share of a beam filling the entrance
    // pupil that gets through, no cos^4) and the spot at the paraxial focus.
    const double maxField = fieldOfView(diagonal, p.efl) / 2.0;
    const std::vector<FieldPoint> field = analyzeField(lens, maxField, f->steps);
    // Relative illumination from the object side (lens_analysis.h): the beam's transmitted
    // cross-section and the field-angle-to-image-height Jacobian; the vignetting column above is
    // its first factor.
    const std::vector<IlluminationPoint> illumination = relativeIllumination(lens, maxField, f->steps);
    printFieldTable(field, illumination);
    if (!prescription.projection.empty()) std::printf("stated projection: %s\n", prescription.projection.c_str());
    if (!f->svg.empty()) {
      writeBytesAtomically(f->svg, crossSectionSvg(lens, maxField * 0.7));
      std::printf("\ncross-section: %s\n", f->svg.c_str());
    }
    if (!f->plots.empty()) writePlots(lens, field, maxField, f->steps, f->plots);
    return kOk;
  };
}

}  // namespace lensfarm::cli
