// RealLensCamera: camera rays through a real lens (real_lens_camera.h).
#include "common/camera/real_lens_camera.h"

#include <cmath>

#include "common/camera/spectral_response.h"
#include "common/util/error.h"

namespace lensfarm {

namespace {
constexpr int kBoundsGrid = 64;  // rear-plane samples across, per pupil-bounds radius
}

RealLensCamera::RealLensCamera(const ThinLensParams& frame, const RealLensParams& lens, int width, int height)
    : frame_(frame, width, height), params_(lens) {
  const LensSystem& l = *params_.lens;
  const double scale = params_.sceneUnitsPerMm;
  // Focusing by moving the lens group: the paraxial (thick-lens) film distance, refined to the
  // one where an axial point at the focus distance has the least RMS spot (LensSystem::exactFocus).
  const std::optional<LensSystem::ExactFocus> focus = l.exactFocus(frame.focusDistance / scale);
  const std::optional<double> back = focus ? std::optional<double>(focus->exact) : std::nullopt;
  if (!back || !(*back > 0.0))
    throw InputError("focus_distance", std::to_string(frame.focusDistance) + " (" +
                                           std::to_string(frame.focusDistance / scale) +
                                           " mm from the front vertex) "
                                           "is inside the lens's front focal length: it forms no real image there");
  rearZ_ = l.totalTrack();
  filmZ_ = rearZ_ + *back;
  // The rear element's rim lies |sag| in front of its vertex plane (a surface curving toward the
  // object), so a ray from an off-axis film point to the near side of the rim crosses that plane
  // outside the rim's radius. The pupil bounds search the plane out to where such a ray from the
  // sensor's corner crosses it (at least 1.5 x the rim, as pbrt-v4's RealisticCamera does).
  const LensSurface& rearSurface = l.surfaces().back();
  const double rim = rearSurface.aperture / 2, sag = std::max(0.0, -rearSurface.sag(rim));
  const double halfWidth = frame.sensorWidth / scale / 2;
  const double halfHeight = frame_.params().sensorHeight / scale / 2;
  maxFilmRadius_ = std::hypot(halfWidth, halfHeight);
  rearRadius_ = std::max(1.5 * rim, rim + std::max(0.0, maxFilmRadius_ - rim) * sag / (filmZ_ - rearZ_ + sag) * 1.1);
  // A bin's bounds serve every film radius in it: the union of those at its two edges (as
  // pbrt-v4's BoundExitPupil unions over the interval), so that where the pupil shrinks or shifts
  // quickly with the radius (a wide-angle's vignetted corner), the inner points' rays are not
  // cut by the outer edge's box.
  Bounds edge = boundsAt(0.0);
  for (int b = 0; b < kPupilBins; ++b) {
    const Bounds next = boundsAt(maxFilmRadius_ * (b + 1) / kPupilBins);
    Bounds& u = bounds_[size_t(b)];
    if (edge.empty() || next.empty()) {
      u = edge.empty() ? next : edge;
    } else {
      u = Bounds{std::min(edge.x0, next.x0), std::max(edge.x1, next.x1), std::min(edge.y0, next.y0),
                 std::max(edge.y1, next.y1)};
    }
    edge = next;
  }
  // The normalisation: the mean weight of rays from the film's centre, over its bounds.
  const Bounds& c = boundsAt(0.0);
  double sum = 0.0;
  const int n = 32;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const DVec3 film(0.0, 0.0, filmZ_);
      const DVec3 rear(c.x0 + (c.x1 - c.x0) * (a + 0.5) / n, c.y0 + (c.y1 - c.y0) * (b + 0.5) / n, rearZ_);
      if (traceOut(film, rear)) sum += weightOf(film, rear, (c.x1 - c.x0) * (c.y1 - c.y0));
    }
  if (!(sum > 0.0)) throw InputError("lens", params_.name + ": no ray from the film's centre gets through the lens");
  normalisation_ = double(n) * n / sum;
}

double RealLensCamera::passingFraction(int filmGrid, int pupilGrid) const {
  const int width = frame_.width(), height = frame_.height();
  uint64_t tried = 0, passed = 0;
  for (int a = 0; a < filmGrid; ++a)
    for (int b = 0; b < filmGrid; ++b)
      for (int u = 0; u < pupilGrid; ++u)
        for (int v = 0; v < pupilGrid; ++v) {
          float w = 0.0f;
          ++tried;
          const Vec2 lens((float(u) + 0.5f) / float(pupilGrid), (float(v) + 0.5f) / float(pupilGrid));
          passed += generateRay(a * width / filmGrid, b * height / filmGrid, Vec2(0.5f), lens, &w).has_value();
        }
  return double(passed) / double(tried);
}

std::optional<LensRay> RealLensCamera::traceOut(const DVec3& film, const DVec3& rear, double wavelengthNm) const {
  return params_.lens->traceFromImageSide(LensRay{film, glm::normalize(rear - film)}, wavelengthNm);
}

double RealLensCamera::weightOf(const DVec3& film, const DVec3& rear, double area) const {
  const DVec3 d = rear - film;
  const double cosTheta = std::abs(d.z) / glm::length(d);
  const double gap = filmZ_ - rearZ_;
  return area * cosTheta * cosTheta * cosTheta * cosTheta / (gap * gap);
}

RealLensCamera::Bounds RealLensCamera::boundsAt(double radius) const {
  // The rear-plane points through which a ray from (radius, 0) gets out, boxed, grown by a grid
  // cell on every side (a ray between two that pass may pass). Through a lens that disperses the
  // pupil shifts a little with colour: the box then takes in the grid points just outside it
  // through which a ray gets out at the sensor's shortest or longest wavelength, until none does
  // (every grid point, should none get out at the d line).
  Bounds b{1e30, -1e30, 1e30, -1e30};
  const double cell = 2.0 * rearRadius_ / kBoundsGrid;
  const DVec3 film(radius, 0.0, filmZ_);
  const auto scan = [&](double wavelengthNm, bool aroundTheBox) {
    const Bounds before = b;
    bool grew = false;
    for (int a = 0; a < kBoundsGrid; ++a)
      for (int c = 0; c < kBoundsGrid; ++c) {
        const double x = -rearRadius_ + cell * (a + 0.5), y = -rearRadius_ + cell * (c + 0.5);
        if (aroundTheBox &&
            ((x >= before.x0 && x <= before.x1 && y >= before.y0 && y <= before.y1) || x < before.x0 - cell ||
             x > before.x1 + cell || y < before.y0 - cell || y > before.y1 + cell))
          continue;
        if (!traceOut(film, DVec3(x, y, rearZ_), wavelengthNm)) continue;
        b.x0 = std::min(b.x0, x - cell), b.x1 = std::max(b.x1, x + cell);
        b.y0 = std::min(b.y0, y - cell), b.y1 = std::max(b.y1, y + cell);
        grew = true;
      }
    return grew;
  };
  scan(LensSystem::kWavelengthD, false);
  if (spectral())
    for (const double nm : {spectral::kBandEdges[0], spectral::kBandEdges[spectral::kBands]}) {
      if (b.empty()) {
        scan(nm, false);
      } else {
        while (scan(nm, true)) {
        }
      }
    }
  if (b.empty()) return Bounds{};
  return b;
}

std::optional<CameraRay> RealLensCamera::generateRay(int i, int j, Vec2 uSensor, Vec2 uLens, float* weight,
                                                     double wavelengthNm) const {
  const Vec2 s = frame_.sensorPoint(i, j, uSensor);
  const double scale = params_.sceneUnitsPerMm;
  const DVec3 film(double(s.x) / scale, double(s.y) / scale, filmZ_);
  const double r = std::hypot(film.x, film.y);
  const int bin = std::min(kPupilBins - 1, int(r / maxFilmRadius_ * kPupilBins));
  const Bounds& b = bounds_[size_t(bin)];
  if (b.empty()) return std::nullopt;
  // The bounds were found for a film point on +x: turn them to this point's direction.
  const double bx = b.x0 + (b.x1 - b.x0) * double(uLens.x), by = b.y0 + (b.y1 - b.y0) * double(uLens.y);
  const double cosPhi = r > 0.0 ? film.x / r : 1.0, sinPhi = r > 0.0 ? film.y / r : 0.0;
  const DVec3 rear(cosPhi * bx - sinPhi * by, sinPhi * bx + cosPhi * by, rearZ_);
  const std::optional<LensRay> out = traceOut(film, rear, wavelengthNm);
  if (!out) return std::nullopt;
  *weight = float(weightOf(film, rear, (b.x1 - b.x0) * (b.y1 - b.y0)) * normalisation_);
  // Lens frame to the camera's: x = right, y = up, z = -forward; millimetres to scene units.
  const Vec3 right = frame_.right(), up = frame_.up(), forward = frame_.forward();
  const DVec3 o = out->origin * scale, d = out->direction;
  const Vec3 origin = frame_.params().position + float(o.x) * right + float(o.y) * up - float(o.z) * forward;
  const Vec3 direction = glm::normalize(float(d.x) * right + float(d.y) * up - float(d.z) * forward);
  return CameraRay{origin, direction};
}

void RealLensCamera::sampleRays(const CameraSampleLanes& s, CameraRayLanes& rays, float (&weight)[kPacketWidth]) const {
  const bool disperses = spectral();
  for (int k = 0; k < kPacketWidth; ++k) {
    weight[k] = 0.0f;
    std::optional<CameraRay> ray;
    if (k < s.count)
      ray = generateRay(s.column[k], s.row, Vec2(s.u0[k], s.u1[k]), Vec2(s.lens0[k], s.lens1[k]), &weight[k],
                        disperses ? s.wavelengthNm[k] : LensSystem::kWavelengthD);
    // A stopped lane keeps a finite ray that is never traced.
    rays.set(k, ray ? *ray : CameraRay{frame_.params().position, frame_.forward()});
    if (!ray) weight[k] = 0.0f;
  }
}

ExitPupil RealLensCamera::exitPupil() const {
  const LensSystem::Paraxial p = params_.lens->paraxial();
  return ExitPupil{Aperture(), (filmZ_ - p.exitPupilZ) / p.exitPupilDiameter};
}

}  // namespace lensfarm
