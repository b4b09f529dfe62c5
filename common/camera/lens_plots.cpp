// SVG plots of a real lens (lens_plots.h).
#include "common/camera/lens_plots.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace lensfarm {

namespace {

std::string format(const char* fmt, double a, double b = 0.0, double c = 0.0, double d = 0.0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, fmt, a, b, c, d);
  return buf;
}

// A tick step of 1, 2 or 5 x 10^k giving about 5 ticks over `span`.
double tickStep(double span) {
  const double raw = span / 5.0, decade = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0})
    if (m * decade >= raw) return m * decade;
  return 10.0 * decade;
}

std::string escaped(const std::string& s) {
  std::string out;
  for (char c : s) out += c == '<' ? std::string("&lt;") : c == '&' ? std::string("&amp;") : std::string(1, c);
  return out;
}

constexpr double kWidth = 560, kHeight = 360, kLeft = 64, kRight = 150, kTop = 36, kBottom = 48;

}  // namespace

std::string linePlotSvg(const std::string& title, const std::string& xLabel, const std::string& yLabel,
                        const std::vector<PlotSeries>& series) {
  double x0 = 1e300, x1 = -1e300, y0 = 0.0, y1 = 0.0;
  for (const PlotSeries& s : series)
    for (const auto& [x, y] : s.points)
      x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
  if (!(x1 > x0)) x1 = x0 + 1.0;
  if (!(y1 > y0)) y1 = y0 + 1.0;
  const double yStep = tickStep(y1 - y0), xStep = tickStep(x1 - x0);
  y0 = std::floor(y0 / yStep) * yStep, y1 = std::ceil(y1 / yStep) * yStep;
  const double w = kWidth - kLeft - kRight, h = kHeight - kTop - kBottom;
  const auto px = [&](double x) { return kLeft + (x - x0) / (x1 - x0) * w; };
  const auto py = [&](double y) { return kTop + (y1 - y) / (y1 - y0) * h; };
  std::string svg = format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 %g %g\" width=\"%g\" height=\"%g\" "
      "font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n",
      kWidth, kHeight, kWidth, kHeight);
  svg += "<text x=\"" + format("%g", kLeft) + "\" y=\"20\" font-size=\"14\">" + escaped(title) + "</text>\n";
  for (double y = y0; y <= y1 + 1e-9 * yStep; y += yStep) {
    svg +=
        format("<line x1=\"%g\" y1=\"%.2f\" x2=\"%g\" y2=\"%.2f\" stroke=\"#ddd\"/>", kLeft, py(y), kLeft + w, py(y));
    svg += format("<text x=\"%g\" y=\"%.2f\" text-anchor=\"end\">%g</text>\n", kLeft - 6, py(y) + 4,
                  std::abs(y) < 1e-12 ? 0.0 : y);
  }
  for (double x = std::ceil(x0 / xStep) * xStep; x <= x1 + 1e-9 * xStep; x += xStep) {
    svg += format("<line x1=\"%.2f\" y1=\"%g\" x2=\"%.2f\" y2=\"%g\" stroke=\"#ddd\"/>", px(x), kTop, px(x), kTop + h);
    svg += format("<text x=\"%.2f\" y=\"%g\" text-anchor=\"middle\">%g</text>\n", px(x), kTop + h + 16, x);
  }
  svg +=
      format("<rect x=\"%g\" y=\"%g\" width=\"%g\" height=\"%g\" fill=\"none\" stroke=\"#000\"/>\n", kLeft, kTop, w, h);
  svg += format("<text x=\"%g\" y=\"%g\" text-anchor=\"middle\">", kLeft + w / 2, kHeight - 10) + escaped(xLabel) +
         "</text>\n";
  svg += format("<text transform=\"translate(16 %g) rotate(-90)\" text-anchor=\"middle\">", kTop + h / 2) +
         escaped(yLabel) + "</text>\n";
  for (size_t i = 0; i < series.size(); ++i) {
    const PlotSeries& s = series[i];
    std::string points;
    for (const auto& [x, y] : s.points) points += format("%.2f,%.2f ", px(x), py(y));
    svg += "<polyline fill=\"none\" stroke=\"" + s.colour + "\" stroke-width=\"2\"" +
           (s.dashed ? " stroke-dasharray=\"6 4\"" : "") + " points=\"" + points + "\"/>\n";
    const double ly = kTop + 14 + 20 * double(i);
    svg += format("<line x1=\"%g\" y1=\"%g\" x2=\"%g\" y2=\"%g\" stroke=\"", kLeft + w + 10, ly, kLeft + w + 34, ly) +
           s.colour + "\" stroke-width=\"2\"" + (s.dashed ? " stroke-dasharray=\"6 4\"" : "") + "/>";
    svg += format("<text x=\"%g\" y=\"%g\">", kLeft + w + 40, ly + 4) + escaped(s.name) + "</text>\n";
  }
  return svg + "</svg>\n";
}

std::string distortionSvg(const std::vector<FieldPoint>& field) {
  PlotSeries s{"distortion", "#c40", {}, false};
  for (const FieldPoint& f : field)
    if (f.transmitted > 0.0) s.points.emplace_back(f.angleDegrees, 100.0 * f.distortion);
  return linePlotSvg("Distortion (real image height / f tan(angle) - 1)", "field angle (degrees)", "distortion (%)",
                     {s});
}

std::string illuminationSvg(const std::vector<IlluminationPoint>& table) {
  PlotSeries ri{"relative illumination", "#06c", {}, false}, area{"vignetting (beam area)", "#090", {}, true},
      cos4{"cos^4 (angle)", "#888", {}, true};
  for (const IlluminationPoint& p : table) {
    ri.points.emplace_back(p.imageHeight, p.relative);
    area.points.emplace_back(p.imageHeight, p.area);
    const double c = std::cos(p.angleDegrees * 3.14159265358979323846 / 180.0);
    cos4.points.emplace_back(p.imageHeight, c * c * c * c);
  }
  return linePlotSvg("Relative illumination (object at infinity)", "image height (mm)", "relative to the axis",
                     {ri, area, cos4});
}

std::string spotDiagramsSvg(const LensSystem& lens, const std::vector<double>& angles, double filmZ) {
  const LensSystem::Paraxial p = lens.paraxial();
  const double airy = 1.22 * LensSystem::kWavelengthD * 1e-6 * p.efl / p.entrancePupilDiameter;  // mm
  // One scale for every panel: the largest distance of a ray from its centroid, or the Airy ring.
  std::vector<std::vector<DVec3>> spots;
  std::vector<DVec3> centroids;
  double reach = 2.0 * airy;
  for (double a : angles) {
    spots.push_back(spotHits(lens, a, filmZ, 17));
    DVec3 c(0.0);
    for (const DVec3& h : spots.back()) c += h;
    if (!spots.back().empty()) c /= double(spots.back().size());
    centroids.push_back(c);
    for (const DVec3& h : spots.back()) reach = std::max(reach, std::hypot(h.x - c.x, h.y - c.y));
  }
  const double panel = 180, gap = 12, side = panel / 2 - 10;
  const double width = double(angles.size()) * (panel + gap) + gap, height = panel + 70;
  std::string svg = format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 %g %g\" width=\"%g\" height=\"%g\" "
      "font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n",
      width, height, width, height);
  svg += format(
      "<text x=\"%g\" y=\"18\" font-size=\"14\">Spot diagrams (panel half-width %.4g mm; circle: Airy disk, radius "
      "%.4g mm)</text>\n",
      gap, reach, airy);
  for (size_t k = 0; k < angles.size(); ++k) {
    const double cx = gap + double(k) * (panel + gap) + panel / 2, cy = 30 + panel / 2, s = side / reach;
    svg += format("<rect x=\"%g\" y=\"%g\" width=\"%g\" height=\"%g\" fill=\"none\" stroke=\"#999\"/>\n",
                  cx - panel / 2, cy - panel / 2, panel, panel);
    svg += format("<circle cx=\"%g\" cy=\"%g\" r=\"%.3f\" fill=\"none\" stroke=\"#c00\"/>\n", cx, cy, airy * s);
    for (const DVec3& h : spots[k])
      svg += format("<circle cx=\"%.2f\" cy=\"%.2f\" r=\"0.9\" fill=\"#024\"/>", cx + (h.x - centroids[k].x) * s,
                    cy - (h.y - centroids[k].y) * s);
    svg += format("\n<text x=\"%g\" y=\"%g\" text-anchor=\"middle\">%.1f deg, h = %.2f mm</text>\n", cx,
                  cy + panel / 2 + 18, angles[k], centroids[k].y);
    svg += format("<text x=\"%g\" y=\"%g\" text-anchor=\"middle\">%g rays</text>\n", cx, cy + panel / 2 + 34,
                  double(spots[k].size()));
  }
  return svg + "</svg>\n";
}

}  // namespace lensfarm
