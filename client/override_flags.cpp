#include "client/override_flags.h"

#include <fmt/format.h>

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <memory>

#include "common/scene/scene_loader.h"
#include "common/util/error.h"

namespace lensfarm::cli {

namespace {

// The check of a flag's text, from its row's kind (scene/render_overrides.h).
void checkByKind(CLI::Option* option, const OverrideRow& row) {
  switch (row.kind) {
    case OverrideKind::kWhole: option->type_name("UINT")->check(wholeNumberIn(row.wholeLo, row.wholeHi)); break;
    case OverrideKind::kNumber: option->type_name("FLOAT")->check(numberIn(row.lo, row.hi, row.unit)); break;
    case OverrideKind::kDuration: option->transform(durationIn(row.lo, row.hi)); break;
    case OverrideKind::kName: option->check(CLI::IsMember(row.names)); break;
    case OverrideKind::kOnOff: option->check(CLI::IsMember({"on", "off"})); break;
    case OverrideKind::kText: option->type_name(row.valueName); break;  // the row's parser names what is wrong
  }
}

}  // namespace

void OverrideFlags::addTo(CLI::App* cmd) {
  cmd->add_option("--camera", camera, "A camera of the scene's glTF models, by name (instead of the scene's camera)");
  for (const OverrideRow& row : overrideTable()) {
    if (row.flag.empty()) continue;
    CLI::Option* option = cmd->add_option(row.flag, texts[row.name], row.help);
    if (!row.repeatable) option->expected(1)->multi_option_policy(CLI::MultiOptionPolicy::Throw);
    checkByKind(option, row);
  }
  cmd->add_option("--frames", frames,
                  "Render an animation's frames: 7, 1-240 or 1-240x2 (every 2nd); outputs need #### for the number");
  cmd->add_option(
         "--allow-path", allowPaths,
         "A folder outside the scene's that the scene and its models may read files from (repeatable); "
         "by default every file must lie inside the scene's folder (LENSFARM_ALLOW_PATH: more, colon-separated)")
      ->check(CLI::ExistingDirectory);
}

RenderOverrides OverrideFlags::toOverrides() const {
  RenderOverrides o;
  for (const OverrideRow& row : overrideTable()) {
    const auto given = texts.find(row.name);
    if (given == texts.end() || given->second.empty()) continue;
    std::string text;
    for (const std::string& t : given->second) text += (text.empty() ? "" : ",") + t;
    row.setText(o, text, row.flag);
  }
  // A stopping rule alone lifts the sample cap: the job runs until the target error or the deadline.
  if ((o.targetError || o.timeLimitSeconds) && !o.samplesPerPixel) o.samplesPerPixel = kMaxSamplesPerPixel;
  return o;
}

std::optional<FrameRange> OverrideFlags::frameRange() const {
  if (!frames) return std::nullopt;
  return parseFrameRange(*frames, "--frames");
}

}  // namespace lensfarm::cli
