#pragma once
// Overrides of a scene's render settings, given on the command line (`lensfarm render`, `submit`)
// or in a job request (JobSpec.overrides). A worker applies a job's overrides exactly as the
// coordinator did, so every process renders the same job.
//
// Every override is one row of overrideTable(): its name (the proto field of
// lensfarm.v1.RenderOverrides, the stored job's JSON key and "overrides.<name>" in messages), its
// command-line flag and help, the kind of value it takes, and how it reads, writes and applies the
// RenderOverrides member that holds it. The CLI, applyOverrides, the proto conversion and the
// coordinator's stored jobs all walk the table; adding an override is one proto field, one member
// below and one row.
#include <cstdint>
#include <functional>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/scene/scene.h"

namespace lensfarm {

struct RenderOverrides {
  std::optional<uint64_t> samplesPerPixel;
  std::optional<int> width, height;
  std::optional<int> maxBounces;
  std::optional<uint64_t> seed;
  std::optional<IntegratorKind> integrator;
  std::optional<SamplerKind> sampler;
  std::optional<bool> russianRoulette;
  std::optional<double> targetError;       // relative RMSE; samplesPerPixel becomes a cap
  std::optional<double> timeLimitSeconds;  // the deadline, from submission
  std::optional<double> ev;
  std::optional<int> tileSize;        // RenderSettings::tileSize's code (scene/tile_size.h)
  std::optional<AovSet> aovs;         // replaces render.aovs (docs/aovs.md)
  std::optional<bool> adaptive;       // RenderSettings::adaptive.enabled (its other settings stay the scene's)
  std::optional<TraceKernel> kernel;  // RenderSettings::kernel (util/trace_kernel.h)
};

// What a flag's text must look like; the CLI checks it before the row parses it.
enum class OverrideKind {
  kWhole,     // a whole number in [wholeLo, wholeHi]
  kNumber,    // a finite number in [lo, hi] (`unit`)
  kDuration,  // "90s", "10m", "2h", "250ms" or plain seconds, in [lo, hi]
  kName,      // one of `names`
  kOnOff,     // "on" or "off"
  kText,      // a form of its own, parsed by the row (a resolution, a tile size, an AOV list)
};

struct OverrideRow {
  std::string name;  // proto field, stored-job key, "overrides.<name>"
  std::string flag;  // "--spp"; empty when another row's flag sets it (height: --resolution)
  std::string help;
  std::string valueName;  // kText: how --help shows the value ("WIDTHxHEIGHT")
  OverrideKind kind = OverrideKind::kText;
  uint64_t wholeLo = 0, wholeHi = 0;  // kWhole
  double lo = 0.0, hi = 0.0;          // kNumber, kDuration
  std::string unit;                   // kNumber
  std::vector<std::string> names;     // kName
  bool repeatable = false;            // the flag may be given many times; the texts join with ','

  // The value as JSON (an unsigned or signed integer, a number, a bool or a string), or nothing
  // when unset. JSON is the common currency of the stored job and the proto conversion.
  std::function<std::optional<nlohmann::json>(const RenderOverrides&)> get;
  // Sets the value from JSON of the row's type; throws InputError("overrides.<name>", ...) for a
  // value it cannot hold (a name that is not an integrator, a string where a number belongs).
  std::function<void(RenderOverrides&, const nlohmann::json&)> set;
  // Sets the value from the flag's text; throws InputError naming `flag`.
  std::function<void(RenderOverrides&, const std::string& text, const std::string& flag)> setText;
  // Copies a set value into the settings (unset: the scene's value stays).
  std::function<void(const RenderOverrides&, RenderSettings&)> apply;
};

// Every override, in the order `--help` lists their flags.
const std::vector<OverrideRow>& overrideTable();

// The overrides as the stored job's JSON object ({"samples_per_pixel": 64, ...}), and back;
// fromJson throws InputError naming the key.
nlohmann::json overridesToJson(const RenderOverrides& o);
RenderOverrides overridesFromJson(const nlohmann::json& object);

// Parses AOV lists ("albedo,normal", each a --aov value) into `o`; throws InputError naming `flag`.
void parseAovs(const std::vector<std::string>& lists, RenderOverrides& o, const std::string& flag = "--aov");

// Parses "auto", "off" or a tile edge in pixels (at least 1) into `o`; throws InputError naming
// `flag` ("--tile-size 0: ...").
void parseTileSize(const std::string& text, RenderOverrides& o, const std::string& flag = "--tile-size");

// Parses "WIDTHxHEIGHT" into `o`; throws InputError naming `flag`.
void parseResolution(const std::string& text, RenderOverrides& o, const std::string& flag = "--resolution");

// Applies the overrides and checks the result against the loader's limits; throws InputError
// naming `where` and the setting.
void applyOverrides(const RenderOverrides& o, RenderSettings& settings, const std::string& where);

}  // namespace lensfarm
