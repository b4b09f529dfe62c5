#pragma once
// A real lens's prescription as JSON (docs/scene-format.md "Lens prescriptions"): inline as the
// real_lens camera's `lens`, or a `.json` lens file that the scene's `lens` and `lensfarm lens`
// name. One object:
//   {"name": "...", "source": "...", "focal_length": 50, "f_number": 2, "projection": "...",
//    "surfaces": [{"radius": 29.475, "thickness": 3.76, "index": 1.67, "abbe": 47.1,
//                  "aperture": 25.2, "conic": -0.5, "aspheric": [A4, A6, ...]},
//                 {"stop": true, "radius": 0, "thickness": 4, "aperture": 17.1}, ...]}
// Units and conventions are lens_system.h's (mm; radius > 0 centred toward the image; index and
// abbe of the medium after the surface; the even asphere's conic k and A4 .. A16). The metadata
// (name, source, focal_length, f_number, projection, notes) is read and kept for reports; the
// tracer uses the surfaces only. Every error names the field's path, e.g.
// `camera.lens.surfaces[3].radius` (0-based, as JSON indexes arrays).
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "common/camera/lens_system.h"

namespace lensfarm {

struct LensPrescription {
  LensSystem system;
  std::string name, source, projection;  // empty when not given
  std::optional<double> focalLength, fNumber;
};

// `object` at field path `path` ("" for a lens file's top level) of `file`.
LensPrescription lensFromJson(const nlohmann::json& object, const std::string& path, const std::string& file);

// A lens file's text: a JSON prescription when its first non-blank character is '{', else
// pbrt-v4's tabular format (LensSystem::parsePbrt). InputError naming `file`.
LensPrescription readLensFile(const std::string& text, const std::string& file);

}  // namespace lensfarm
