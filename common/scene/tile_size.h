#pragma once
// How the frame is cut into units has one encoding: RenderSettings::tileSize, an int that is
// RenderSettings::kTilesAuto (0: the farm chooses), kTilesOff (-1: every unit is a pass over the
// whole frame) or N >= 1 (tiles of N x N pixels). The proto (RenderOverrides.tile_size) and the
// coordinator's stored jobs carry that int; people write it as "auto", "off" or N (the scene
// file's render.tile_size, the CLI's --tile-size), read here and nowhere else.
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>

namespace lensfarm {

// "auto", "off" or a whole number in [1, kMaxResolution] (a JSON number, or its digits as text),
// as the code; nothing for anything else.
std::optional<int> tileSizeFromJson(const nlohmann::json& value);
std::optional<int> tileSizeFromText(const std::string& text);

// What the two above accept, for messages: "auto, off or a tile edge in pixels in [1, 16384]".
std::string tileSizeForms();

}  // namespace lensfarm
