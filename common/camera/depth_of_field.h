#pragma once
// Depth of field for the thin-lens camera (2013 report §4.6.1, Table 1).
//
// The circle of confusion is c = d / 1500 with d the sensor diagonal. The report's formulas are
//     H  = f^2 / (N c) + f              (8)
//     DN = S1 H / (H + S1 - f)          (9)
//     DF = S1 H / (H - S1 - f)          (10)
// The textbook ones (e.g. Ray, "Applied Photographic Optics") are
//     DN = S1 (H - f) / (H + S1 - 2f),  DF = S1 (H - f) / (H - S1)
// and DF is infinite once the subject is at or beyond the hyperfocal distance. Both report an
// infinite DF (never a negative or huge number) where the denominator reaches zero.
#include <vector>

namespace lensfarm {

struct DepthOfField {
  double fNumber;
  double hyperfocal;  // H
  double nearLimit;   // DN
  double farLimit;    // DF, +inf beyond the hyperfocal distance
  double depth() const { return farLimit - nearLimit; }
};

double circleOfConfusion(double sensorWidth, double sensorHeight);

DepthOfField seedDepthOfField(double focalLength, double focusDistance, double fNumber, double coc);
DepthOfField textbookDepthOfField(double focalLength, double focusDistance, double fNumber, double coc);

}  // namespace lensfarm
