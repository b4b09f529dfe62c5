// The one place diffraction is applied (docs/optics.md "Diffraction"): every image the coordinator
// develops (`lensfarm render`, downloads, snapshots) is the sensor's mean radiance convolved with
// the scene's kernel; the sensor's sums, which workers send and checkpoints keep, are not touched.
#include <gtest/gtest.h>

#include "common/film/psf_convolution.h"
#include "common/film/sensor.h"
#include "common/scene/scene_diffraction.h"
#include "coordinator/core/coordinator.h"
#include "tests/coordinator/coordinator_fixtures.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

TEST(DiffractionImage, TheDevelopedImageIsTheSensorsConvolvedAndTheSensorIsUntouched) {
  json scene = test::minimalSceneJson();
  scene["camera"]["type"] = "thin_lens";
  scene["camera"]["f_number"] = 16;
  scene["camera"]["aperture_blades"] = 6;
  scene["camera"]["diffraction"] = json{{"scene_units_per_mm", 2.0}, {"wavelengths", 1}};  // about 3.6 px
  scene["render"]["resolution"] = {16, 12};
  scene["render"]["samples_per_pixel"] = 1;
  scene["render"]["samples_per_unit"] = 1;
  JobSpec spec;
  spec.sceneName = "diff.json";
  spec.sceneJson = scene.dump();
  Coordinator::Options options;
  options.auditFraction = 0.0;
  Coordinator c(options);
  const JobInfo job = c.submit(spec, 0);
  const std::string w = c.registerWorker(test::workerInfo("w"));
  const auto g = c.lease(w, 0);
  ASSERT_TRUE(g);
  UnitResult result = test::resultFor(w, *g, 0.0, 0.0, 16, 12);
  result.buffer.sums[3 * (5 * 16 + 7) + 1] = 1.0;  // one green cell
  ASSERT_TRUE(c.acceptResult(result));

  Sensor sensor(16, 12);
  sensor.add(result.buffer, 1);
  Image expected = sensor.developImage();
  const test::TempDir dir;
  const auto kernel = diffractionKernelFor(test::loadSceneJson(dir, scene));
  ASSERT_TRUE(kernel);
  convolveChannels(expected, *kernel);
  const JobImage image = c.image(job.id);
  EXPECT_TRUE(image.image.rgb == expected.rgb);
  EXPECT_FALSE(image.image.rgb == sensor.developImage().rgb);
  EXPECT_TRUE(Sensor::deserialize(c.sensorState(job.id)).developImage().rgb == sensor.developImage().rgb)
      << "the sums stay the sensor's";
  bool listed = false;
  for (const std::string& e : c.job(job.id).effects) listed |= e.rfind("diffraction: on (", 0) == 0;
  EXPECT_TRUE(listed);
}

}  // namespace
}  // namespace lensfarm
