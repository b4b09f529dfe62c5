#include "common/film/diffraction_psf.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "common/camera/aperture.h"
#include "common/math/real_fft2d.h"

namespace lensfarm {

double FraunhoferPattern::at(double x, double y) const {
  const double u = x / spacing + size / 2, v = y / spacing + size / 2;
  const double fu = std::floor(u), fv = std::floor(v);
  if (!(fu >= 0.0 && fv >= 0.0 && fu < size - 1 && fv < size - 1)) return 0.0;
  const size_t c = size_t(fu), r = size_t(fv);
  const double a = u - fu, b = v - fv;
  const double* row = &intensity[r * size_t(size) + c];
  return (1.0 - b) * ((1.0 - a) * row[0] + a * row[1]) + b * ((1.0 - a) * row[size] + a * row[size + 1]);
}

FraunhoferPattern fraunhoferPattern(int blades, double rotation, int gridSize, int padding) {
  return fraunhoferPattern(Aperture(ApertureSpec{blades, rotation * 180.0 / std::acos(-1.0), 0.0, nullptr}), gridSize,
                           padding);
}

FraunhoferPattern fraunhoferPattern(const Aperture& aperture, int gridSize, int padding) {
  if (gridSize < 8 || (gridSize & (gridSize - 1)) || padding < 2 || gridSize % padding)
    throw std::invalid_argument("fraunhoferPattern: the grid must be a power of two and the padding >= 2");
  const int n = gridSize, m = gridSize / padding;
  // The pupil's transmission over its bounding square (Aperture::rasterize: row 0 at the top),
  // placed with row 0 at the bottom so that the pattern's rows run along `up`.
  std::vector<float> pupil;
  aperture.rasterize(m, pupil);
  RealFft2d fft(n, n);
  double* field = fft.data();
  for (int r = 0; r < m; ++r)
    for (int c = 0; c < m; ++c) field[size_t(r) * n + c] = pupil[size_t(m - 1 - r) * m + c];  // the rest stays 0
  fft.forward();
  // |F|^2 over the whole plane from the half FFTW keeps (F(-k) = conj F(k)), moved so that zero
  // frequency sits at (n/2, n/2). Where the pupil sits in the grid only changes F's phase.
  FraunhoferPattern out;
  out.size = n;
  out.spacing = 1.0 / padding;
  out.intensity.assign(size_t(n) * n, 0.0);
  const int half = n / 2 + 1;
  const std::complex<double>* spectrum = fft.spectrum();
  double total = 0.0;
  for (int ky = 0; ky < n; ++ky)
    for (int kx = 0; kx < n; ++kx) {
      const bool stored = kx < half;
      const int sy = stored ? ky : (n - ky) % n, sx = stored ? kx : n - kx;
      const double power = std::norm(spectrum[size_t(sy) * half + sx]);
      out.intensity[size_t((ky + n / 2) % n) * n + size_t((kx + n / 2) % n)] = power;
      total += power;
    }
  for (double& v : out.intensity) v /= total;
  return out;
}

std::vector<double> channelWavelengths(int channel, int perChannel) {
  const double lo = 600.0 - 100.0 * channel;  // red 600-700, green 500-600, blue 400-500 nm
  std::vector<double> out;
  for (int k = 0; k < perChannel; ++k) out.push_back(lo + 100.0 * (k + 0.5) / perChannel);
  return out;
}

namespace {
// Up to this many cells a pattern sample, the pattern is splatted; beyond, sampled at points.
constexpr double kSplatBelow = 2.0;

// The integral over [lo, hi] of the unit-area tent of half-width s centred at 0.
double tentIntegral(double lo, double hi, double s) {
  const auto cdf = [s](double u) {
    if (u <= -s) return 0.0;
    if (u >= s) return 1.0;
    return u <= 0.0 ? (u + s) * (u + s) / (2 * s * s) : 1.0 - (s - u) * (s - u) / (2 * s * s);
  };
  return cdf(hi) - cdf(lo);
}

// Adds `share` of the pattern, at `sampleMm` on the sensor, integrated over each cell of the kernel
// exactly as its bilinear interpolant: sample j's value spreads by the tent (1 - |x - x_j| / s) / s
// in each axis, whose integral over the cells is 1 (every sample's energy lands somewhere).
// Image rows run down, the sensor's `up` the other way; the pattern is point-symmetric (|FT|^2 of
// a real pupil), so the lens's inversion leaves it as it is.
void splatPattern(const FraunhoferPattern& pattern, double sampleMm, double pitchX, double pitchY, double share,
                  int radius, std::vector<double>& kernel) {
  const int n = pattern.size, side = 2 * radius + 1;
  // The weights of the cells a sample at `x` (mm) reaches along one axis, from cell `first` on.
  const auto weights = [&](double x, double pitch, int& first, std::vector<double>& w) {
    w.clear();
    first = int(std::floor((x - sampleMm) / pitch + 0.5));
    const int last = int(std::floor((x + sampleMm) / pitch + 0.5));
    for (int d = first; d <= last; ++d)
      w.push_back(tentIntegral((d - 0.5) * pitch - x, (d + 0.5) * pitch - x, sampleMm));
  };
  std::vector<double> wx, wy;
  for (int r = 0; r < n; ++r) {
    int firstY;
    weights(-(r - n / 2) * sampleMm, pitchY, firstY, wy);
    if (firstY > radius || firstY + int(wy.size()) - 1 < -radius) continue;
    for (int c = 0; c < n; ++c) {
      int firstX;
      weights((c - n / 2) * sampleMm, pitchX, firstX, wx);
      if (firstX > radius || firstX + int(wx.size()) - 1 < -radius) continue;
      const double v = share * pattern.intensity[size_t(r) * n + c];
      for (size_t j = 0; j < wy.size(); ++j) {
        const int dy = firstY + int(j);
        if (dy < -radius || dy > radius) continue;
        double* row = &kernel[size_t(dy + radius) * side];
        for (size_t i = 0; i < wx.size(); ++i) {
          const int dx = firstX + int(i);
          if (dx >= -radius && dx <= radius) row[dx + radius] += v * wy[j] * wx[i];
        }
      }
    }
  }
}

// The crop's taper at `rho` cells from the centre: 1 within `inner` cells, a raised cosine down to
// 0 at the kernel's edge (radius + 1/2), so that the truncated tail of a very bright light's
// pattern fades out instead of ending at a visible square; round, so no square shows either.
double kernelWindow(double rho, double inner, int radius) {
  const double outer = radius + 0.5, start = std::min(inner, 0.5 * outer);
  if (rho <= start) return 1.0;
  if (rho >= outer) return 0.0;
  return 0.5 * (1.0 + std::cos(std::acos(-1.0) * (rho - start) / (outer - start)));
}

// The smallest half-width h (in the pattern's samples) of the centred square holding `share` of
// the pattern's energy.
int halfWidthHolding(const FraunhoferPattern& pattern, double share) {
  const int n = pattern.size;
  std::vector<double> ring(size_t(n / 2 + 1), 0.0);  // energy at Chebyshev distance h from the centre
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c)
      ring[size_t(std::min(std::max(std::abs(r - n / 2), std::abs(c - n / 2)), n / 2))] +=
          pattern.intensity[size_t(r) * n + c];
  double sum = 0.0;
  for (int h = 0; h <= n / 2; ++h)
    if ((sum += ring[size_t(h)]) >= share) return h;
  return n / 2;
}
}  // namespace

DiffractionKernel diffractionKernel(const FraunhoferPattern& pattern, const DiffractionOptics& optics,
                                    int wavelengthsPerChannel) {
  const double pitchX = optics.pixelWidthMm, pitchY = optics.pixelHeightMm;
  const double lambdaNMax = 700.0e-6 * optics.workingFNumber;  // mm: the widest pattern's unit
  // The crop: twice the square holding kKeptEnergy at the reddest wavelength (in cells), within
  // the image's size; the kernel is tapered to 0 beyond that square (kernelWindow).
  const double pitch = std::min(pitchX, pitchY);
  const double inner = (halfWidthHolding(pattern, kKeptEnergy) + 1) * pattern.spacing * lambdaNMax / pitch;
  DiffractionKernel k;
  k.radius = std::max(1, int(std::min<double>(std::ceil(2.0 * inner), std::max(optics.width, optics.height))));
  const int side = 2 * k.radius + 1;
  k.keptEnergy = 1.0;
  for (int c = 0; c < 3; ++c) {
    std::vector<double>& kernel = k.channel[size_t(c)];
    kernel.assign(size_t(side) * side, 0.0);
    const std::vector<double> wavelengths = channelWavelengths(c, wavelengthsPerChannel);
    for (double lambda : wavelengths) {
      const double unit = lambda * 1e-6 * optics.workingFNumber;  // lambda N_w, mm
      const double sampleMm = pattern.spacing * unit;             // the pattern's spacing on the sensor
      const double share = 1.0 / double(wavelengths.size());
      if (sampleMm <= kSplatBelow * std::min(pitchX, pitchY)) {
        splatPattern(pattern, sampleMm, pitchX, pitchY, share, k.radius, kernel);
        continue;
      }
      // Cells smaller than the pattern's samples: the bilinear interpolant at 2 x 2 points a cell
      // (exact where a cell lies within one interpolation square), each point standing for a
      // quarter of the cell, the pattern's value for sampleMm^2.
      const double weight = (pitchX / 2) * (pitchY / 2) / (sampleMm * sampleMm) * share;
      for (int dy = -k.radius; dy <= k.radius; ++dy)
        for (int dx = -k.radius; dx <= k.radius; ++dx) {
          double sum = 0.0;
          for (int sy = 0; sy < 2; ++sy) {
            const double y = -(dy - 0.25 + 0.5 * sy) * pitchY / unit;  // image rows run down, `up` up
            for (int sx = 0; sx < 2; ++sx) sum += pattern.at((dx - 0.25 + 0.5 * sx) * pitchX / unit, y);
          }
          kernel[size_t(dy + k.radius) * side + size_t(dx + k.radius)] += sum * weight;
        }
    }
    double kept = 0.0;
    for (int dy = -k.radius; dy <= k.radius; ++dy)
      for (int dx = -k.radius; dx <= k.radius; ++dx) {
        double& v = kernel[size_t(dy + k.radius) * side + size_t(dx + k.radius)];
        v *= kernelWindow(std::hypot(dx * pitchX, dy * pitchY) / pitch, inner, k.radius);
        kept += v;
      }
    k.keptEnergy = std::min(k.keptEnergy, kept);
    for (double& v : kernel) v /= kept;
  }
  return k;
}

}  // namespace lensfarm
