#include "common/scene/scene_diffraction.h"

#include <cmath>

#include "common/camera/aperture.h"

namespace lensfarm {

DiffractionOptics diffractionOpticsOf(const Scene& scene) {
  DiffractionOptics o;
  o.width = scene.render.width;
  o.height = scene.render.height;
  const ThinLensCamera camera = scene.camera();
  double unitsPerMm = scene.diffraction ? scene.diffraction->sceneUnitsPerMm : 0.001;
  if (const auto real = scene.realLensCamera()) {
    // The real lens's stop is round; the PSF scale comes from its exit pupil and film (mm).
    const LensSystem::Paraxial p = real->lens().paraxial();
    o.workingFNumber = (real->filmZ() - p.exitPupilZ) / p.exitPupilDiameter;
    unitsPerMm = scene.realLens->sceneUnitsPerMm;
  } else {
    o.blades = camera.params().apertureBlades;
    o.rotation = camera.params().apertureRotation * std::acos(-1.0) / 180.0;
    o.workingFNumber = camera.imageDistance() / (2.0 * camera.lensRadius());
  }
  o.pixelWidthMm = camera.params().sensorWidth / o.width / unitsPerMm;
  o.pixelHeightMm = camera.params().sensorHeight / o.height / unitsPerMm;
  return o;
}

std::shared_ptr<const DiffractionKernel> diffractionKernelFor(const Scene& scene) {
  if (!scene.diffraction) return nullptr;
  const DiffractionOptics optics = diffractionOpticsOf(scene);
  // A real lens's stop is round; a thin lens's aperture is its shape (blades, curvature, image).
  const Aperture pupil = scene.realLens ? Aperture() : scene.camera().aperture();
  return std::make_shared<const DiffractionKernel>(
      diffractionKernel(fraunhoferPattern(pupil), optics, scene.diffraction->wavelengthsPerChannel));
}

}  // namespace lensfarm
