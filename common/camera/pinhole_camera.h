#pragma once
// A pinhole: every camera ray through the centre of a thin lens (camera/thin_lens_camera.h), with
// no lens sample. What the scene's "pinhole" camera is (f_number infinity), and what a thin lens
// is traced as when its blur is below a cell at the render resolution (scene/effects.h: depth of
// field is an effect a scene calls for or not). Its rays are the thin lens's generatePinholeRay,
// bit for bit, and weigh the aperture's weight (1 but for an aperture image).
#include <utility>

#include "common/camera/thin_lens_camera.h"

namespace lensfarm {

class PinholeCamera final : public Camera {
 public:
  explicit PinholeCamera(ThinLensCamera lens) : lens_(std::move(lens)) {}

  const char* type() const override { return "pinhole"; }
  const ThinLensCamera& paraxial() const override { return lens_; }
  bool usesLensSample() const override { return false; }
  void sampleRays(const CameraSampleLanes& s, CameraRayLanes& rays, float (&weight)[kPacketWidth]) const override;
  bool connects() const override { return true; }
  std::optional<CameraConnection> connect(const Vec3& p, Vec2) const override {
    return lens_.connectThrough(p, Vec2(0.0f));
  }
  ExitPupil exitPupil() const override { return lens_.exitPupil(); }

 private:
  ThinLensCamera lens_;
};

}  // namespace lensfarm
