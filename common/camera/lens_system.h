#pragma once
// A real lens: a sequence of refracting surfaces, from its prescription (docs/optics.md
// "Real lenses"). The answer to the report's future work ("more advanced optical systems for
// simulation of cameras").
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
//  - Aspheric surfaces: the even asphere of ISO 10110-12 (and Zemax's / Code V's "even asphere"),
//    sag along +z from the vertex at height r from the axis
//        z(r) = c r^2 / (1 + sqrt(1 - (1 + k) c^2 r^2)) + A4 r^4 + A6 r^6 + ... + A16 r^16,
//    c = 1/R the vertex curvature, k the conic constant (0 sphere, -1 paraboloid, < -1 hyperboloid,
//    -1 < k < 0 prolate and k > 0 oblate ellipsoid). A sphere is k = 0 with no coefficients, and
//    keeps its closed-form intersection; an asphere is intersected by Newton's method.
//
// Paraxial (first-order) optics uses ray-transfer matrices in reduced angles (height y, n u):
// refraction at a surface of curvature c = 1/R from index n to n':  n'u' = n u - y (n' - n) c,
// transfer over thickness t in index n:  y' = y + t u  (Hecht, Optics, 5th ed., §6.2).
#include <optional>
#include <string>
#include <vector>

#include "common/math/vec.h"

namespace lensfarm {

struct LensSurface {
  double radius = 0.0;     // mm; 0: flat
  double thickness = 0.0;  // mm, along the axis to the next surface (the last: to the film at its design focus, or 0)
  double index = 1.0;      // of the medium after it, at the d line
  double abbe = 0.0;       // of that medium; 0: no dispersion
  double aperture = 0.0;   // mm, clear diameter
  bool stop = false;       // the aperture stop (flat, in air)
  double conic = 0.0;      // k of the even asphere (see above); 0: a sphere
  std::vector<double> aspheric{};  // A4, A6, ... A16 (mm^-3, mm^-5, ...); empty: none

  bool spherical() const;  // k = 0 and every A = 0: the sphere's closed-form path
  // The sag z(r) from the vertex at height r (mm); NaN where the conic is not defined (beyond
  // its rim, 1 - (1 + k) c^2 r^2 < 0). Flat surfaces: 0.
  double sag(double r) const;
  // dz/dr at r: the conic's c r / sqrt(1 - (1 + k) c^2 r^2) + sum 2i A_2i r^(2i - 1).
  double sagSlope(double r) const;
  static constexpr size_t kMaxAspheric = 7;  // A4 .. A16
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
  // thickness, an index below 1 (or above 4), a negative Abbe number, an aperture wider than
  // its sphere (|R| < aperture / 2) or, for an asphere, than its conic's rim; `where` alone without exactly one stop or
  // with no surface.
  LensSystem(std::vector<LensSurface> surfaces, const std::string& where);

  // pbrt-v4's tabular lens files (RealisticCamera): '#' comments, then one surface a line,
  // "radius thickness index aperture-diameter" in mm, front surface first; a radius of 0 is the
  // aperture stop (index 0 or 1). An optional fifth column is the Abbe number (lensfarm's
  // extension; pbrt ignores it). InputError naming `file` and the line.
  // The first problem with surface `s`'s own numbers (the checks above but the index, which a
  // stop takes from the medium before it, and the count of stops): the field at fault
  // ("radius", "thickness", "aperture", "abbe", "conic", "aspheric") and why; nullopt if none.
  // The constructor and the JSON prescription reader (scene/lens_prescription.h) share it.
  struct SurfaceProblem {
    std::string field, why;
  };
  static std::optional<SurfaceProblem> problemWith(const LensSurface& s);

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
    double efl = 0.0;                                    // effective focal length: 1 / power
    double bfl = 0.0;                                    // back focal length: last vertex to the rear focal point
    double ffl = 0.0;                                    // front focal length: front focal point to the front vertex
    double rearPrincipalZ = 0.0, frontPrincipalZ = 0.0;  // principal planes
    double entrancePupilZ = 0.0, entrancePupilDiameter = 0.0;  // the stop seen from the object side
    double exitPupilZ = 0.0, exitPupilDiameter = 0.0;          // the stop seen from the image side
    double fNumber = 0.0;                                      // efl / entrance pupil diameter
    double petzvalSum = 0.0;                                   // sum over surfaces of (n' - n) / (n n' R), 1/mm
  };
  Paraxial paraxial(double wavelengthNm = kWavelengthD) const;

  // The distance from the last vertex to the film that focuses an object at `distance` mm in
  // front of the front vertex (infinity: the rear focal point), paraxially; nullopt if the
  // image is virtual (the object is inside the front focal length).
  std::optional<double> focusDistanceFromRear(double objectDistance, double wavelengthNm = kWavelengthD) const;

  // The exact focus: the film distance behind the last vertex (as focusDistanceFromRear) at which
  // the rays from the axial object point at `objectDistance` (infinity: a parallel beam), filling
  // the entrance pupil on a 64 x 64 grid and traced exactly, have the smallest RMS spot radius.
  // Every ray's hit on a film plane moves linearly with the plane's position, so the spot's
  // variance is a quadratic in it and its minimum is found in closed form (no search, no
  // tolerance; the same bits on every machine). The paraxial focus is the start: nullopt where it
  // is (a virtual image) or where fewer than 8 rays get through.
  struct ExactFocus {
    double paraxial = 0.0;     // focusDistanceFromRear
    double exact = 0.0;        // the least-RMS film distance
    double paraxialRms = 0.0;  // the on-axis spot's RMS radius there, mm
    double exactRms = 0.0;
    int rays = 0;  // rays traced through
  };
  std::optional<ExactFocus> exactFocus(double objectDistance, double wavelengthNm = kWavelengthD) const;

  // Exact tracing (Snell's law at each surface, vector form; the normal of an asphere from its
  // sag's gradient). From the image side: `ray` starts
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
