// libFuzzer target: a lens prescription (camera/lens_system.h), from its text to rays through it.
// Any input must end in a lens or an InputError; a lens must then give finite paraxial figures or
// report none, trace rays in both directions to a ray or nullopt, analyse its field, and build a
// camera behind it or refuse with an InputError. Anything else (a crash, a hang, another
// exception, a sanitizer report) is a finding. `make fuzz` runs it on scenes/lenses/.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "common/camera/lens_analysis.h"
#include "common/camera/lens_system.h"
#include "common/camera/real_lens_camera.h"
#include "common/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace lensfarm;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    auto lens = std::make_shared<const LensSystem>(LensSystem::parsePbrt(text, "fuzz.dat"));
    const LensSystem::Paraxial p = lens->paraxial();
    (void)lens->focusDistanceFromRear(1000.0);
    for (int k = 0; k < 8; ++k) {
      const double h = 0.1 * k;
      (void)lens->traceFromObjectSide(LensRay{DVec3(0.0, h, -1.0), glm::normalize(DVec3(0.0, 0.01 * k, 1.0))});
      (void)lens->traceFromImageSide(
          LensRay{DVec3(0.0, h, lens->totalTrack() + 50.0), glm::normalize(DVec3(0.0, -0.01 * k, -1.0))}, 486.13);
    }
    if (std::isfinite(p.efl) && p.efl > 0.0 && p.efl < 1e6) {
      (void)analyzeField(*lens, 20.0, 2, 6);
      // A camera traces some 270 k rays to bound its exit pupil: one input in eight builds one,
      // so that the fuzzer keeps its pace on the rest.
      if (size % 8 != 0) return 0;
      ThinLensParams frame;
      frame.position = Vec3(0.0f), frame.lookAt = Vec3(0.0f, 0.0f, 1.0f);
      frame.sensorWidth = 0.036, frame.focusDistance = 10.0, frame.focalLength = p.efl * 0.001;
      RealLensParams params{lens, "fuzz.dat", 0.001};
      const RealLensCamera camera(frame, params, 4, 4);
      float w = 0.0f;
      (void)camera.generateRay(1, 2, Vec2(0.5f), Vec2(0.3f, 0.7f), &w);
    }
  } catch (const InputError&) {
  }
  return 0;
}
