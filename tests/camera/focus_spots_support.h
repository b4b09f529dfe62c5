#pragma once
// The seed scene's thin lens at an f-number, its circle of confusion and the report's eq. 1 axial
// spot in closed form, shared by focus_spots_test and focus_spots_cli_test.
#include <cmath>

#include "common/camera/depth_of_field.h"
#include "common/camera/thin_lens_camera.h"
#include "common/scene/scene_loader.h"
#include "tests/test_support.h"

namespace lensfarm::test {

inline ThinLensParams seedCameraAt(double fNumber) {
  ThinLensParams p = loadScene(test::scenesDir() / "cornell-seed.json").camera().params();
  p.fNumber = fNumber;
  return p;
}

inline double coc(const ThinLensParams& p) { return circleOfConfusion(p.sensorWidth, p.sensorHeight); }

// On the axis, eq. 1 with a unit n1 sends the ray through lens radius rho to the focal plane at
// radius rho (S1 / f) (L / S2 - 1), L = sqrt(S2^2 + rho^2) (from n2 = n1 - r/f, x = rho + S1 n2x /
// n2z and 1/S1 + 1/S2 = 1/f), so its RMS spot radius over the disk of radius R is
//     sqrt( (2 / R^2) Int_0^R rho^3 (S1/f)^2 (L/S2 - 1)^2 drho ),
// times S2 / S1 on the sensor. Integrated here by Simpson's rule.
inline double seedAxialRmsDiameter(const ThinLensParams& p) {
  const double f = p.focalLength, s1 = p.focusDistance, s2 = 1.0 / (1.0 / f - 1.0 / s1), big = f / (2.0 * p.fNumber);
  const int n = 2000;
  double sum = 0.0;
  for (int k = 0; k <= n; ++k) {
    const double rho = big * k / n, l = std::sqrt(s2 * s2 + rho * rho);
    const double g = rho * rho * rho * (s1 / f) * (s1 / f) * (l / s2 - 1.0) * (l / s2 - 1.0);
    sum += g * (k == 0 || k == n ? 1.0 : k % 2 ? 4.0 : 2.0);
  }
  const double integral = sum * (big / n) / 3.0;
  return 2.0 * std::sqrt(2.0 / (big * big) * integral) * s2 / s1;
}

}  // namespace lensfarm::test
