// SceneParser, media and materials: the scene's named media (placed in render space once the
// camera is read) and materials, and a shape's material by name.
#include <memory>
#include <string>

#include "common/medium/medium.h"
#include "common/scene/scene_parser.h"
#include "common/util/field_reader.h"

namespace lensfarm {

void SceneParser::parseMedia(FieldReader& top) {
  if (!top.has("media")) return;
  const json& media = top.raw("media");
  if (!media.is_object()) top.fail("media", "must be an object of named media");
  for (auto it = media.begin(); it != media.end(); ++it) {
    FieldReader r(it.value(), "media." + it.key(), fileName_);
    std::shared_ptr<Medium> m =
        parseMedium(it.key(), r, [this](FieldReader& reader, const std::string& key, const std::string& kind) {
          return readAssetFile(reader, key, kind);
        });
    unplacedMedia_.push_back(m);
    scene_.media[it.key()] = m;
  }
}

void SceneParser::placeMedia(FieldReader& top) {
  for (const std::shared_ptr<Medium>& m : unplacedMedia_) m->place(scene_.origin);
  unplacedMedia_.clear();
  if (!top.has("medium")) return;
  const std::string name = top.string("medium");
  const auto it = scene_.media.find(name);
  if (it == scene_.media.end()) top.fail("medium", "unknown medium \"" + name + "\" (not in media)");
  scene_.medium = it->second;
}

void SceneParser::parseMaterials(FieldReader& top) {
  // Optional where every shape brings its own (glTF, OBJ with MTL).
  if (!top.has("materials")) return;
  const json& mats = top.raw("materials");
  if (!mats.is_object()) top.fail("materials", "must be an object of named materials");
  for (auto it = mats.begin(); it != mats.end(); ++it) {
    FieldReader r(it.value(), "materials." + it.key(), fileName_);
    Material m = parseMaterial(it.key(), r, scene_.media);
    materialIndex_[m.name] = uint32_t(scene_.materials.size());
    scene_.materials.push_back(m);
  }
}

uint32_t SceneParser::materialRef(FieldReader& r, const std::string& key) {
  const std::string name = r.string(key);
  return lookupMaterial(r, r.field(key), name);
}

uint32_t SceneParser::lookupMaterial(FieldReader& r, const std::string& field, const std::string& name) {
  auto it = materialIndex_.find(name);
  if (it == materialIndex_.end()) r.fail(field, "unknown material \"" + name + "\" (not in materials)");
  return it->second;
}

}  // namespace lensfarm
