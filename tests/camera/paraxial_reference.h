#pragma once
// An independent first-order reference for lens tests: the 2x2 ray-transfer matrix (height,
// reduced angle n u) of a prescription, multiplied out surface by surface (Hecht, Optics, §6.2),
// without LensSystem::paraxial. EFL = -1/C, BFL = -A/C, FFL = -D/C for a lens in air.
#include "common/camera/lens_system.h"

namespace lensfarm::test {

struct Abcd {
  double a, b, c, d;
  double efl() const { return -1.0 / c; }
  double bfl() const { return -a / c; }
  double ffl() const { return -d / c; }
};

inline Abcd systemMatrix(const std::vector<LensSurface>& surfaces) {
  Abcd m{1, 0, 0, 1};
  double n = 1.0;
  for (size_t k = 0; k < surfaces.size(); ++k) {
    const double c = surfaces[k].radius == 0.0 ? 0.0 : 1.0 / surfaces[k].radius;
    const double next = surfaces[k].stop ? n : surfaces[k].index;
    const double p = (next - n) * c;
    m = {m.a, m.b, m.c - p * m.a, m.d - p * m.b};  // refraction [[1, 0], [-p, 1]] * m
    if (k + 1 < surfaces.size()) {
      const double t = surfaces[k].thickness / next;  // transfer [[1, t/n], [0, 1]] * m
      m = {m.a + t * m.c, m.b + t * m.d, m.c, m.d};
    }
    n = next;
  }
  return m;
}

}  // namespace lensfarm::test
