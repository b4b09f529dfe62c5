// The spots of points on the plane of focus (camera/focus_spots.h; docs/figure7.md, the report's
// Figure 7d question), against expectations computed here independently: the ideal thin lens
// images the focal plane without blur; the report's eq. 1 with a unit n1 blurs the axial point by
// an amount integrated here in closed form over the aperture's radius; a real lens lies between
// and lights nothing past its image circle.
#include "common/camera/focus_spots.h"

#include <gtest/gtest.h>

#include "common/scene/scene_loader.h"
#include "tests/camera/focus_spots_support.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using test::coc;
using test::seedAxialRmsDiameter;
using test::seedCameraAt;

TEST(FocusSpots, TheIdealThinLensImagesThePlaneOfFocusWithoutBlurAtEveryFieldAndAperture) {
  for (double n : {1.4, 4.0}) {
    const ThinLensParams p = seedCameraAt(n);
    for (const FocusSpot& s : thinLensFocusSpots(p, ThinLensRule::kIdealThinLens, 8))
      EXPECT_LT(s.rmsDiameter, 1e-3 * coc(p)) << "f/" << n << " field " << s.field;  // float rounding only
  }
}

TEST(FocusSpots, TheSeedsEquationAsWrittenBlursTheAxisAsTheClosedFormSaysAndMoreOffIt) {
  const ThinLensParams p = seedCameraAt(1.4);
  const std::vector<FocusSpot> spots = thinLensFocusSpots(p, ThinLensRule::kSeedEquationAsWritten, 8, 96);
  EXPECT_NEAR(spots[0].rmsDiameter / seedAxialRmsDiameter(p), 1.0, 0.02);
  EXPECT_GT(spots[0].rmsDiameter, 10.0 * coc(p)) << "far from acceptably sharp even on the axis";
  for (size_t k = 1; k < spots.size(); ++k) EXPECT_GT(spots[k].rmsDiameter, spots[k - 1].rmsDiameter) << k;
  EXPECT_GT(spots.back().rmsDiameter, 5.0 * spots[0].rmsDiameter) << "the corner much blurrier than the centre";
  // Closing the aperture shrinks it: at f/16 the axial spot is the closed form's too, and below c.
  const ThinLensParams narrow = seedCameraAt(16.0);
  const double axial = thinLensFocusSpots(narrow, ThinLensRule::kSeedEquationAsWritten, 1, 96)[0].rmsDiameter;
  EXPECT_NEAR(axial / seedAxialRmsDiameter(narrow), 1.0, 0.02);
  EXPECT_LT(axial, coc(narrow));
}

TEST(FocusSpots, AFastRealLensBlursLessThanTheSeedsEquationAndLightsNothingPastItsImageCircle) {
  const Scene real = loadScene(test::scenesDir() / "cornell-seed-fast-lens.json");
  ASSERT_TRUE(real.realLens);
  const ThinLensParams seed = seedCameraAt(1.4);
  const std::vector<FocusSpot> lens = realLensFocusSpots(real.camera().params(), *real.realLens, 8);
  const std::vector<FocusSpot> eq1 = thinLensFocusSpots(seed, ThinLensRule::kSeedEquationAsWritten, 8);
  EXPECT_GT(lens[0].passing, 0.5);
  EXPECT_LT(lens[0].rmsDiameter, 2.0 * coc(seed)) << "near the axis the f/1.4 design is nearly sharp";
  for (size_t k = 0; k < lens.size(); ++k) {
    if (lens[k].passing > 0.0) {
      EXPECT_LT(lens[k].rmsDiameter, 0.25 * eq1[k].rmsDiameter) << k;
    }
  }
  // Its design covers 13 degrees half field (23 mm of image height at 100 mm): the 2013 report's 37
  // degree half-diagonal is beyond it, and the corner gets no light.
  EXPECT_EQ(lens.back().passing, 0.0);
}

}  // namespace
}  // namespace lensfarm
