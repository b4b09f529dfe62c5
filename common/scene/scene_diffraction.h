#pragma once
// The diffraction a scene asks for (camera.diffraction): the optics of its camera and the
// point-spread function they give (film/diffraction_psf.h holds the physics).
#include <memory>

#include "common/film/diffraction_psf.h"
#include "common/scene/scene.h"

namespace lensfarm {

// The optics of `scene`'s camera: a thin lens's aperture at the image distance S2 (z = S2,
// D = f / N, so N_w = S2 N / f); a real lens's exit pupil and film (paraxial, round stop).
// Requires scene.diffraction and a lens (not a pinhole).
DiffractionOptics diffractionOpticsOf(const Scene& scene);

// The kernel `scene` calls for, or null when it asks for no diffraction (nothing computed then).
std::shared_ptr<const DiffractionKernel> diffractionKernelFor(const Scene& scene);

}  // namespace lensfarm
