#pragma once
// A real lens: a sequence of refracting surfaces, from its prescription (docs/optics.md
// "Real lenses"). The issue-23 answer to the report's future work ("more advanced optical systems
// for simulation of cameras").
//
// Units and conventions (written once, here):
//  - Lengths in millimetres, as lens prescriptions give them.
//  - The optical axis is +z, from the object side (the scene) toward the image side (the film).
//    Surface 0 is the front (object-side) surface; its vertex is at z = 0; surface k's vertex is
//    at the sum of the thicknesses before it.
//  - A surface's radius R > 0 has its centre of curvature on the image side (+z) of its vertex,
//    R < 0 on the object side; R = 0 is flat (the aperture stop is flat).
//  - `index` and `abbe` describe the medium after a surface (toward the image), at the Fraunhofer
//    d line (587.56 nm); air is index 1 (pbrt's files write 0 for the air after the stop).
//  - Dispersion: the index at wavelength lambda follows Cauchy's two-term law n = A + B / lambda^2,
//    fitted so that n(d) = n_d and n(F) - n(C) = (n_d - 1) / V_d (the Abbe number's definition;
//    F = 486.13 nm, C = 656.27 nm). Media with V_d = 0 do not disperse.
//
// Paraxial (first-order) optics uses ray-transfer matrices in reduced angles (height y, n u):
// refraction at a surface of curvature c = 1/R from index n to n':  n'u' = n u - y (n' - n) c,
// transfer over thickness t in index n:  y' = y + t u  (Hecht, Optics, 5th ed., §6.2).
#include <optional>
#include <string>
#include <vector>

#include "math/vec.h"

namespace lensfarm {

struct LensSurface {
  double radius = 0.0;     // mm; 0: flat
  double thickness = 0.0;  // mm, along the axis to the next surface (the last: to the film at its design focus, or 0)
  double index = 1.0;      // of the medium after it, at the d line
  double abbe = 0.0;       // of that medium; 0: no dispersion
  double aperture = 0.0;   // mm, clear diameter
  bool stop = false;       // the aperture stop (flat, in air)
};

// A ray in the lens's frame (mm; see above).
struct LensRay {
  DVec3 origin;
  DVec3 direction;  // unit
};

class LensSystem {
 public:
  // Validates the prescription: InputError whose `where` is `where` + " surface K" (1-based) for
  // a surface without a positive finite aperture, a non-finite radius or thickness, a negative
  // thickness, an index below 1 (or above 4), a negative Abbe number, or an aperture wider than
  // its sphere (|R| < aperture / 2); `where` alone without exactly one stop or with no surface.
  LensSystem(std::vector<LensSurface> surfaces, const std::string& where);

  // pbrt-v4's tabular lens files (RealisticCamera): '#' comments, then one surface a line,
  // "radius thickness index aperture-diameter" in mm, front surface first; a radius of 0 is the
  // aperture stop (index 0 or 1). An optional fifth column is the Abbe number (lensfarm's
  // extension; pbrt ignores it). InputError naming `file` and the line.
  static LensSystem parsePbrt(const std::string& text, const std::string& file);

  const std::vector<LensSurface>& surfaces() const { return surfaces_; }
  size_t stopIndex() const { return stop_; }
  double vertexZ(size_t k) const { return vertexZ_[k]; }  // z of surface k's vertex
  double totalTrack() const { return vertexZ_.back(); }   // front vertex to last vertex
  bool disperses() const;                                 // some medium has an Abbe number

  // The index of the medium after surface k (k = -1: the object space, air) at `wavelengthNm`.
  double indexAfter(int k, double wavelengthNm) const;

  // First-order properties at the d line (or `wavelengthNm`), for an object at infinity.
  struct Paraxial {
    double efl = 0.0;  // effective focal length: 1 / power
    double bfl = 0.0;  // back focal length: last vertex to the rear focal point
    double ffl = 0.0;  // front focal length: front focal point to the front vertex
    double rearPrincipalZ = 0.0, frontPrincipalZ = 0.0;    // principal planes
    double entrancePupilZ = 0.0, entrancePupilDiameter = 0.0;  // the stop seen from the object side
    double exitPupilZ = 0.0, exitPupilDiameter = 0.0;          // the stop seen from the image side
    double fNumber = 0.0;      // efl / entrance pupil diameter
    double petzvalSum = 0.0;   // sum over surfaces of (n' - n) / (n n' R), 1/mm
  };
  Paraxial paraxial(double wavelengthNm = kWavelengthD) const;

  // The distance from the last vertex to the film that focuses an object at `distance` mm in
  // front of the front vertex (infinity: the rear focal point), paraxially; nullopt if the
  // image is virtual (the object is inside the front focal length).
  std::optional<double> focusDistanceFromRear(double objectDistance, double wavelengthNm = kWavelengthD) const;

  // Exact tracing (Snell's law at each sphere, vector form). From the image side: `ray` starts
  // behind the last surface heading toward -z; the result leaves the front surface into the
  // scene. nullopt if it misses a surface, hits outside a clear aperture (vignetting) or is
  // totally internally reflected.
  std::optional<LensRay> traceFromImageSide(LensRay ray, double wavelengthNm = kWavelengthD) const;
  // From the object side: `ray` heads toward +z in front of surface 0; the result leaves the last
  // surface toward the film.
  // `hits`, if given, receives the point on each surface passed (for drawings).
  std::optional<LensRay> traceFromObjectSide(LensRay ray, double wavelengthNm = kWavelengthD,
                                             std::vector<DVec3>* hits = nullptr) const;

  static constexpr double kWavelengthD = 587.56, kWavelengthF = 486.13, kWavelengthC = 656.27;

 private:
  // Traces through surfaces `first` .. `last` in the direction `step` (+1 or -1).
  std::optional<LensRay> trace(LensRay ray, int first, int last, int step, double wavelengthNm,
                               std::vector<DVec3>* hits) const;

  std::vector<LensSurface> surfaces_;
  std::vector<double> vertexZ_;
  size_t stop_ = 0;
};

}  // namespace lensfarm
