// JSON lens prescriptions (lens_prescription.h).
#include "common/scene/lens_prescription.h"

#include "common/util/field_reader.h"

namespace lensfarm {

LensPrescription lensFromJson(const nlohmann::json& object, const std::string& path, const std::string& file) {
  FieldReader r(object, path, file);
  std::vector<LensSurface> surfaces;
  const json& list = r.raw("surfaces");
  const std::string listField = r.field("surfaces");
  if (!list.is_array() || list.empty()) r.fail(listField, "must be an array of surfaces, front (object side) first");
  for (size_t k = 0; k < list.size(); ++k) {
    const std::string at = listField + "[" + std::to_string(k) + "]";
    FieldReader s(list[k], at, file);
    LensSurface surface;
    surface.stop = s.boolean("stop", false);
    surface.radius =
        surface.stop ? s.number("radius", 0.0, -std::numeric_limits<double>::max(), std::numeric_limits<double>::max())
                     : s.number("radius");
    surface.thickness = s.number("thickness");
    surface.aperture = s.number("aperture");
    if (surface.stop && s.has("index"))
      s.fail(s.field("index"), "the aperture stop does not change the medium: leave index (and abbe) out");
    surface.index = s.number("index", 1.0, 1.0, 4.0);
    surface.abbe = s.number("abbe", 0.0, 0.0, 1e6);
    surface.conic = s.number("conic", 0.0, -std::numeric_limits<double>::max(), std::numeric_limits<double>::max());
    if (s.has("aspheric")) {
      const json& a = s.raw("aspheric");
      if (!a.is_array()) s.fail(s.field("aspheric"), "must be an array of numbers: A4, A6, ... A16");
      for (size_t i = 0; i < a.size(); ++i)
        surface.aspheric.push_back(s.checkNumber(a[i], s.field("aspheric") + "[" + std::to_string(i) + "]",
                                                 -std::numeric_limits<double>::max(),
                                                 std::numeric_limits<double>::max()));
    }
    if (const std::optional<LensSystem::SurfaceProblem> bad = LensSystem::problemWith(surface))
      s.fail(s.field(bad->field), bad->why);
    s.finish();
    surfaces.push_back(std::move(surface));
  }
  LensPrescription p{LensSystem(std::move(surfaces), path.empty() ? file : file + ": " + path), "", "", "", {}, {}};
  p.name = r.string("name", "");
  p.source = r.string("source", "");
  p.projection = r.string("projection", "");
  (void)r.string("notes", "");
  if (r.has("focal_length")) p.focalLength = r.number("focal_length", 1e-6, 1e9);
  if (r.has("f_number")) p.fNumber = r.number("f_number", 1e-6, 1e9);
  r.finish();
  return p;
}

LensPrescription readLensFile(const std::string& text, const std::string& file) {
  const size_t first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos || text[first] != '{')
    return LensPrescription{LensSystem::parsePbrt(text, file), "", "", "", {}, {}};
  json object;
  try {
    object = json::parse(text);
  } catch (const json::parse_error& e) {
    throw InputError(file, std::string("not valid JSON: ") + e.what());
  }
  return lensFromJson(object, "", file);
}

}  // namespace lensfarm
