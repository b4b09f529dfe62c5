// LensSystem: a real lens's prescription, its first-order properties and exact ray tracing
// (lens_system.h).
#include "common/camera/lens_system.h"

#include <cmath>
#include <sstream>

#include "common/util/error.h"

namespace lensfarm {

namespace {

double curvatureOf(const LensSurface& s) { return s.radius == 0.0 ? 0.0 : 1.0 / s.radius; }

// One refraction of a paraxial trace, in travel order: curvature in the travel frame, the
// indices before and after, and the gap to the next refraction.
struct Step {
  double c, n1, n2, gap;
};

// Paraxial ray (height y, reduced angle nu = n u) after the last step's refraction.
struct ParaxialRay {
  double y, nu;
};

ParaxialRay run(const std::vector<Step>& steps, ParaxialRay r) {
  for (size_t i = 0; i < steps.size(); ++i) {
    r.nu -= r.y * (steps[i].n2 - steps[i].n1) * steps[i].c;              // refraction
    if (i + 1 < steps.size()) r.y += steps[i].gap * r.nu / steps[i].n2;  // transfer
  }
  return r;
}

// Snell's law in vector form: `d` (unit) refracted at a surface of unit normal `n` (facing
// against `d`) from index n1 into n2; nullopt at total internal reflection.
std::optional<DVec3> refract(const DVec3& d, const DVec3& n, double n1, double n2) {
  const double eta = n1 / n2;
  const double cosI = -glm::dot(n, d);
  const double sin2T = eta * eta * std::max(0.0, 1.0 - cosI * cosI);
  if (sin2T > 1.0) return std::nullopt;
  return glm::normalize(eta * d + (eta * cosI - std::sqrt(1.0 - sin2T)) * n);
}

// Where `ray` crosses the sphere of radius R (!= 0) through the vertex at z: of its two crossings
// the one on the vertex's side, the nearer when the ray travels toward the centre. nullopt if it
// misses the sphere.
std::optional<double> sphereCrossing(const LensRay& ray, double z, double radius) {
  const DVec3 centre(0.0, 0.0, z + radius);
  const DVec3 oc = ray.origin - centre;
  const double b = glm::dot(oc, ray.direction);
  const double disc = b * b - (glm::dot(oc, oc) - radius * radius);
  if (disc < 0.0) return std::nullopt;
  const double root = std::sqrt(disc);
  const bool nearer = (ray.direction.z > 0.0) == (radius > 0.0);
  return nearer ? -b - root : -b + root;
}

// The even asphere's crossing by Newton's method on f(t) = z(t) - z_vertex - sag(r(t)), started
// at the vertex sphere's crossing (the plane's for a flat vertex, or when the ray misses the
// sphere); f'(t) = grad F . d with grad F = (-sag'(r) x / r, -sag'(r) y / r, 1), which is also
// the surface normal. Converges quadratically from the sphere's crossing for surfaces whose
// departure from it is small compared with the ray's obliquity; nullopt (a miss) when the sag is
// undefined at an iterate (beyond the conic's rim), the ray grazes (f' ~ 0) or kMaxNewton steps
// do not bring the step below kNewtonTolerance mm.
constexpr int kMaxNewton = 30;
constexpr double kNewtonTolerance = 1e-12;

std::optional<double> asphereCrossing(const LensRay& ray, double z, const LensSurface& s, DVec3* normal) {
  std::optional<double> start = s.radius != 0.0 ? sphereCrossing(ray, z, s.radius) : std::nullopt;
  if (!start) {
    if (ray.direction.z == 0.0) return std::nullopt;
    start = (z - ray.origin.z) / ray.direction.z;
  }
  double t = *start;
  for (int i = 0; i < kMaxNewton; ++i) {
    const DVec3 p = ray.origin + t * ray.direction;
    const double r = std::hypot(p.x, p.y);
    const double sag = s.sag(r), slope = s.sagSlope(r);
    if (!std::isfinite(sag) || !std::isfinite(slope)) return std::nullopt;
    const DVec3 grad = r > 0.0 ? DVec3(-slope * p.x / r, -slope * p.y / r, 1.0) : DVec3(0.0, 0.0, 1.0);
    const double f = p.z - z - sag, fPrime = glm::dot(grad, ray.direction);
    if (std::abs(fPrime) < 1e-12) return std::nullopt;
    const double dt = f / fPrime;
    t -= dt;
    if (std::abs(dt) < kNewtonTolerance * (1.0 + std::abs(t))) {
      const DVec3 q = ray.origin + t * ray.direction;
      const double rq = std::hypot(q.x, q.y), sq = s.sagSlope(rq);
      if (!std::isfinite(sq)) return std::nullopt;
      *normal = glm::normalize(rq > 0.0 ? DVec3(-sq * q.x / rq, -sq * q.y / rq, 1.0) : DVec3(0.0, 0.0, 1.0));
      return t;
    }
  }
  return std::nullopt;
}

}  // namespace

bool LensSurface::spherical() const {
  if (conic != 0.0) return false;
  for (double a : aspheric)
    if (a != 0.0) return false;
  return true;
}

double LensSurface::sag(double r) const {
  const double c = radius == 0.0 ? 0.0 : 1.0 / radius, r2 = r * r;
  const double root = 1.0 - (1.0 + conic) * c * c * r2;
  if (root < 0.0) return NAN;
  double z = c * r2 / (1.0 + std::sqrt(root)), power = r2 * r2;  // r^4
  for (double a : aspheric) z += a * power, power *= r2;
  return z;
}

double LensSurface::sagSlope(double r) const {
  const double c = radius == 0.0 ? 0.0 : 1.0 / radius, r2 = r * r;
  const double root = 1.0 - (1.0 + conic) * c * c * r2;
  if (root <= 0.0) return NAN;
  double slope = c * r / std::sqrt(root), power = r2 * r;  // r^3
  for (size_t i = 0; i < aspheric.size(); ++i) slope += double(2 * i + 4) * aspheric[i] * power, power *= r2;
  return slope;
}

std::optional<LensSystem::SurfaceProblem> LensSystem::problemWith(const LensSurface& s) {
  const auto mm = [](double x) { return std::to_string(x); };
  if (!std::isfinite(s.radius)) return SurfaceProblem{"radius", "radius must be a finite number of mm (0: flat)"};
  if (!std::isfinite(s.thickness) || s.thickness < 0.0)
    return SurfaceProblem{"thickness", "thickness must be a finite number of mm, 0 or more"};
  if (!(s.aperture > 0.0) || !std::isfinite(s.aperture))
    return SurfaceProblem{"aperture", "aperture (clear diameter) must be a positive number of mm"};
  if (!(s.abbe >= 0.0) || !std::isfinite(s.abbe)) return SurfaceProblem{"abbe", "Abbe number must be 0 (none) or more"};
  if (!std::isfinite(s.conic)) return SurfaceProblem{"conic", "conic constant must be a finite number"};
  if (s.aspheric.size() > LensSurface::kMaxAspheric)
    return SurfaceProblem{"aspheric", "at most " + std::to_string(LensSurface::kMaxAspheric) +
                                          " aspheric coefficients (A4 .. A16), found " +
                                          std::to_string(s.aspheric.size())};
  for (double a : s.aspheric)
    if (!std::isfinite(a)) return SurfaceProblem{"aspheric", "aspheric coefficients must be finite numbers"};
  if (s.stop && s.radius != 0.0) return SurfaceProblem{"radius", "the aperture stop is flat (radius 0)"};
  if (!s.spherical()) {
    if (s.stop) return SurfaceProblem{"conic", "the aperture stop is flat: no conic constant or aspheric coefficients"};
    if (!std::isfinite(s.sag(s.aperture / 2)) || !std::isfinite(s.sagSlope(s.aperture / 2)))
      return SurfaceProblem{"aperture", "aperture " + mm(s.aperture) +
                                            " mm reaches beyond the rim of the conic (radius " + mm(s.radius) +
                                            " mm, conic " + mm(s.conic) + ")"};
  } else if (s.radius != 0.0 && std::abs(s.radius) < s.aperture / 2) {
    return SurfaceProblem{
        "aperture", "aperture " + mm(s.aperture) + " mm is wider than the sphere of radius " + mm(s.radius) + " mm"};
  }
  return std::nullopt;
}

LensSystem::LensSystem(std::vector<LensSurface> surfaces, const std::string& where) : surfaces_(std::move(surfaces)) {
  if (surfaces_.empty()) throw InputError(where, "a lens needs at least one surface");
  size_t stops = 0;
  double z = 0.0;
  for (size_t k = 0; k < surfaces_.size(); ++k) {
    LensSurface& s = surfaces_[k];
    const std::string at = where + " surface " + std::to_string(k + 1);
    if (const std::optional<SurfaceProblem> bad = problemWith(s)) throw InputError(at, bad->why);
    if (s.stop) {
      ++stops;
      stop_ = k;
      s.index = k == 0 ? 1.0 : surfaces_[k - 1].index;  // the stop does not change the medium
      s.abbe = k == 0 ? 0.0 : surfaces_[k - 1].abbe;
    }
    if (!(s.index >= 1.0 && s.index <= 4.0)) throw InputError(at, "index must be from 1 to 4");
    vertexZ_.push_back(z);
    z += s.thickness;
  }
  if (stops != 1)
    throw InputError(where, "a lens needs exactly one aperture stop (a surface of radius 0 and index 0), found " +
                                std::to_string(stops));
  if (surfaces_.back().index != 1.0) throw InputError(where, "the last surface must end in air (index 1)");
}

LensSystem LensSystem::parsePbrt(const std::string& text, const std::string& file) {
  std::vector<LensSurface> surfaces;
  std::istringstream lines(text);
  std::string line;
  int number = 0;
  while (std::getline(lines, line)) {
    ++number;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream in(line);
    std::vector<double> v;
    std::string word;
    while (in >> word) {
      char* end = nullptr;
      const double x = std::strtod(word.c_str(), &end);
      if (end != word.c_str() + word.size() || !std::isfinite(x))
        throw InputError(file + ":" + std::to_string(number), "\"" + word + "\" is not a number");
      v.push_back(x);
    }
    if (v.empty()) continue;
    if (v.size() != 4 && v.size() != 5)
      throw InputError(file + ":" + std::to_string(number),
                       "a surface is 4 numbers (radius, thickness, index, aperture diameter, in mm) and an optional "
                       "Abbe number; found " +
                           std::to_string(v.size()));
    LensSurface s;
    s.radius = v[0];
    s.thickness = v[1];
    s.stop = v[0] == 0.0 && (v[2] == 0.0 || v[2] == 1.0);
    s.index = v[2] == 0.0 ? 1.0 : v[2];
    s.aperture = v[3];
    s.abbe = v.size() == 5 ? v[4] : 0.0;
    surfaces.push_back(s);
  }
  return LensSystem(std::move(surfaces), file);
}

bool LensSystem::disperses() const {
  for (const LensSurface& s : surfaces_)
    if (s.abbe > 0.0 && s.index != 1.0) return true;
  return false;
}

double LensSystem::indexAfter(int k, double wavelengthNm) const {
  if (k < 0) return 1.0;
  const LensSurface& s = surfaces_[size_t(k)];
  if (s.abbe <= 0.0 || s.index == 1.0) return s.index;
  // Cauchy n = A + B / lambda^2 through n_d, with n_F - n_C = (n_d - 1) / V_d.
  const auto inv2 = [](double nm) { return 1.0 / (nm * nm); };
  const double b = (s.index - 1.0) / s.abbe / (inv2(kWavelengthF) - inv2(kWavelengthC));
  return s.index + b * (inv2(wavelengthNm) - inv2(kWavelengthD));
}

LensSystem::Paraxial LensSystem::paraxial(double wavelengthNm) const {
  const int last = int(surfaces_.size()) - 1;
  // Surfaces [from, to] in travel order, forward (+z) or backward (-z).
  const auto steps = [&](int from, int to, bool forward) {
    std::vector<Step> out;
    for (int k = from; forward ? k <= to : k >= to; k += forward ? 1 : -1) {
      const double c = curvatureOf(surfaces_[size_t(k)]);
      if (forward)
        out.push_back(
            {c, indexAfter(k - 1, wavelengthNm), indexAfter(k, wavelengthNm), surfaces_[size_t(k)].thickness});
      else
        out.push_back({-c, indexAfter(k, wavelengthNm), indexAfter(k - 1, wavelengthNm),
                       k > 0 ? surfaces_[size_t(k - 1)].thickness : 0.0});
    }
    return out;
  };
  Paraxial p;
  // A ray parallel to the axis at height 1 from the object side: power and the rear focus.
  const ParaxialRay rear = run(steps(0, last, true), {1.0, 0.0});
  p.efl = -1.0 / rear.nu;
  p.bfl = -rear.y / rear.nu;
  p.rearPrincipalZ = totalTrack() + p.bfl - p.efl;
  // The same from the image side: the front focus.
  const ParaxialRay front = run(steps(last, 0, false), {1.0, 0.0});
  p.ffl = -front.y / front.nu;
  p.frontPrincipalZ = -p.ffl + p.efl;
  // The stop imaged toward the object (entrance pupil) and toward the image (exit pupil): a ray
  // from the stop's centre; where its line crosses the axis outside is the pupil, and the ratio
  // of reduced angles is the pupil's magnification (the Lagrange invariant).
  const int s = int(stop_);
  const double nStop = indexAfter(s - 1, wavelengthNm), nuStop = 0.01;
  const double stopDiameter = surfaces_[stop_].aperture;
  if (s == 0) {
    p.entrancePupilZ = 0.0;
    p.entrancePupilDiameter = stopDiameter;
  } else {
    const double gap = surfaces_[size_t(s - 1)].thickness;
    const ParaxialRay out = run(steps(s - 1, 0, false), {gap * nuStop / nStop, nuStop});
    p.entrancePupilZ = out.y / out.nu;  // in front of surface 0 when negative
    p.entrancePupilDiameter = stopDiameter * std::abs(nuStop / out.nu);
  }
  if (s == last) {
    p.exitPupilZ = totalTrack();
    p.exitPupilDiameter = stopDiameter;
  } else {
    const double gap = surfaces_[stop_].thickness;
    const ParaxialRay out = run(steps(s + 1, last, true), {gap * nuStop / nStop, nuStop});
    p.exitPupilZ = totalTrack() - out.y / out.nu;
    p.exitPupilDiameter = stopDiameter * std::abs(nuStop / out.nu);
  }
  p.fNumber = p.efl / p.entrancePupilDiameter;
  for (int k = 0; k <= last; ++k) {
    const double n1 = indexAfter(k - 1, wavelengthNm), n2 = indexAfter(k, wavelengthNm);
    p.petzvalSum += (n2 - n1) * curvatureOf(surfaces_[size_t(k)]) / (n1 * n2);
  }
  return p;
}

std::optional<double> LensSystem::focusDistanceFromRear(double objectDistance, double wavelengthNm) const {
  if (std::isinf(objectDistance)) return paraxial(wavelengthNm).bfl;
  std::vector<Step> forward;
  for (size_t k = 0; k < surfaces_.size(); ++k)
    forward.push_back({curvatureOf(surfaces_[k]), indexAfter(int(k) - 1, wavelengthNm),
                       indexAfter(int(k), wavelengthNm), surfaces_[k].thickness});
  // From the axial object point: height objectDistance * u at the front vertex.
  const double nu = 0.01;
  const ParaxialRay out = run(forward, {objectDistance * nu, nu});
  if (out.nu >= 0.0) return std::nullopt;  // diverging: a virtual image
  return -out.y / out.nu;
}

std::optional<LensSystem::ExactFocus> LensSystem::exactFocus(double objectDistance, double wavelengthNm) const {
  const std::optional<double> paraxialBack = focusDistanceFromRear(objectDistance, wavelengthNm);
  if (!paraxialBack) return std::nullopt;
  const Paraxial p = paraxial(wavelengthNm);
  // Rays from the object point through a grid a little wider than the paraxial entrance pupil
  // (the real pupil differs from it; the stop trims the overfill). Each ray's hit on the plane
  // z = Z is a + b Z per coordinate, b = d_x / d_z, a = o_x - o_z b.
  constexpr int kAcross = 64;
  const double radius = 0.55 * p.entrancePupilDiameter;
  const bool atInfinity = std::isinf(objectDistance);
  std::vector<double> ax, bx, ay, by;
  for (int i = 0; i < kAcross; ++i)
    for (int j = 0; j < kAcross; ++j) {
      const double x = radius * (2.0 * (i + 0.5) / kAcross - 1.0), y = radius * (2.0 * (j + 0.5) / kAcross - 1.0);
      if (x * x + y * y > radius * radius) continue;
      const DVec3 atPupil(x, y, p.entrancePupilZ);
      LensRay ray;
      if (atInfinity) {
        ray = LensRay{DVec3(x, y, std::min(0.0, p.entrancePupilZ) - 1.0), DVec3(0.0, 0.0, 1.0)};
      } else {
        const DVec3 object(0.0, 0.0, -objectDistance);
        ray = LensRay{object, glm::normalize(atPupil - object)};
      }
      const std::optional<LensRay> out = traceFromObjectSide(ray, wavelengthNm);
      if (!out || !(out->direction.z > 0.0)) continue;
      const double slopeX = out->direction.x / out->direction.z, slopeY = out->direction.y / out->direction.z;
      ax.push_back(out->origin.x - out->origin.z * slopeX), bx.push_back(slopeX);
      ay.push_back(out->origin.y - out->origin.z * slopeY), by.push_back(slopeY);
    }
  if (ax.size() < 8) return std::nullopt;
  const auto mean = [](const std::vector<double>& v) {
    double sum = 0.0;
    for (double x : v) sum += x;
    return sum / double(v.size());
  };
  const double max = mean(ax), mbx = mean(bx), may = mean(ay), mby = mean(by);
  // Variance(Z) = saa + 2 sab Z + sbb Z^2 (per ray, both coordinates, about the centroid).
  double saa = 0.0, sab = 0.0, sbb = 0.0;
  for (size_t i = 0; i < ax.size(); ++i) {
    const double dax = ax[i] - max, dbx = bx[i] - mbx, day = ay[i] - may, dby = by[i] - mby;
    saa += dax * dax + day * day, sab += dax * dbx + day * dby, sbb += dbx * dbx + dby * dby;
  }
  const double n = double(ax.size());
  const auto rmsAt = [&](double z) { return std::sqrt(std::max(0.0, (saa + 2.0 * sab * z + sbb * z * z) / n)); };
  ExactFocus f;
  f.rays = int(ax.size());
  f.paraxial = *paraxialBack;
  const double rear = totalTrack();
  f.exact = sbb > 0.0 ? -sab / sbb - rear : f.paraxial;
  f.paraxialRms = rmsAt(rear + f.paraxial);
  f.exactRms = rmsAt(rear + f.exact);
  return f;
}

std::optional<LensRay> LensSystem::traceFromImageSide(LensRay ray, double wavelengthNm) const {
  return trace(ray, int(surfaces_.size()) - 1, 0, -1, wavelengthNm, nullptr);
}

std::optional<LensRay> LensSystem::traceFromObjectSide(LensRay ray, double wavelengthNm,
                                                       std::vector<DVec3>* hits) const {
  return trace(ray, 0, int(surfaces_.size()) - 1, +1, wavelengthNm, hits);
}

std::optional<LensRay> LensSystem::trace(LensRay ray, int first, int last, int step, double wavelengthNm,
                                         std::vector<DVec3>* hits) const {
  for (int k = first; step > 0 ? k <= last : k >= last; k += step) {
    const LensSurface& s = surfaces_[size_t(k)];
    const double z = vertexZ_[size_t(k)];
    double t;
    DVec3 normal(0.0, 0.0, -1.0);
    if (!s.spherical()) {
      const std::optional<double> hit = asphereCrossing(ray, z, s, &normal);
      if (!hit) return std::nullopt;
      t = *hit;
    } else if (s.radius == 0.0) {
      if (ray.direction.z == 0.0) return std::nullopt;
      t = (z - ray.origin.z) / ray.direction.z;
    } else {
      const std::optional<double> hit = sphereCrossing(ray, z, s.radius);
      if (!hit) return std::nullopt;
      t = *hit;
      normal = glm::normalize(ray.origin + t * ray.direction - DVec3(0.0, 0.0, z + s.radius));
    }
    if (!(t > 0.0)) return std::nullopt;
    const DVec3 p = ray.origin + t * ray.direction;
    if (p.x * p.x + p.y * p.y > 0.25 * s.aperture * s.aperture) return std::nullopt;  // vignetted
    ray.origin = p;
    if (hits) hits->push_back(p);
    if (s.stop) continue;
    const double n1 = indexAfter(step > 0 ? k - 1 : k, wavelengthNm);
    const double n2 = indexAfter(step > 0 ? k : k - 1, wavelengthNm);
    if (glm::dot(normal, ray.direction) > 0.0) normal = -normal;
    const std::optional<DVec3> d = refract(ray.direction, normal, n1, n2);
    if (!d) return std::nullopt;
    ray.direction = *d;
  }
  return ray;
}

}  // namespace lensfarm
