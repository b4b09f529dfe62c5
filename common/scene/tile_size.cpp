#include "common/scene/tile_size.h"

#include <nlohmann/json.hpp>
#include <regex>

#include "common/scene/scene.h"
#include "common/scene/scene_loader.h"

namespace lensfarm {

std::optional<int> tileSizeFromJson(const nlohmann::json& value) {
  if (value.is_string() && value == "auto") return RenderSettings::kTilesAuto;
  if (value.is_string() && value == "off") return RenderSettings::kTilesOff;
  if (value.is_number_integer() && value.get<int64_t>() >= 1 && value.get<int64_t>() <= kMaxResolution)
    return int(value.get<int64_t>());
  return std::nullopt;
}

std::optional<int> tileSizeFromText(const std::string& text) {
  static const std::regex kEdge(R"(\d{1,6})");
  if (std::regex_match(text, kEdge)) return tileSizeFromJson(std::stoi(text));
  return tileSizeFromJson(text);
}

std::string tileSizeForms() {
  return "auto, off or a tile edge in pixels in [1, " + std::to_string(kMaxResolution) + "]";
}

}  // namespace lensfarm
