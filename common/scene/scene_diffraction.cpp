#include "common/scene/scene_diffraction.h"

#include <cmath>

#include "common/camera/aperture.h"
#include "common/scene/scene_camera.h"

namespace lensfarm {

namespace {

// The optics of `camera`, the scene's declared one: its exit pupil (camera/camera.h) and cells.
DiffractionOptics opticsOf(const Scene& scene, const Camera& camera, const ExitPupil& pupil) {
  DiffractionOptics o;
  o.width = scene.render.width;
  o.height = scene.render.height;
  o.blades = pupil.shape.spec().blades;
  o.rotation = pupil.shape.spec().rotationDegrees * std::acos(-1.0) / 180.0;
  o.workingFNumber = pupil.workingFNumber;
  // Millimetres for the PSF: a real lens's prescription sets the scene's unit; otherwise the
  // scene's camera.diffraction says it.
  const double unitsPerMm = scene.realLens      ? scene.realLens->sceneUnitsPerMm
                            : scene.diffraction ? scene.diffraction->sceneUnitsPerMm
                                                : 0.001;
  const ThinLensParams& lens = camera.paraxial().params();
  o.pixelWidthMm = lens.sensorWidth / o.width / unitsPerMm;
  o.pixelHeightMm = lens.sensorHeight / o.height / unitsPerMm;
  return o;
}

}  // namespace

DiffractionOptics diffractionOpticsOf(const Scene& scene) {
  const std::unique_ptr<const Camera> camera = declaredCamera(scene);
  return opticsOf(scene, *camera, camera->exitPupil());
}

std::shared_ptr<const DiffractionKernel> diffractionKernelFor(const Scene& scene) {
  if (!scene.diffraction) return nullptr;
  const std::unique_ptr<const Camera> camera = declaredCamera(scene);
  const ExitPupil pupil = camera->exitPupil();
  return std::make_shared<const DiffractionKernel>(diffractionKernel(
      fraunhoferPattern(pupil.shape), opticsOf(scene, *camera, pupil), scene.diffraction->wavelengthsPerChannel));
}

}  // namespace lensfarm
