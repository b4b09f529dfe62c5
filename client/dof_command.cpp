// `lensfarm dof SCENE`: depth of field of the scene's camera, with the 2013 report's formulas (8)-(10)
// (reproducing its Table 1) and the textbook ones; with --spots N, the blur of points on the plane
// of focus across the image (camera/focus_spots.h: the report's Figure 7d question, docs/figure7.md).
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "client/commands.h"
#include "client/exit_codes.h"
#include "client/override_flags.h"
#include "common/camera/depth_of_field.h"
#include "common/camera/focus_spots.h"
#include "common/film/image_io.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"

namespace lensfarm::cli {

namespace {
std::string cell(double x) {
  if (std::isinf(x)) return "inf";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", x);
  return buf;
}

void printTable(const char* title, const std::vector<DepthOfField>& rows) {
  std::printf("%s\n%6s %12s %12s %12s %12s\n", title, "N", "H", "DN", "DF", "DF - DN");
  for (const auto& r : rows)
    std::printf("%6g %12s %12s %12s %12s\n", r.fNumber, cell(r.hyperfocal).c_str(), cell(r.nearLimit).c_str(),
                cell(r.farLimit).c_str(), cell(r.depth()).c_str());
}
struct SpotFlags {
  std::optional<double> fNumber;  // --spots N
  std::string compare, svg;
  int steps = 8;
};

// The spot table (and plot) for the scene's thin lens at f/N, with the 2013 report's eq. 1 as written
// and the ideal thin lens, and a real-lens scene's spots beside them.
void printSpots(const Scene& s, const SpotFlags& flags, double c) {
  if (s.realLens)
    throw InputError("--spots",
                     "the scene's camera is a real lens: give it with --compare beside a "
                     "thin-lens scene (its own f_number is used)");
  ThinLensParams p = s.camera().params();  // the sensor's height resolved at the scene's resolution
  p.fNumber = *flags.fNumber;
  p.apertureBlades = 0;
  std::vector<SpotSeries> series{{"2013 report eq. 1 as written (unit n1)", "#d62728",
                                  thinLensFocusSpots(p, ThinLensRule::kSeedEquationAsWritten, flags.steps)},
                                 {"ideal thin lens (lensfarm): 0, drawn on the floor", "#1f77b4",
                                  thinLensFocusSpots(p, ThinLensRule::kIdealThinLens, flags.steps)}};
  std::string lensName;
  if (!flags.compare.empty()) {
    const Scene other = loadScene(flags.compare);
    if (!other.realLens) throw InputError("--compare", flags.compare + ": its camera is not a real_lens");
    lensName = other.realLens->name;
    char label[256];
    std::snprintf(label, sizeof label, "%s at f/%.3g", lensName.c_str(), other.cameraParams.fNumber);
    series.push_back({label, "#2ca02c", realLensFocusSpots(other.camera().params(), *other.realLens, flags.steps)});
  }
  std::printf(
      "\nspots of points on the plane of focus (S1 = %g): RMS diameter on the sensor, in c; thin lens at f/%g\n",
      p.focusDistance, p.fNumber);
  std::printf("%6s %10s %14s %12s", "field", "height", "report eq. 1", "ideal");
  if (series.size() > 2) std::printf(" %14s %8s", "real lens", "passing");
  std::printf("\n");
  for (size_t k = 0; k < series[0].spots.size(); ++k) {
    std::printf("%6.3f %10.4g %14.2f %12.3f", series[0].spots[k].field, series[0].spots[k].imageHeight,
                series[0].spots[k].rmsDiameter / c, series[1].spots[k].rmsDiameter / c);
    if (series.size() > 2) {
      const FocusSpot& real = series[2].spots[k];
      if (real.passing > 0.0)
        std::printf(" %14.2f %7.1f%%", real.rmsDiameter / c, 100.0 * real.passing);
      else
        std::printf(" %14s %7.1f%%", "no light", 0.0);
    }
    std::printf("\n");
  }
  if (!flags.svg.empty()) {
    char title[160];
    std::snprintf(title, sizeof title, "Points on the plane of focus, thin lens at f/%g: spot size across the image",
                  p.fNumber);
    writeBytesAtomically(flags.svg, focusSpotsSvg(series, c, title));
    std::printf("\nplot: %s\n", flags.svg.c_str());
  }
}
}  // namespace

Runner addDofCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("dof", "Print the depth of field of a scene's camera for several f-numbers");
  auto scene = std::make_shared<std::string>();
  auto fNumbers = std::make_shared<std::vector<double>>(std::vector<double>{2, 4, 8, 16, 32});
  cmd->add_option("scene", *scene, "Scene file (JSON), or a model to render as it is (.gltf, .glb, .obj)")->required();
  cmd->add_option("--f-numbers", *fNumbers, "f-numbers to tabulate")->delimiter(',')->check(positiveNumber(""));
  auto spots = std::make_shared<SpotFlags>();
  cmd->add_option("--spots", spots->fNumber,
                  "Also measure the blur of points on the plane of focus across the image at this f-number: the "
                  "the 2013 report's eq. 1 as written against the ideal thin lens (docs/figure7.md)")
      ->check(numberIn(kMinFNumber, 1e6));
  cmd->add_option("--compare", spots->compare, "With --spots: a scene with a real_lens camera to measure beside them");
  cmd->add_option("--svg", spots->svg, "With --spots: write the plot to this SVG file");
  cmd->add_option("--field-steps", spots->steps, "With --spots: field points from the centre to the corner")
      ->check(wholeNumberIn(1, 64));
  return [scene, fNumbers, spots] {
    const Scene s = loadScene(*scene);
    ThinLensParams p = s.camera().params();
    // A pinhole has no focus (its sensor is at f): the tables are for a lens of its focal length
    // focused on look_at, which is what an aperture would make of it.
    if (std::isinf(p.focusDistance)) {
      p.focusDistance = glm::length(DVec3(p.lookAt) - DVec3(p.position));
      std::printf("pinhole: no focus; the tables are for a thin lens of its f focused on look_at\n");
    }
    const double c = circleOfConfusion(p.sensorWidth, p.sensorHeight);
    const double s2 = p.focalLength * p.focusDistance / (p.focusDistance - p.focalLength);
    std::printf("thin lens: f = %g, S1 = %g, sensor %g x %g, S2 = %.6g, c = d/1500 = %.6g\n\n", p.focalLength,
                p.focusDistance, p.sensorWidth, p.sensorHeight, s2, c);
    std::vector<DepthOfField> seed, textbook;
    for (double n : *fNumbers) {
      seed.push_back(seedDepthOfField(p.focalLength, p.focusDistance, n, c));
      textbook.push_back(textbookDepthOfField(p.focalLength, p.focusDistance, n, c));
    }
    printTable("2013 report, formulas (8)-(10):", seed);
    std::printf("\n");
    printTable("textbook (DF = inf at and beyond the hyperfocal distance):", textbook);
    if (spots->fNumber) {
      printSpots(s, *spots, c);
    } else if (!spots->compare.empty() || !spots->svg.empty()) {
      throw InputError("--spots", "--compare and --svg need --spots N");
    }
    return kOk;
  };
}

}  // namespace lensfarm::cli
