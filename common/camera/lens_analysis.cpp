// Field analysis and the cross-section drawing of a real lens (lens_analysis.h).
#include "common/camera/lens_analysis.h"

#include <cmath>
#include <cstdio>

#include "common/camera/spectral_response.h"

namespace lensfarm {

namespace {

double radians(double degrees) { return degrees * 3.14159265358979323846 / 180.0; }

// The ray of a parallel beam at `angle` (in the y-z plane) through point (x, y) of the entrance
// pupil's plane, started 1 mm before the front vertex (or the pupil, if that is in front).
LensRay beamRay(const LensSystem::Paraxial& p, double angle, double x, double y) {
  const DVec3 d(0.0, std::sin(angle), std::cos(angle));
  const DVec3 atPupil(x, y, p.entrancePupilZ);
  const double startZ = std::min(0.0, p.entrancePupilZ) - 1.0;
  return LensRay{atPupil + (startZ - p.entrancePupilZ) / d.z * d, d};
}

// Where a ray leaving the last surface meets the plane z = `planeZ`.
DVec3 onPlane(const LensRay& r, double planeZ) {
  return r.origin + (planeZ - r.origin.z) / r.direction.z * r.direction;
}

// One parallel beam at `angle` through the lens to the plane z = filmZ: its rays on a square
// grid perpendicular to it, first coarse over the front surface's projection, then
// `raysAcross` across the box (grown by a coarse cell) of the coarse rays that passed.
struct Beam {
  double area = 0.0;  // mm^2 of the cross-section that passes
  DVec3 centroid{0.0};
  double rms = 0.0;  // RMS distance of the hits from their centroid
  int rays = 0;
};

Beam traceBeam(const LensSystem& lens, double angle, double filmZ, int raysAcross, double wavelengthNm,
               std::vector<DVec3>* hits = nullptr) {
  const LensSurface& front = lens.surfaces().front();
  const double rim = front.aperture / 2, sag = std::abs(front.sag(rim));
  const DVec3 d(0.0, std::sin(angle), std::cos(angle)), u(1.0, 0.0, 0.0), v(0.0, std::cos(angle), -std::sin(angle));
  // The grid's plane: through the point of the axis mid-way down the front surface's sag, moved
  // back along the beam to start in front of the lens.
  const double reach = rim + sag;
  const DVec3 centre = DVec3(0.0, 0.0, 0.5 * front.sag(rim)) - (reach + 1.0) * d;
  struct Hits {
    int passed = 0;
    DVec3 sum{0.0}, sum2{0.0};
    double lo[2] = {1e30, 1e30}, hi[2] = {-1e30, -1e30};
  };
  const auto grid = [&](double a0, double a1, double b0, double b1, int n, std::vector<DVec3>* out) {
    Hits h;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        const double a = a0 + (a1 - a0) * (i + 0.5) / n, b = b0 + (b1 - b0) * (j + 0.5) / n;
        const std::optional<LensRay> r = lens.traceFromObjectSide(LensRay{centre + a * u + b * v, d}, wavelengthNm);
        if (!r || !(r->direction.z > 0.0)) continue;
        ++h.passed;
        const DVec3 hit = onPlane(*r, filmZ);
        h.sum += hit, h.sum2 += hit * hit;
        if (out) out->push_back(hit);
        h.lo[0] = std::min(h.lo[0], a), h.hi[0] = std::max(h.hi[0], a);
        h.lo[1] = std::min(h.lo[1], b), h.hi[1] = std::max(h.hi[1], b);
      }
    return h;
  };
  constexpr int kCoarse = 96;
  const Hits coarse = grid(-reach, reach, -reach, reach, kCoarse, nullptr);
  if (coarse.passed == 0) return Beam{};
  const double cell = 2.0 * reach / kCoarse;
  const double a0 = coarse.lo[0] - cell, a1 = coarse.hi[0] + cell, b0 = coarse.lo[1] - cell, b1 = coarse.hi[1] + cell;
  const Hits fine = grid(a0, a1, b0, b1, raysAcross, hits);
  if (fine.passed == 0) return Beam{};
  const DVec3 mean = fine.sum / double(fine.passed), var = fine.sum2 / double(fine.passed) - mean * mean;
  return Beam{fine.passed * (a1 - a0) * (b1 - b0) / (double(raysAcross) * raysAcross), mean,
              std::sqrt(std::max(0.0, var.x + var.y)), fine.passed};
}

}  // namespace

std::vector<FieldPoint> analyzeField(const LensSystem& lens, double maxAngleDegrees, int steps, int raysAcross,
                                     double wavelengthNm) {
  const LensSystem::Paraxial p = lens.paraxial(wavelengthNm);
  const double focusZ = lens.totalTrack() + p.bfl;
  std::vector<FieldPoint> out;
  double axial = 0.0;
  for (int s = 0; s <= steps; ++s) {
    FieldPoint f;
    f.angleDegrees = steps > 0 ? maxAngleDegrees * s / steps : 0.0;
    const double angle = radians(f.angleDegrees);
    const Beam b = traceBeam(lens, angle, focusZ, raysAcross, wavelengthNm);
    if (s == 0) axial = b.area;
    f.paraxialHeight = p.efl * std::tan(angle);
    if (b.rays > 0) {
      f.imageHeight = s == 0 ? 0.0 : b.centroid.y;  // on the axis: 0 by symmetry (not -0 from rounding)
      f.rmsSpot = b.rms;
      f.distortion = f.paraxialHeight != 0.0 ? f.imageHeight / f.paraxialHeight - 1.0 : 0.0;
    }
    f.transmitted = axial > 0.0 ? b.area / (axial * std::cos(angle)) : 0.0;
    out.push_back(f);
  }
  return out;
}

std::vector<IlluminationPoint> relativeIllumination(const LensSystem& lens, double maxAngleDegrees, int steps,
                                                    double filmZ, int raysAcross, double wavelengthNm) {
  if (std::isnan(filmZ)) filmZ = lens.totalTrack() + lens.paraxial(wavelengthNm).bfl;
  const double delta = radians(0.25);
  const auto beam = [&](double angle) { return traceBeam(lens, angle, filmZ, raysAcross, wavelengthNm); };
  const Beam axis = beam(0.0);
  // h'(0) by symmetry: h(-delta) = -h(delta).
  const double slope0 = beam(delta).centroid.y / delta;
  std::vector<IlluminationPoint> out;
  for (int s = 0; s <= steps; ++s) {
    IlluminationPoint p;
    p.angleDegrees = steps > 0 ? maxAngleDegrees * s / steps : 0.0;
    const double angle = radians(p.angleDegrees);
    if (s == 0) {
      p.area = p.relative = axis.area > 0.0 ? 1.0 : 0.0;
      out.push_back(p);
      continue;
    }
    const Beam b = beam(angle);
    p.imageHeight = b.centroid.y;
    p.area = axis.area > 0.0 ? b.area / (axis.area * std::cos(angle)) : 0.0;
    // Central difference; one-sided where the beam beyond is cut off entirely.
    const Beam plus = beam(angle + delta), minus = beam(angle - delta);
    const double slope = plus.area > 0.0 ? (plus.centroid.y - minus.centroid.y) / (2.0 * delta)
                                         : (b.centroid.y - minus.centroid.y) / delta;
    if (b.area > 0.0 && p.imageHeight != 0.0 && slope != 0.0)
      p.relative = p.area * std::cos(angle) * std::sin(angle) * slope0 * slope0 / (p.imageHeight * slope);
    out.push_back(p);
  }
  return out;
}

double relativeIlluminationAt(const std::vector<IlluminationPoint>& table, double h) {
  for (size_t i = 1; i < table.size(); ++i)
    if (h <= table[i].imageHeight) {
      const IlluminationPoint &a = table[i - 1], &b = table[i];
      const double t = (h - a.imageHeight) / (b.imageHeight - a.imageHeight);
      return a.relative + t * (b.relative - a.relative);
    }
  return NAN;
}

std::vector<DVec3> spotHits(const LensSystem& lens, double angleDegrees, double filmZ, int raysAcross,
                            double wavelengthNm) {
  if (std::isnan(filmZ)) filmZ = lens.totalTrack() + lens.paraxial(wavelengthNm).bfl;
  std::vector<DVec3> hits;
  traceBeam(lens, radians(angleDegrees), filmZ, raysAcross, wavelengthNm, &hits);
  return hits;
}

std::optional<Projection> projectionNamed(const std::string& name) {
  for (Projection p : {Projection::kRectilinear, Projection::kEquidistant, Projection::kEquisolid,
                       Projection::kOrthographic, Projection::kStereographic})
    if (name == projectionName(p)) return p;
  return std::nullopt;
}

const char* projectionName(Projection p) {
  switch (p) {
    case Projection::kRectilinear: return "rectilinear";
    case Projection::kEquidistant: return "equidistant";
    case Projection::kEquisolid: return "equisolid";
    case Projection::kOrthographic: return "orthographic";
    case Projection::kStereographic: return "stereographic";
  }
  return "";
}

double projectedHeight(Projection p, double f, double theta) {
  switch (p) {
    case Projection::kRectilinear: return f * std::tan(theta);
    case Projection::kEquidistant: return f * theta;
    case Projection::kEquisolid: return 2.0 * f * std::sin(theta / 2.0);
    case Projection::kOrthographic: return f * std::sin(theta);
    case Projection::kStereographic: return 2.0 * f * std::tan(theta / 2.0);
  }
  return NAN;
}

std::string crossSectionSvg(const LensSystem& lens, double fieldDegrees) {
  const LensSystem::Paraxial p = lens.paraxial();
  const double focusZ = lens.totalTrack() + p.bfl;
  double halfHeight = 0.0;
  for (const LensSurface& s : lens.surfaces()) halfHeight = std::max(halfHeight, s.aperture / 2);
  const double left = -0.3 * focusZ, right = focusZ * 1.05, top = -1.3 * halfHeight, height = 2.6 * halfHeight;
  std::string svg;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"%.3f %.3f %.3f %.3f\" width=\"900\" "
                "height=\"%d\">\n<rect x=\"%.3f\" y=\"%.3f\" width=\"%.3f\" height=\"%.3f\" fill=\"white\"/>\n",
                left, top, right - left, height, int(900 * height / (right - left)), left, top, right - left, height);
  svg += buf;
  const double stroke = (right - left) / 900.0;
  std::snprintf(buf, sizeof buf,
                "<line x1=\"%.3f\" y1=\"0\" x2=\"%.3f\" y2=\"0\" stroke=\"#999\" stroke-width=\"%.4f\" "
                "stroke-dasharray=\"%.3f\"/>\n",
                left, right, stroke, 4 * stroke);
  svg += buf;
  // Surfaces: each sphere's arc within its clear aperture (y down in SVG: flip).
  for (size_t k = 0; k < lens.surfaces().size(); ++k) {
    const LensSurface& s = lens.surfaces()[k];
    const double z = lens.vertexZ(k), h = s.aperture / 2;
    std::string path;
    for (int i = 0; i <= 32; ++i) {
      const double y = -h + 2 * h * i / 32;
      const double sag = s.sag(std::abs(y));
      std::snprintf(buf, sizeof buf, "%s%.4f %.4f", i == 0 ? "M" : " L", z + sag, -y);
      path += buf;
    }
    std::snprintf(buf, sizeof buf, "\" fill=\"none\" stroke=\"%s\" stroke-width=\"%.4f\"/>\n", s.stop ? "#c00" : "#024",
                  (s.stop ? 2 : 1.5) * stroke);
    svg += "<path d=\"" + path + buf;
  }
  // Rays: 9 across the entrance pupil, on the axis (blue) and at the field angle (green).
  for (const auto& [angle, colour] : {std::pair<double, const char*>{0.0, "#06c"}, {radians(fieldDegrees), "#090"}}) {
    for (int i = 0; i < 9; ++i) {
      const double y = p.entrancePupilDiameter / 2 * (2.0 * i / 8 - 1.0) * 0.98;
      const LensRay start = beamRay(p, angle, 0.0, y);
      const LensRay from{start.origin + (left - start.origin.z) / start.direction.z * start.direction, start.direction};
      std::vector<DVec3> hits = {from.origin};
      const std::optional<LensRay> out = lens.traceFromObjectSide(from, LensSystem::kWavelengthD, &hits);
      if (!out) continue;
      hits.push_back(onPlane(*out, focusZ));
      std::string points;
      for (const DVec3& h : hits) {
        std::snprintf(buf, sizeof buf, "%s%.4f,%.4f", points.empty() ? "" : " ", h.z, -h.y);
        points += buf;
      }
      std::snprintf(buf, sizeof buf, "\" fill=\"none\" stroke=\"%s\" stroke-width=\"%.4f\" opacity=\"0.8\"/>\n", colour,
                    0.7 * stroke);
      svg += "<polyline points=\"" + points;
      svg += buf;
    }
  }
  std::snprintf(buf, sizeof buf,
                "<line x1=\"%.3f\" y1=\"%.3f\" x2=\"%.3f\" y2=\"%.3f\" stroke=\"#000\" stroke-width=\"%.4f\"/>\n",
                focusZ, top, focusZ, top + height, stroke);
  svg += buf;
  return svg + "</svg>\n";
}

// ---- Lateral colour (lens_analysis.h) ----

LateralColour lateralColour(const LensSystem& lens, double fieldDegrees, double objectDistance, double filmZ,
                            int raysAcross, int wavelengthsPerBand) {
  const LensSystem::Paraxial p = lens.paraxial();
  const double angle = radians(fieldDegrees), radius = 0.75 * p.entrancePupilDiameter;
  const bool atInfinity = std::isinf(objectDistance);
  // The object point: on the chief ray through the entrance pupil's centre.
  const DVec3 object(0.0, -(objectDistance + p.entrancePupilZ) * std::tan(angle), -objectDistance);
  double height[spectral::kBands] = {};
  for (int band = 0; band < spectral::kBands; ++band) {
    const int channel = spectral::channelOfBand(band);
    const double lo = spectral::kBandEdges[band], hi = spectral::kBandEdges[band + 1];
    double sum = 0.0, weights = 0.0;
    for (int w = 0; w < wavelengthsPerBand; ++w) {
      const double nm = lo + (hi - lo) * (w + 0.5) / wavelengthsPerBand;
      const double response = spectral::response(channel, nm);
      for (int i = 0; i < raysAcross; ++i)
        for (int j = 0; j < raysAcross; ++j) {
          const double x = radius * (2.0 * (i + 0.5) / raysAcross - 1.0),
                       y = radius * (2.0 * (j + 0.5) / raysAcross - 1.0);
          if (x * x + y * y > radius * radius) continue;
          LensRay ray = beamRay(p, angle, x, y);
          double solidAngle = 1.0;  // a parallel beam: every ray the same area of the pupil
          if (!atInfinity) {
            // From the point through (x, y) of the pupil's plane: dA cos / r^2 of solid angle.
            const DVec3 toPupil = DVec3(x, y, p.entrancePupilZ) - object;
            const double r = glm::length(toPupil);
            ray = LensRay{object, toPupil / r};
            solidAngle = toPupil.z / (r * r * r);
          }
          const std::optional<LensRay> out = lens.traceFromObjectSide(ray, nm);
          if (!out || out->direction.z <= 0.0) continue;
          sum += response * solidAngle * onPlane(*out, filmZ).y;
          weights += response * solidAngle;
        }
    }
    height[channel] = weights > 0.0 ? sum / weights : 0.0;
  }
  LateralColour out;
  out.heightRed = height[0], out.heightGreen = height[1], out.heightBlue = height[2];
  out.lateral = out.heightRed - out.heightBlue;
  return out;
}

}  // namespace lensfarm
