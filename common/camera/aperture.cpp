#include "common/camera/aperture.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/util/error.h"

namespace lensfarm {

Aperture::Aperture(const ApertureSpec& spec) : spec_(spec) {
  if (spec.blades != 0 && !(spec.blades >= 3 && spec.blades <= 64))
    throw InputError("aperture_blades", "must be 0 (round) or 3 to 64 blades, got " + std::to_string(spec.blades));
  if (!std::isfinite(spec.rotationDegrees)) throw InputError("aperture_rotation", "must be a finite number of degrees");
  if (!(spec.curvature >= 0.0 && spec.curvature <= 1.0))
    throw InputError("aperture_curvature",
                     "must be in [0, 1] (0 straight blades, 1 a circle), got " + std::to_string(spec.curvature));
  if (spec.curvature > 0.0 && spec.blades == 0)
    throw InputError("aperture_curvature", "curves the blades' edges: it needs aperture_blades (3 to 64)");
  if (spec.image && spec.blades != 0)
    throw InputError("aperture_image",
                     "is the whole aperture's shape: give either aperture_image or aperture_blades, "
                     "not both");
  if (spec.image) {
    kind_ = Kind::kImage;
    weight_ = float(spec.image->meanTransmission());
    openArea_ = 4.0 * spec.image->meanTransmission();
    return;
  }
  if (spec.blades == 0) return;  // round

  const int n = spec.blades;
  step_ = 2.0 * std::numbers::pi / n;
  rotation_ = spec.rotationDegrees * std::numbers::pi / 180.0;
  cosStep_ = float(std::cos(step_)), sinStep_ = float(std::sin(step_));
  cosRotation_ = float(std::cos(rotation_)), sinRotation_ = float(std::sin(rotation_));
  const double sb = std::sin(step_ / 2.0), cb = std::cos(step_ / 2.0);
  if (spec.curvature < kMinCurvature) {
    kind_ = Kind::kPolygon;
    openArea_ = 0.5 * n * std::sin(step_);
    return;
  }

  kind_ = Kind::kCurvedPolygon;
  const double c = spec.curvature;
  rho_ = 1.0 / c;
  apex_ = cb + c * sb * sb / (1.0 + std::sqrt(1.0 - c * c * sb * sb));
  negD_ = rho_ - apex_;
  q_ = 1.0 - c * apex_;
  psiVertex_ = std::asin(c * sb);
  halfSectorG_ = curvedG(psiVertex_);
  openArea_ = n * rho_ * halfSectorG_;  // 2n half-sectors of area (rho / 2) G(psi_vertex)
  // psi at equal steps of area, by bisection to the last bit (G is increasing).
  psiTable_.resize(kCurvedTableSize + 1);
  for (int j = 0; j <= kCurvedTableSize; ++j) {
    const double target = halfSectorG_ * j / kCurvedTableSize;
    double lo = 0.0, hi = psiVertex_;
    for (int it = 0; it < 200 && hi > lo; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (mid <= lo || mid >= hi) break;
      (curvedG(mid) < target ? lo : hi) = mid;
    }
    psiTable_[j] = j == 0 ? 0.0 : j == kCurvedTableSize ? psiVertex_ : 0.5 * (lo + hi);
  }
  for (int k = 0; k < n; ++k) {
    const double bisector = rotation_ + (k + 0.5) * step_;
    cosBisector_.push_back(std::cos(bisector));
    sinBisector_.push_back(std::sin(bisector));
  }
}

double Aperture::curvedG(double psi) const {
  // psi - sin psi by its series where the difference would cancel.
  const double p2 = psi * psi;
  const double psiMinusSin = std::abs(psi) < 0.1
                                 ? psi * p2 * (1.0 / 6.0 - p2 * (1.0 / 120.0 - p2 * (1.0 / 5040.0 - p2 / 362880.0)))
                                 : psi - std::sin(psi);
  return apex_ * psi + negD_ * psiMinusSin;
}

double Aperture::curvedBoundary(double alpha) const {
  const double s = std::sin(alpha);
  return (1.0 + q_) * apex_ / (std::sqrt(1.0 - q_ * q_ * s * s) + q_ * std::cos(alpha));
}

Vec2 Aperture::sampleCurved(Vec2 u) const {
  const int halves = 2 * spec_.blades;
  const double scaled = double(u.x) * halves;
  const int h = std::clamp(int(scaled), 0, halves - 1);
  const bool second = (h & 1) != 0;
  // The area fraction from the bisector: the first half of sector k runs from vertex k to the
  // bisector, the second from the bisector to vertex k + 1, so the angle grows with u.x.
  const double fromStart = std::clamp(scaled - h, 0.0, 1.0);
  const double t = second ? fromStart : 1.0 - fromStart;
  const double x = t * kCurvedTableSize;
  const int j = std::min(int(x), kCurvedTableSize - 1);
  double psi = psiTable_[j] + (x - j) * (psiTable_[j + 1] - psiTable_[j]);
  const double target = t * halfSectorG_;
  for (int it = 0; it < 2; ++it) {
    const double half = std::sin(0.5 * psi);
    psi -= (curvedG(psi) - target) / (apex_ + negD_ * 2.0 * half * half);
  }
  psi = std::clamp(psi, 0.0, psiVertex_);
  const double half = std::sin(0.5 * psi), radial = std::sqrt(double(u.y));
  const double bx = radial * (apex_ - 2.0 * rho_ * half * half);
  const double by = radial * rho_ * std::sin(psi) * (second ? 1.0 : -1.0);
  const int k = h / 2;
  return Vec2(float(bx * cosBisector_[k] - by * sinBisector_[k]), float(bx * sinBisector_[k] + by * cosBisector_[k]));
}

Vec2 Aperture::sampleImage(Vec2 u) const {
  const Vec2 uv = spec_.image->distribution().sample(u);
  return Vec2(2.0f * uv.x - 1.0f, 1.0f - 2.0f * uv.y);
}

float Aperture::transmission(Vec2 p) const {
  const double x = p.x, y = p.y;
  if (kind_ == Kind::kImage) {
    if (!(std::abs(x) <= 1.0 && std::abs(y) <= 1.0)) return 0.0f;
    const int side = spec_.image->side();
    return spec_.image->at(cellIndex(float(0.5 * (x + 1.0)), side), cellIndex(float(0.5 * (1.0 - y)), side));
  }
  const double r = std::hypot(x, y);
  if (kind_ == Kind::kRound) return r <= 1.0 ? 1.0f : 0.0f;
  // The angle from the bisector of the edge the direction crosses.
  double rel = std::fmod(std::atan2(y, x) - rotation_, step_);
  if (rel < 0.0) rel += step_;
  const double alpha = rel - 0.5 * step_;
  const double boundary = kind_ == Kind::kPolygon ? std::cos(0.5 * step_) / std::cos(alpha) : curvedBoundary(alpha);
  return r <= boundary ? 1.0f : 0.0f;
}

double Aperture::extent() const { return kind_ == Kind::kImage ? spec_.image->extent() : 1.0; }

void Aperture::rasterize(int n, std::vector<float>& out) const {
  out.assign(size_t(n) * size_t(n), 0.0f);
  if (n <= 0) return;
  if (kind_ != Kind::kImage) {
    constexpr int kSub = 8;
    for (int row = 0; row < n; ++row)
      for (int col = 0; col < n; ++col) {
        int inside = 0;
        for (int b = 0; b < kSub; ++b)
          for (int a = 0; a < kSub; ++a) {
            const double x = -1.0 + 2.0 * (col + (a + 0.5) / kSub) / n, y = 1.0 - 2.0 * (row + (b + 0.5) / kSub) / n;
            inside += transmission(Vec2(float(x), float(y))) > 0.0f ? 1 : 0;
          }
        out[size_t(row) * size_t(n) + size_t(col)] = float(inside) / (kSub * kSub);
      }
    return;
  }
  // An image: each cell the area-weighted mean of the pixels it covers, one axis at a time.
  const ApertureImage& image = *spec_.image;
  const int m = image.side();
  struct Tap {
    int pixel;
    double weight;
  };
  std::vector<std::vector<Tap>> taps(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double a = double(i) * m / n, b = double(i + 1) * m / n;
    for (int p = int(std::floor(a)); p < std::min(m, int(std::ceil(b))); ++p) {
      const double overlap = std::min(b, p + 1.0) - std::max(a, double(p));
      if (overlap > 0.0) taps[size_t(i)].push_back({p, overlap / (b - a)});
    }
  }
  std::vector<double> rows(size_t(m) * size_t(n));  // the image's rows, resampled along x
  for (int y = 0; y < m; ++y)
    for (int i = 0; i < n; ++i) {
      double v = 0.0;
      for (const Tap& t : taps[size_t(i)]) v += t.weight * image.at(t.pixel, y);
      rows[size_t(y) * size_t(n) + size_t(i)] = v;
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      double v = 0.0;
      for (const Tap& t : taps[size_t(j)]) v += t.weight * rows[size_t(t.pixel) * size_t(n) + size_t(i)];
      out[size_t(j) * size_t(n) + size_t(i)] = float(v);
    }
}

}  // namespace lensfarm
