// `lensfarm dof SCENE`: depth of field of the scene's camera, with the seed's formulas (8)-(10)
// (reproducing its Table 1) and the textbook ones.
#include <cstdio>
#include <string>
#include <vector>

#include "camera/depth_of_field.h"
#include "commands.h"
#include "exit_codes.h"
#include "override_flags.h"
#include "scene/scene_loader.h"

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
}  // namespace

Runner addDofCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("dof", "Print the depth of field of a scene's camera for several f-numbers");
  auto scene = std::make_shared<std::string>();
  auto fNumbers = std::make_shared<std::vector<double>>(std::vector<double>{2, 4, 8, 16, 32});
  cmd->add_option("scene", *scene, "Scene file (JSON), or a model to render as it is (.gltf, .glb, .obj)")->required();
  cmd->add_option("--f-numbers", *fNumbers, "f-numbers to tabulate")
      ->delimiter(',')
      ->check(positiveNumber(""));
  return [scene, fNumbers] {
    const Scene s = loadScene(*scene);
    const ThinLensParams p = s.camera().params();
    const double c = circleOfConfusion(p.sensorWidth, p.sensorHeight);
    std::printf("thin lens: f = %g, S1 = %g, sensor %g x %g, S2 = %.6g, c = d/1500 = %.6g\n\n", p.focalLength,
                p.focusDistance, p.sensorWidth, p.sensorHeight, s.camera().imageDistance(), c);
    std::vector<DepthOfField> seed, textbook;
    for (double n : *fNumbers) {
      seed.push_back(seedDepthOfField(p.focalLength, p.focusDistance, n, c));
      textbook.push_back(textbookDepthOfField(p.focalLength, p.focusDistance, n, c));
    }
    printTable("seed report, formulas (8)-(10):", seed);
    std::printf("\n");
    printTable("textbook (DF = inf at and beyond the hyperfocal distance):", textbook);
    return kOk;
  };
}

}  // namespace lensfarm::cli
