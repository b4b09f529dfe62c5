#pragma once
// The thin lens's aperture: the shape through which it lets light pass, how lens points
// are sampled over it, and what it lets through.
//
// Units and conventions (owned here; docs/optics.md "Aperture shape" describes them):
//  - The unit aperture. Lens points are in units of R = f / (2N), the radius of the 2013 report's round
//    aperture (camera/thin_lens_camera.h, report eq. 7), which the camera multiplies in. x runs along
//    the camera's `right`, y along its `up`: the aperture as the photographer behind the camera
//    sees it, looking along the view.
//  - Round (the report's): the unit disk.
//  - Blades: n straight blades (3 to 64) make the regular n-gon inscribed in the unit circle, its
//    vertex k at angle a + 2 pi k / n (a = `rotation`, counter-clockwise from `right`).
//  - Curved blades, curvature c in [0, 1]: each edge of the n-gon becomes a circular arc through
//    its two vertices, bulging outward, of radius rho = 1 / c: its curvature is c times the unit
//    circle's. c = 0 is the straight polygon, c = 1 the circle; between, the rounded iris of a
//    real lens. With half-angle b = pi / n, the arc's centre lies on the edge's bisector at the
//    signed distance d = cos b - sqrt(rho^2 - sin^2 b) <= 0 from the centre (beyond it, on the
//    far side), and the arc's apex at h = d + rho = cos b + c sin^2 b / (1 + sqrt(1 - c^2 sin^2 b))
//    from the centre. Along the direction at angle alpha from the bisector, the boundary lies at
//        r(alpha) = (1 + q) h / (sqrt(1 - q^2 sin^2 alpha) + q cos alpha),   q = -c d = 1 - c h,
//    (the ray from the centre meets the arc's circle once; c -> 0 gives cos b / cos alpha, the
//    straight edge, and c = 1 gives 1). Curvatures below kMinCurvature are the straight polygon.
//  - Image: a square greyscale transmission image t(x, y) in [0, 1] over the bounding square
//    [-1, 1]^2 (side 2R = f / N, the round aperture's diameter): column 0 at x = -1, row 0 at
//    y = +1 (the image's top is `up`). It reads as drawn to the photographer behind the camera:
//    a highlight beyond the focus distance takes the image's shape upright, one nearer than it
//    turned by 180 degrees (the thin lens maps lens point p to p (1 - d / S1) on the plane at
//    distance d). RGB images give their Rec. 709 luminance times alpha; 8-bit values are sRGB
//    encoded (decoded as the project's own PNGs are written), EXR and HDR values linear.
//
// Sampling is uniform in area over the shape (the image: in proportion to t), from the two lens
// sample dimensions with a fixed amount of work, no rejection: deterministic, counter-based.
//  - Round: the concentric map; blades: one of the n fan triangles by u.x, a point in it by the
//    square-root warp (the original sampler's bits, unchanged).
//  - Curved: the shape is star-shaped about the centre, so a direction phi is drawn with density
//    proportional to r(phi)^2 / 2 (the area of the thin wedge) and then a radius r(phi) sqrt(u.y).
//    u.x picks one of the 2n half-sectors (equal areas, by symmetry) and the area fraction within
//    it. The area swept from the bisector to the point at angle psi around the arc's centre is
//        A(psi) = (rho / 2) G(psi),   G(psi) = h psi - d (psi - sin psi)
//    (Green's theorem along the arc; the radial sides add nothing); G is increasing (G' =
//    h - d (1 - cos psi) > 0), so psi for a fraction of the half-sector's area is its root, found
//    from a table of kCurvedTableSize nodes built once and two Newton steps. The boundary point
//    is then (h - 2 rho sin^2(psi / 2), rho sin psi) in the bisector's frame.
//  - Image: a pixel in proportion to t by the project's piecewise-constant 2D distribution
//    (math/distribution.h), uniform within it.
//
// Exposure: what the f-number means for a non-round aperture. The 2013 report's convention (§4.6.1)
// is that the exposure is made for the aperture: every sample weighs 1, and the picture is as
// bright at f/8 as at f/2. The f-number N sets the aperture's size: the round aperture's diameter,
// the diameter of the circle the blades are inscribed in, the side of an image's square, all
// f / N. An iris (round or bladed, straight or curved) is the aperture at N, exposed as the report
// exposes it: weight 1, its shape changes the blur, not the brightness. An aperture image is a
// mask over that opening (as a cut-out card over a lens is): it passes the share of the light of
// the fully open square that its mean transmission T = (1 / 4) integral t says, as physics does.
// Every sample of it carries weight T (importance sampling by t: t / pdf = T), so a half-black
// image gives half the light of a white one, a star the share of the square it covers. pbrt-v4's
// RealisticCamera instead rescales an aperture image to a round aperture's brightness.
//
// Open area (units R^2): pi; (n / 2) sin(2 pi / n) for straight blades; that plus n circular
// segments rho^2 (beta - sin beta cos beta), sin beta = c sin(pi / n), for curved ones; 4 T for an
// image.
#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "common/camera/aperture_image.h"
#include "common/math/sampling.h"
#include "common/math/vec.h"

namespace lensfarm {

// What a scene asks of the aperture (scene fields aperture_blades, aperture_rotation,
// aperture_curvature, aperture_image; docs/scene-format.md).
struct ApertureSpec {
  int blades = 0;  // 0 = round
  double rotationDegrees = 0.0;
  double curvature = 0.0;                      // with blades only
  std::shared_ptr<const ApertureImage> image;  // not with blades
};

class Aperture {
 public:
  enum class Kind { kRound, kPolygon, kCurvedPolygon, kImage };
  static constexpr double kMinCurvature = 1e-12;
  static constexpr int kCurvedTableSize = 64;

  Aperture() = default;  // round
  // Validates the spec; throws InputError whose `where` is the field: aperture_blades (not 0 or
  // 3 to 64), aperture_rotation (not finite), aperture_curvature (outside [0, 1], or without
  // blades), aperture_image (together with blades).
  explicit Aperture(const ApertureSpec& spec);

  Kind kind() const { return kind_; }
  bool isRound() const { return kind_ == Kind::kRound; }
  const ApertureSpec& spec() const { return spec_; }

  // A point of the unit aperture for the lens sample u in [0,1)^2 (see the top of the file).
  Vec2 sample(Vec2 u) const;
  // The weight every sample carries (the exposure convention above): T for an image, else 1.
  float weight() const { return weight_; }
  // The transmission at a point of the unit aperture: 1 inside a shape and 0 outside, or the
  // image's pixel; 0 outside the bounding square.
  float transmission(Vec2 p) const;
  // The integral of the transmission over the plane, in units of R^2 (the formulas above).
  double openArea() const { return openArea_; }
  // The largest distance from the centre at which light passes (units R): 1, or an image's.
  double extent() const;

  // The transmission averaged over the cells of an n x n grid over the bounding square
  // [-1, 1]^2, row-major, row 0 at the top (y = +1), column 0 at x = -1: for the diffraction's
  // Fourier transform of the pupil. Shapes are averaged over 8 x 8 points per cell; an image is
  // resampled exactly (each cell the area-weighted mean of the pixels it covers).
  void rasterize(int n, std::vector<float>& out) const;

 private:
  Vec2 samplePolygon(Vec2 u) const;
  Vec2 sampleCurved(Vec2 u) const;
  Vec2 sampleImage(Vec2 u) const;
  double curvedG(double psi) const;           // G(psi) above
  double curvedBoundary(double alpha) const;  // r(alpha) above, alpha from the bisector

  ApertureSpec spec_;
  Kind kind_ = Kind::kRound;
  float weight_ = 1.0f;
  double openArea_ = std::numbers::pi;
  // Blades: the polygon's step and rotation, for the fan sampler (single precision, as the original sampler).
  float cosStep_ = 1.0f, sinStep_ = 0.0f, cosRotation_ = 1.0f, sinRotation_ = 0.0f;
  // Curved blades: the arc (units R), its half-sector and the table of psi at equal area steps.
  double step_ = 0.0, rotation_ = 0.0, rho_ = 0.0, apex_ = 0.0, negD_ = 0.0, q_ = 0.0, psiVertex_ = 0.0;
  double halfSectorG_ = 0.0;
  std::vector<double> psiTable_;                   // kCurvedTableSize + 1 nodes
  std::vector<double> cosBisector_, sinBisector_;  // per sector
};

// The original straight-bladed sampler, as it was (kept inline for the lane loop's bits): triangle k
// of the n-gon's fan is picked by u.x (each has area sin(2 pi / n) / 2), a point within it by
// the square-root warp.
inline Vec2 Aperture::samplePolygon(Vec2 u) const {
  const int blades = spec_.blades;
  const float scaled = u.x * float(blades);
  const int k = std::min(int(scaled), blades - 1);
  const float a = std::sqrt(scaled - float(k)), b = u.y;
  // Vertices k and k + 1 of the unit n-gon turned by the rotation: angle rotation + k * step.
  float c = cosRotation_, s = sinRotation_;
  for (int t = 0; t < k; ++t) {
    const float cn = c * cosStep_ - s * sinStep_;
    s = s * cosStep_ + c * sinStep_;
    c = cn;
  }
  const Vec2 v0(c, s), v1(c * cosStep_ - s * sinStep_, s * cosStep_ + c * sinStep_);
  return a * ((1.0f - b) * v0 + b * v1);
}

inline Vec2 Aperture::sample(Vec2 u) const {
  switch (kind_) {
    case Kind::kRound: return sampleConcentricDisk(u);
    case Kind::kPolygon: return samplePolygon(u);
    case Kind::kCurvedPolygon: return sampleCurved(u);
    case Kind::kImage: return sampleImage(u);
  }
  return Vec2(0.0f);
}

}  // namespace lensfarm
