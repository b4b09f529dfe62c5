#pragma once
// Typed, range-checked reading of the scene file's JSON objects (docs/scene-format.md, "Value
// types"): every error names the file and the field, and fields nobody asked for are reported
// (a typo must not be ignored). Shared by the scene loader and the material types
// (material/material.cpp), which parse their own fields.
#include <cmath>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "common/math/vec.h"
#include "common/util/error.h"
#include "common/util/spelling.h"

namespace lensfarm {

using json = nlohmann::json;

// What a colour channel may be: 0, or a number in [lo, hi] that the single-precision kernel
// carries through a path (docs/scene-format.md, "Value types"; docs/numerics.md, "Extreme values").
struct ColorRange {
  double lo, hi;
  const char* belowWhy;  // why (0, lo) is refused
  const char* aboveWhy;  // why a value above hi is refused
};
// Albedos and reflectances. Above 1 a surface would reflect more than it receives. Below 1e-6 it
// is darker than any real material (the blackest coatings reflect about 4e-4), and a path through
// it would fall below single precision with the dimmest radiance (1e-30 x 1e-6 = 1e-36 is still
// above the smallest normal float, 1.2e-38; the kernel flushes anything smaller to 0).
inline constexpr ColorRange kReflectanceRange{
    1e-6, 1.0,
    "a reflectance below 1e-6 is darker than any real material and would be lost below single precision "
    "(the kernel flushes numbers under 1.2e-38 to 0); write 0 for black",
    "a reflectance is the fraction of light a surface reflects: above 1 it would make light from nothing"};
// Radiance and emission. The kernel multiplies radiance by path weights in single precision
// (3.4e38 at most, numbers under 1.2e-38 flushed to 0): 1e30 leaves 10^8 of headroom for the
// weights of a path (albedos, cosines, 1/pdf) before a sample overflows to Inf (and is dropped);
// 1e-30 keeps a path's contribution (radiance x weights, down to ~1e-8) a normal number, so a
// dim scene is never silently black.
inline constexpr ColorRange kRadianceRange{
    1e-30, 1e30,
    "below 1e-30, radiance times a path's weights falls under single precision's smallest normal number "
    "(1.2e-38), which the kernel flushes to 0: the image would be silently black; choose a larger radiance unit "
    "(the EXR stores the same unit)",
    "above 1e30, radiance times a path's weights (up to ~1e8) overflows single precision (3.4e38); choose a "
    "smaller radiance unit (the EXR stores the same unit)"};

// ---------------------------------------------------------------------------------------------
// FieldReader: typed, range-checked access to one JSON object that remembers which keys were
// read, so that anything left over is reported as an unknown field (a typo must not be ignored).
class FieldReader {
 public:
  FieldReader(const json& object, std::string path, const std::string& file)
      : object_(object), path_(std::move(path)), file_(file) {
    if (!object_.is_object()) fail(path_.empty() ? "(top level)" : path_, "must be a JSON object");
  }

  // A field missing from the object ("is required", "give exactly one of ...") is often there
  // under a slightly different name: the message then shows it.
  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw InputError(file_, field + ": " + what + misspellingHint(field));
  }
  std::string field(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

  bool has(const std::string& key) {
    seen_.insert(key);
    return object_.contains(key);
  }
  const json& raw(const std::string& key) {
    if (!has(key)) fail(field(key), "is required");
    return object_.at(key);
  }

  double number(const std::string& key, double lo = -std::numeric_limits<double>::max(),
                double hi = std::numeric_limits<double>::max()) {
    return checkNumber(raw(key), field(key), lo, hi);
  }
  double number(const std::string& key, double fallback, double lo, double hi) {
    return has(key) ? number(key, lo, hi) : fallback;
  }
  double checkNumber(const json& v, const std::string& name, double lo, double hi) const {
    if (!v.is_number()) fail(name, "must be a number");
    const double x = v.get<double>();
    if (!std::isfinite(x)) fail(name, "must be a finite number");
    if (x < lo || x > hi) fail(name, "must be in [" + fmt(lo) + ", " + fmt(hi) + "], got " + fmt(x));
    return x;
  }

  uint64_t integer(const std::string& key, uint64_t lo, uint64_t hi) {
    const json& v = raw(key);
    if (!v.is_number_integer() || (v.is_number_integer() && !v.is_number_unsigned() && v.get<int64_t>() < 0))
      fail(field(key), "must be a non-negative integer");
    const uint64_t x = v.get<uint64_t>();
    if (x < lo || x > hi)
      fail(field(key), "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + std::to_string(x));
    return x;
  }
  uint64_t integer(const std::string& key, uint64_t fallback, uint64_t lo, uint64_t hi) {
    return has(key) ? integer(key, lo, hi) : fallback;
  }

  bool boolean(const std::string& key, bool fallback) {
    if (!has(key)) return fallback;
    const json& v = object_.at(key);
    if (!v.is_boolean()) fail(field(key), "must be true or false");
    return v.get<bool>();
  }

  std::string string(const std::string& key) {
    const json& v = raw(key);
    if (!v.is_string()) fail(field(key), "must be a string");
    return v.get<std::string>();
  }
  std::string string(const std::string& key, const std::string& fallback) { return has(key) ? string(key) : fallback; }

  Vec3 vec3(const std::string& key) { return toVec3(raw(key), field(key)); }
  Vec3 vec3(const std::string& key, Vec3 fallback) { return has(key) ? vec3(key) : fallback; }
  Vec3 toVec3(const json& v, const std::string& name) const {
    const DVec3 d = toDVec3(v, name);
    for (int i = 0; i < 3; ++i)
      if (std::abs(d[i]) > std::numeric_limits<float>::max())
        fail(name + "[" + std::to_string(i) + "]", "is too large for single precision");
    return Vec3(d);
  }
  // Positions and offsets in the world: kept in double until the scene is re-centred on the
  // camera (SceneParser::toRenderSpace).
  DVec3 dvec3(const std::string& key) { return toDVec3(raw(key), field(key)); }
  DVec3 toDVec3(const json& v, const std::string& name) const {
    if (!v.is_array() || v.size() != 3) fail(name, "must be an array of 3 numbers");
    DVec3 out;
    for (int i = 0; i < 3; ++i)
      out[i] = checkNumber(v[i], name + "[" + std::to_string(i) + "]", -std::numeric_limits<double>::max(),
                           std::numeric_limits<double>::max());
    return out;
  }

  // A direction (light directions): a vec3 that is not zero, normalised in double (divided by its
  // largest component first, so that no length overflows).
  Vec3 direction(const std::string& key) { return toDirection(toDVec3(raw(key), field(key)), field(key)); }
  Vec3 toDirection(const DVec3& d, const std::string& name) const {
    const double largest = largestAbs(d);
    if (!(largest > 0.0)) fail(name, "must not be [0, 0, 0]: it gives a direction");
    return Vec3(glm::normalize(d / largest));
  }

  // A colour: three numbers, or one number for grey; each channel 0 or in [range.lo, range.hi].
  Spectrum color(const std::string& key, const ColorRange& range) {
    const json& v = raw(key);
    if (v.is_number()) return Spectrum(float(checkChannel(v, field(key), range)));
    if (!v.is_array() || v.size() != 3) fail(field(key), "must be an array of 3 numbers, or one number for grey");
    Spectrum c;
    for (int i = 0; i < 3; ++i) c[i] = float(checkChannel(v[i], field(key) + "[" + std::to_string(i) + "]", range));
    return c;
  }
  Spectrum color(const std::string& key, Spectrum fallback, const ColorRange& range) {
    return has(key) ? color(key, range) : fallback;
  }
  double checkChannel(const json& v, const std::string& name, const ColorRange& range) const {
    const double x = checkNumber(v, name, -std::numeric_limits<double>::max(), std::numeric_limits<double>::max());
    if (x == 0.0) return 0.0;  // also -0
    if (x < 0.0)
      fail(name, "must be 0 or in [" + fmt(range.lo) + ", " + fmt(range.hi) + "], got " + fmt(x) +
                     ": a colour is never negative");
    if (x > range.hi)
      fail(name,
           "must be 0 or in [" + fmt(range.lo) + ", " + fmt(range.hi) + "], got " + fmt(x) + ": " + range.aboveWhy);
    if (x < range.lo)
      fail(name,
           "must be 0 or in [" + fmt(range.lo) + ", " + fmt(range.hi) + "], got " + fmt(x) + ": " + range.belowWhy);
    return x;
  }

  // Reports the first key that no accessor asked for.
  void finish() const {
    for (auto it = object_.begin(); it != object_.end(); ++it) {
      if (!seen_.count(it.key())) {
        std::string allowed;
        for (const auto& k : seen_) allowed += (allowed.empty() ? "" : ", ") + k;
        const std::optional<std::string> meant =
            nearestName(it.key(), std::vector<std::string>(seen_.begin(), seen_.end()));
        fail(field(it.key()), meant
                                  ? "unknown field; did you mean \"" + *meant + "\"? (expected one of: " + allowed + ")"
                                  : "unknown field (expected one of: " + allowed + ")");
      }
    }
  }

  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }

 private:
  // "; the object has \"focal_lenght\": a misspelling of \"focal_length\"?" when `name` is a key of
  // this object that it lacks and a key nobody asked for is within a slip of it.
  std::string misspellingHint(const std::string& name) const {
    const std::string prefix = path_.empty() ? "" : path_ + ".";
    if (!object_.is_object() || name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) return "";
    const std::string key = name.substr(prefix.size());
    if (key.find_first_of(".[") != std::string::npos || object_.contains(key)) return "";
    std::vector<std::string> unread;
    for (auto it = object_.begin(); it != object_.end(); ++it)
      if (!seen_.count(it.key())) unread.push_back(it.key());
    const std::optional<std::string> written = nearestName(key, unread);
    return written ? "; the object has \"" + *written + "\": a misspelling of \"" + key + "\"?" : "";
  }

  static std::string fmt(double x) {
    std::ostringstream s;
    s << x;
    return s.str();
  }
  const json& object_;
  std::string path_;
  const std::string& file_;
  std::set<std::string> seen_;
};

}  // namespace lensfarm
