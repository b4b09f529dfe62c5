// Spots of points on the plane of focus across the image (focus_spots.h).
#include "common/camera/focus_spots.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "common/math/sampling.h"
#include "common/util/error.h"

namespace lensfarm {

namespace {

// Weighted points on the plane of focus, in its (right, up) coordinates.
struct Spread {
  double w = 0, x = 0, y = 0, xx = 0, yy = 0;
  void add(double px, double py, double weight) {
    w += weight, x += weight * px, y += weight * py, xx += weight * px * px, yy += weight * py * py;
  }
  double cx() const { return x / w; }
  double cy() const { return y / w; }
  double rms() const { return std::sqrt(std::max(0.0, (xx + yy) / w - cx() * cx() - cy() * cy())); }
};

// The sensor point at `field` of the half-diagonal, toward the upper right corner: the offset
// within a 1 x 1-cell sensor (every camera's sensorPoint maps u in [0,1)^2 onto the whole sensor).
Vec2 sensorOffset(double field) { return Vec2(float(0.5 + 0.5 * field), float(0.5 - 0.5 * field)); }

Vec2 lensSample(int a, int b, int across) {
  return Vec2((float(a) + 0.5f) / float(across), (float(b) + 0.5f) / float(across));
}

// Where a world-space ray meets the plane at `distance` along `forward` from `centre`, in the
// plane's (right, up) coordinates; nullopt for a ray that does not head into the scene.
std::optional<DVec3> onPlane(const CameraRay& ray, const ThinLensCamera& frame, double distance) {
  const DVec3 o = DVec3(ray.origin) - DVec3(frame.params().position), d(ray.direction);
  const DVec3 f(frame.forward()), r(frame.right()), u(frame.up());
  const double along = glm::dot(d, f);
  if (!(along > 0.0)) return std::nullopt;
  const DVec3 p = o + d * ((distance - glm::dot(o, f)) / along);
  return DVec3(glm::dot(p, r), glm::dot(p, u), 0.0);
}

void checkSteps(int steps, int raysAcross) {
  if (steps < 1 || raysAcross < 2) throw InputError("focus spots", "need at least 1 field step and 2 rays across");
}

}  // namespace

std::vector<FocusSpot> thinLensFocusSpots(const ThinLensParams& params, ThinLensRule rule, int steps, int raysAcross) {
  checkSteps(steps, raysAcross);
  const ThinLensCamera camera(params, 1, 1);
  if (camera.isPinhole()) throw InputError("f_number", "a pinhole has no aperture: every point is in focus");
  const double s1 = params.focusDistance, s2 = camera.imageDistance(), f = params.focalLength;
  const double halfDiagonal = 0.5 * std::hypot(params.sensorWidth, camera.params().sensorHeight);
  std::vector<FocusSpot> out;
  for (int k = 0; k <= steps; ++k) {
    const double field = double(k) / steps;
    const Vec2 s = camera.sensorPoint(0, 0, sensorOffset(field));
    Spread spread;
    for (int a = 0; a < raysAcross; ++a)
      for (int b = 0; b < raysAcross; ++b) {
        const Vec2 r = sampleConcentricDisk(lensSample(a, b, raysAcross)) * float(camera.lensRadius());
        if (rule == ThinLensRule::kIdealThinLens) {
          const std::optional<DVec3> p = onPlane(camera.rayThrough(s, r), camera, s1);
          if (p) spread.add(p->x, p->y, 1.0);
          continue;
        }
        // The 2013 report's eq. 1 as written, in the camera frame (lens at the origin, sensor at -S2, the
        // scene toward +z): n1 the unit vector from (s, -S2) to (r, 0); n2 = n1 - r / f.
        const DVec3 n1 = glm::normalize(DVec3(double(r.x) - s.x, double(r.y) - s.y, s2));
        const DVec3 n2(n1.x - r.x / f, n1.y - r.y / f, n1.z);
        spread.add(r.x + s1 * n2.x / n2.z, r.y + s1 * n2.y / n2.z, 1.0);
      }
    out.push_back(FocusSpot{field, field * halfDiagonal, 2.0 * spread.rms() * s2 / s1, 1.0});
  }
  return out;
}

std::vector<FocusSpot> realLensFocusSpots(const ThinLensParams& frame, const RealLensParams& lens, int steps,
                                          int raysAcross) {
  checkSteps(steps, raysAcross);
  const RealLensCamera camera(frame, lens, 1, 1);
  const ThinLensCamera axes(frame, 1, 1);  // the camera's frame: forward, right, up
  const double halfDiagonal = 0.5 * std::hypot(frame.sensorWidth, axes.params().sensorHeight);
  std::vector<FocusSpot> out;
  std::vector<double> magnification;
  for (int k = 0; k <= steps; ++k) {
    const double field = double(k) / steps;
    Spread spread;
    int passed = 0;
    for (int a = 0; a < raysAcross; ++a)
      for (int b = 0; b < raysAcross; ++b) {
        float w = 0.0f;
        const std::optional<CameraRay> ray =
            camera.generateRay(0, 0, sensorOffset(field), lensSample(a, b, raysAcross), &w);
        if (!ray) continue;
        const std::optional<DVec3> p = onPlane(*ray, axes, frame.focusDistance);
        if (!p || !(w > 0.0f)) continue;
        ++passed;
        spread.add(p->x, p->y, w);
      }
    FocusSpot spot{field, field * halfDiagonal, 0.0, double(passed) / (raysAcross * raysAcross)};
    if (passed > 1) {
      spot.rmsDiameter = 2.0 * spread.rms();  // on the plane of focus, for now
      magnification.push_back(field > 0.0 ? spot.imageHeight / std::hypot(spread.cx(), spread.cy()) : 0.0);
    } else {
      magnification.push_back(0.0);
    }
    out.push_back(spot);
  }
  for (size_t k = 0; k < out.size(); ++k) {
    // On the axis, the magnification of the first field point off it.
    const double m = k == 0 && out.size() > 1 ? magnification[1] : magnification[k];
    out[k].rmsDiameter *= m;
  }
  return out;
}

std::string focusSpotsSvg(const std::vector<SpotSeries>& series, double circleOfConfusion, const std::string& title) {
  // A logarithmic axis of spot / c from 0.1 to a whole decade: the spots span three decades. A
  // spot below 0.1 c (the ideal lens's zero) is drawn on the floor; a field point no ray reaches
  // (a real lens past its field) is left out.
  const double w = 640, h = 400, left = 70, right = 20, top = 40, bottom = 50, floor = 0.1;
  double yMax = 10.0;
  for (const SpotSeries& s : series)
    for (const FocusSpot& p : s.spots) yMax = std::max(yMax, p.rmsDiameter / circleOfConfusion);
  const double decades = std::ceil(std::log10(yMax / floor));
  const auto px = [&](double field) { return left + field * (w - left - right); };
  const auto py = [&](double y) {
    const double d = std::log10(std::max(y, floor) / floor);
    return h - bottom - d / decades * (h - top - bottom);
  };
  std::string svg;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%g\" height=\"%g\" font-family=\"sans-serif\" "
                "font-size=\"12\">\n<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n"
                "<text x=\"%g\" y=\"22\" font-size=\"14\">%s</text>\n",
                w, h, left, title.c_str());
  svg += buf;
  for (int t = 0; t <= int(decades); ++t) {
    const double y = floor * std::pow(10.0, t);
    std::snprintf(buf, sizeof buf,
                  "<line x1=\"%g\" y1=\"%.1f\" x2=\"%g\" y2=\"%.1f\" stroke=\"#ddd\"/>\n"
                  "<text x=\"%g\" y=\"%.1f\" text-anchor=\"end\">%g</text>\n",
                  left, py(y), w - right, py(y), left - 6, py(y) + 4, y);
    svg += buf;
  }
  for (int t = 0; t <= 4; ++t) {
    std::snprintf(buf, sizeof buf, "<text x=\"%.1f\" y=\"%g\" text-anchor=\"middle\">%g</text>\n", px(t / 4.0),
                  h - bottom + 18, t / 4.0);
    svg += buf;
  }
  std::snprintf(buf, sizeof buf,
                "<text x=\"%g\" y=\"%g\" text-anchor=\"middle\">image height (centre 0, corner 1)</text>\n"
                "<text x=\"16\" y=\"%g\" transform=\"rotate(-90 16 %g)\" text-anchor=\"middle\">RMS spot "
                "diameter / c (log)</text>\n"
                "<line x1=\"%g\" y1=\"%.1f\" x2=\"%g\" y2=\"%.1f\" stroke=\"black\" stroke-dasharray=\"4 3\"/>\n"
                "<text x=\"%g\" y=\"%.1f\" text-anchor=\"end\">c = d/1500: acceptably sharp</text>\n",
                (left + w - right) / 2, h - 12, (top + h - bottom) / 2, (top + h - bottom) / 2, left, py(1.0),
                w - right, py(1.0), w - right - 4, py(1.0) - 4);
  svg += buf;
  int row = 0;
  for (const SpotSeries& s : series) {
    svg += "<polyline fill=\"none\" stroke-width=\"2\" stroke=\"" + s.colour + "\" points=\"";
    for (const FocusSpot& p : s.spots) {
      if (!(p.passing > 0.0)) continue;
      std::snprintf(buf, sizeof buf, "%.1f,%.1f ", px(p.field), py(p.rmsDiameter / circleOfConfusion));
      svg += buf;
    }
    svg += "\"/>\n";
    std::snprintf(buf, sizeof buf,
                  "<line x1=\"%g\" y1=\"%d\" x2=\"%g\" y2=\"%d\" stroke-width=\"2\" stroke=\"%s\"/>"
                  "<text x=\"%g\" y=\"%d\">",
                  left + 12, 58 + 16 * row, left + 32, 58 + 16 * row, s.colour.c_str(), left + 38, 62 + 16 * row);
    svg += buf;
    svg += s.label + "</text>\n";
    ++row;
  }
  svg += "</svg>\n";
  return svg;
}

}  // namespace lensfarm
