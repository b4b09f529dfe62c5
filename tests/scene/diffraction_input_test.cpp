// camera.diffraction (docs/scene-format.md): true, false or an object; every mistake names its
// field; a pinhole or a closed aperture has nothing to diffract at; the effect analysis says what
// the pattern's scale is, and that a scene without the field asks for nothing.
#include <gtest/gtest.h>

#include <string>

#include "common/film/diffraction_psf.h"
#include "common/scene/effects.h"
#include "common/scene/scene_diffraction.h"
#include "common/scene/scene_loader.h"
#include "tests/scene/scene_error_fixture.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;
using test::kNoError;

class DiffractionInput : public test::SceneErrorTest {
 protected:
  DiffractionInput() : SceneErrorTest("diff.json") {}

  // The minimal scene through a thin lens at f/16 (a 0.1 focal length on a 0.1 sensor, 16 px).
  static json thinLens(const json& diffraction) {
    json j = test::minimalSceneJson();
    j["camera"]["type"] = "thin_lens";
    j["camera"]["f_number"] = 16;
    if (!diffraction.is_null()) j["camera"]["diffraction"] = diffraction;
    return j;
  }
  Scene load(const json& scene) const { return test::loadSceneJson(dir_, scene); }
};

TEST_F(DiffractionInput, TrueOrAnObjectTurnsItOnAndWithoutItNothingIsComputed) {
  EXPECT_FALSE(load(thinLens(nullptr)).diffraction);
  EXPECT_FALSE(load(thinLens(false)).diffraction);
  const Scene on = load(thinLens(true));
  ASSERT_TRUE(on.diffraction);
  EXPECT_EQ(on.diffraction->wavelengthsPerChannel, 4);
  EXPECT_DOUBLE_EQ(on.diffraction->sceneUnitsPerMm, 0.001);
  const Scene options = load(thinLens(json{{"wavelengths", 2}, {"scene_units_per_mm", 0.01}}));
  EXPECT_EQ(options.diffraction->wavelengthsPerChannel, 2);
  EXPECT_DOUBLE_EQ(options.diffraction->sceneUnitsPerMm, 0.01);
  EXPECT_EQ(diffractionKernelFor(load(thinLens(nullptr))), nullptr);
}

TEST_F(DiffractionInput, MistakesNameTheField) {
  EXPECT_TRUE(namesField(errorOf(thinLens(3)), "camera.diffraction", {"true, false or an object"}));
  EXPECT_TRUE(namesField(errorOf(thinLens(json{{"wavelengths", 0}})), "camera.diffraction.wavelengths"));
  EXPECT_TRUE(namesField(errorOf(thinLens(json{{"wavelengths", 17}})), "camera.diffraction.wavelengths"));
  EXPECT_TRUE(namesField(errorOf(thinLens(json{{"scene_units_per_mm", -1}})), "camera.diffraction.scene_units_per_mm"));
  EXPECT_TRUE(namesField(errorOf(thinLens(json{{"wavelenghts", 2}})), "camera.diffraction.wavelenghts"));
  json pinhole = test::minimalSceneJson();
  pinhole["camera"]["diffraction"] = true;
  EXPECT_TRUE(namesField(errorOf(pinhole), "camera.diffraction", {"pinhole"}));
  json closed = thinLens(true);
  closed["camera"]["f_number"] = "infinity";
  EXPECT_TRUE(namesField(errorOf(closed), "camera.diffraction", {"f_number is infinity"}));
  EXPECT_EQ(errorOf(thinLens(json::object())), kNoError);
}

TEST_F(DiffractionInput, TheEffectAnalysisGivesTheAiryRadiusInPixels) {
  const Scene off = load(thinLens(nullptr));
  EXPECT_NE(analyzeEffects(off, off.camera()).summary().find("diffraction: off (not asked)"), std::string::npos);
  // f/16 focused 3 units away with f = 0.1: S2 = 0.1 * 3 / 2.9, N_w = 16 S2 / f = 16.55; in metres
  // (0.001 units a mm) the Airy radius at 550 nm is 1.22 * 0.55 um * 16.55 = 11.1 um; a 0.1 m
  // sensor over 16 px has 6.25 mm cells: 0.0018 px, below a pixel.
  json scene = thinLens(true);
  scene["camera"]["aperture_blades"] = 6;
  const Scene on = load(scene);
  const EffectSet e = analyzeEffects(on, on.camera());
  EXPECT_NE(e.summary().find("diffraction: on (f/16.6 working aperture, 6 blades, Airy radius 11.1 µm = 0.00178 px"),
            std::string::npos)
      << e.summary();
  bool warned = false;
  for (const std::string& w : e.warnings())
    warned |= w.find("diffraction: the Airy radius is 0.0018 px, below a pixel") == 0;
  EXPECT_TRUE(warned);
  // The same lens in a scene in millimetres: 6.25 um cells.
  scene["camera"]["diffraction"] = json{{"scene_units_per_mm", 1.0}};
  const Scene fine = load(scene);
  const EffectSet f = analyzeEffects(fine, fine.camera());
  EXPECT_NE(f.summary().find("= 1.78 px"), std::string::npos) << f.summary();
  for (const std::string& w : f.warnings()) EXPECT_EQ(w.find("diffraction"), std::string::npos) << w;
}

// A real lens diffracts at its exit pupil: the double-Gauss at f/2.8 focused 2.9 scene units
// (1044 mm) away works at N_w = z / D_xp a little above 2.8 (N_w = N (1 + m / P) for a
// magnification m of about 0.05 and a pupil magnification P near 1).
TEST_F(DiffractionInput, ARealLensDiffractsAtItsExitPupil) {
  json scene = json::parse(test::readFile(test::scenesDir() / "cornell-real-lens.json"));
  dir_.write("meshes/cornell-box.obj", test::readFile(test::scenesDir() / "meshes/cornell-box.obj"));
  dir_.write("lenses/dgauss.50mm.dat", test::readFile(test::scenesDir() / "lenses/dgauss.50mm.dat"));
  scene["camera"]["diffraction"] = true;
  const Scene real = load(scene);
  const DiffractionOptics optics = diffractionOpticsOf(real);
  EXPECT_EQ(optics.blades, 0);
  EXPECT_GT(optics.workingFNumber, 2.8);
  EXPECT_LT(optics.workingFNumber, 3.2);
  // 0.1 scene units of sensor over 800 cells, 0.0027778 units a mm: 45 um cells.
  EXPECT_NEAR(optics.pixelWidthMm, 0.1 / 800 / 0.0027778, 1e-9);
  EXPECT_NE(analyzeEffects(real, real.camera()).summary().find("diffraction: on (f/"), std::string::npos);
  scene["camera"]["diffraction"] = json{{"scene_units_per_mm", 0.001}};
  EXPECT_TRUE(namesField(errorOf(scene), "camera.diffraction.scene_units_per_mm", {"camera.scene_units_per_mm"}));
}

}  // namespace
}  // namespace lensfarm
