#include "common/camera/camera.h"

#include "common/camera/thin_lens_camera.h"

namespace lensfarm {

int Camera::width() const { return paraxial().width(); }
int Camera::height() const { return paraxial().height(); }

}  // namespace lensfarm
