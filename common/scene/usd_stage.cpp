#include "common/scene/usd_stage.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <utility>

#include "common/util/error.h"

namespace lensfarm {

namespace fs = std::filesystem;

const UsdProperty* UsdPrim::property(const std::string& propertyName) const {
  const auto it = properties.find(propertyName);
  return it == properties.end() ? nullptr : it->second.spec;
}

const UsdLayer* UsdPrim::layerOf(const std::string& propertyName) const {
  const auto it = properties.find(propertyName);
  return it == properties.end() ? nullptr : it->second.layer;
}

std::string mapUsdPath(std::string path, const UsdPathMaps& maps) {
  for (const auto& [from, to] : maps)
    if (path.compare(0, from.size(), from) == 0 &&
        (path.size() == from.size() || path[from.size()] == '/' || path[from.size()] == '.'))
      path = to + path.substr(from.size());
  return path;
}

std::vector<std::string> UsdPrim::targets(const std::string& propertyName) const {
  const auto it = properties.find(propertyName);
  if (it == properties.end()) return {};
  std::vector<std::string> out;
  for (const std::string& t : it->second.spec->connections)
    out.push_back(it->second.maps ? mapUsdPath(t, *it->second.maps) : t);
  return out;
}

namespace {

// One opinion about a prim: a spec in a layer, at `path` in that layer, seen on the stage through
// `maps`. A prim's opinions, strongest first.
struct Opinion {
  const UsdPrimSpec* spec;
  const UsdLayer* layer;
  std::string path;
  std::shared_ptr<const UsdPathMaps> maps;
};

// The arcs of an opinion's metadata: each reference or payload target as (asset, prim path).
std::vector<std::pair<std::string, std::string>> arcTargets(const UsdPrimSpec& spec) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const char* key : {"references", "payload"}) {
    const auto it = spec.metadata.find(key);
    if (it == spec.metadata.end() || it->second.op == "delete") continue;
    const UsdValue& v = it->second.value;
    for (const UsdValue& target : v.kind == UsdValue::Kind::kArray ? v.items : std::vector<UsdValue>{v}) {
      if (target.kind == UsdValue::Kind::kAsset)
        out.emplace_back(target.text, target.items.empty() ? "" : target.items[0].text);
      else if (target.kind == UsdValue::Kind::kPath)
        out.emplace_back("", target.text);
    }
  }
  return out;
}

class Composer {
 public:
  Composer(UsdStage& stage, const ModelFileReader& read, std::string rootShown)
      : stage_(stage), read_(read), rootShown_(std::move(rootShown)) {}

  void compose() {
    const UsdLayer& root = *stage_.layers.front();
    loadSublayers(root, "");
    std::vector<Opinion> rootOpinions;
    std::vector<std::string> names;
    for (const auto& layer : layerOrder_)
      for (const auto& prim : layer->prims) {
        if (std::find(names.begin(), names.end(), prim->name) == names.end()) names.push_back(prim->name);
      }
    for (const std::string& name : names) {
      std::vector<Opinion> opinions;
      for (const UsdLayer* layer : layerOrder_)
        for (const auto& prim : layer->prims)
          if (prim->name == name) opinions.push_back({prim.get(), layer, "/" + name, nullptr});
      if (auto prim = composePrim(opinions, "/" + name)) stage_.root.children.push_back(std::move(prim));
    }
  }

 private:
  // The layer at `asset`, relative to the layer `from` (its path relative to the root layer's
  // folder); parsed once.
  const UsdLayer* layerAt(const std::string& asset, const std::string& fromRel) {
    const std::string rel = (fs::path(fromRel).parent_path() / asset).lexically_normal().generic_string();
    if (const auto it = byPath_.find(rel); it != byPath_.end()) return it->second;
    const std::optional<std::string> bytes = read_(rel);
    if (!bytes) throw InputError(rootShown_, "a reference or sublayer names \"" + asset + "\", which cannot be read");
    if (isZip(*bytes) || isUsdCrate(*bytes) || bytes->compare(0, 5, "#usda") != 0)
      throw InputError(rootShown_, "\"" + asset + "\" is not a USD text layer (usda)");
    stage_.layers.push_back(std::make_unique<UsdLayer>(parseUsda(*bytes, rel)));
    const UsdLayer* layer = stage_.layers.back().get();
    relOf_[layer] = rel;
    byPath_[rel] = layer;
    return layer;
  }

  void loadSublayers(const UsdLayer& layer, const std::string& rel) {
    relOf_[&layer] = rel;
    if (layerOrder_.size() > 256) throw InputError(rootShown_, "more than 256 sublayers");
    layerOrder_.push_back(&layer);
    const auto it = layer.metadata.find("subLayers");
    if (it == layer.metadata.end()) return;
    for (const UsdValue& sub : it->second.value.items) {
      if (sub.kind != UsdValue::Kind::kAsset) continue;
      const UsdLayer* child = layerAt(sub.text, rel);
      if (std::find(layerOrder_.begin(), layerOrder_.end(), child) != layerOrder_.end())
        throw InputError(rootShown_, "subLayers form a cycle at \"" + sub.text + "\"");
      loadSublayers(*child, relOf_[child]);
    }
  }

  // The prim spec at `path` ("/A/B") in `layer`, or nullptr.
  static const UsdPrimSpec* specAt(const UsdLayer& layer, const std::string& path) {
    const UsdPrimSpec* at = nullptr;
    size_t from = 1;
    while (from <= path.size()) {
      const size_t end = std::min(path.find('/', from), path.size());
      const std::string name = path.substr(from, end - from);
      if (name.empty()) break;
      const UsdPrimSpec* next = nullptr;
      if (!at) {
        for (const auto& p : layer.prims)
          if (p->name == name) next = p.get();
      } else {
        next = at->child(name);
      }
      if (!next) return nullptr;
      at = next;
      from = end + 1;
    }
    return at;
  }

  std::string targetOf(const UsdLayer& layer) const {
    const auto it = layer.metadata.find("defaultPrim");
    if (it != layer.metadata.end() && !it->second.value.text.empty()) return "/" + it->second.value.text;
    if (!layer.prims.empty()) return "/" + layer.prims.front()->name;
    throw InputError(layer.file, "is referenced without a prim path, and has no defaultPrim nor any prim");
  }

  // `opinions` with every reference and payload they carry expanded, strongest first.
  std::vector<Opinion> expand(std::vector<Opinion> opinions) {
    std::vector<Opinion> out;
    for (const Opinion& o : opinions) {
      out.push_back(o);
      for (const auto& [asset, primPath] : arcTargets(*o.spec)) {
        const UsdLayer* layer = asset.empty() ? o.layer : layerAt(asset, relOf_.at(o.layer));
        const std::string path = primPath.empty() ? targetOf(*layer) : primPath;
        const std::string key = layer->file + "<" + path + ">";
        for (const std::string& k : chain_)
          if (k == key) {
            std::string cycle;
            for (const std::string& c : chain_) cycle += c + " -> ";
            throw InputError(rootShown_, "references form a cycle: " + cycle + key);
          }
        const UsdPrimSpec* target = specAt(*layer, path);
        if (!target)
          throw InputError(o.layer->file, "prim \"" + o.spec->name + "\" refers to " + key + ", which does not exist");
        auto maps = std::make_shared<UsdPathMaps>();
        maps->emplace_back(path, o.path);
        if (o.maps) maps->insert(maps->end(), o.maps->begin(), o.maps->end());
        chain_.push_back(key);
        for (const Opinion& r : expand({{target, layer, path, std::move(maps)}})) out.push_back(r);
        chain_.pop_back();
      }
    }
    return out;
  }

  std::unique_ptr<UsdPrim> composePrim(const std::vector<Opinion>& local, const std::string& path) {
    if (++stage_.primCount > kMaxUsdComposedPrims)
      throw InputError(rootShown_, "has more than " + std::to_string(kMaxUsdComposedPrims) +
                                       " prims once its references are composed");
    const std::vector<Opinion> opinions = expand(local);
    auto prim = std::make_unique<UsdPrim>();
    prim->name = opinions.front().spec->name;
    prim->path = path;
    for (auto it = opinions.rbegin(); it != opinions.rend(); ++it) {  // weakest first: the strongest wins
      const UsdPrimSpec& spec = *it->spec;
      if (!spec.typeName.empty()) prim->typeName = spec.typeName;
      for (const auto& [key, entry] : spec.metadata) prim->metadata[key] = entry.value;
      for (const UsdProperty& p : spec.properties) prim->properties[p.name] = {&p, it->layer, it->maps};
      prim->hasVariantSets |= spec.hasVariantSets;
      prim->hasInherits |= spec.metadata.count("inherits") || spec.metadata.count("specializes");
    }
    if (const auto it = prim->metadata.find("active"); it != prim->metadata.end() && it->second.text == "false")
      return nullptr;
    // An instanceable prim whose children come by reference: composed once, shared.
    const auto inst = prim->metadata.find("instanceable");
    const bool instanceable = inst != prim->metadata.end() && (inst->second.text == "true" || inst->second.number == 1);
    std::string prototypeKey;
    if (instanceable && opinions.size() > local.size()) {
      for (size_t i = local.size(); i < opinions.size(); ++i)
        prototypeKey += opinions[i].layer->file + "|" + opinions[i].spec->name + ";";
      if (const auto it = prototypes_.find(prototypeKey); it != prototypes_.end()) {
        prim->prototype = it->second;
        return prim;
      }
    }
    composeChildren(*prim, opinions, path);
    if (!prototypeKey.empty()) {
      auto prototype = std::make_unique<UsdPrim>();
      prototype->name = prim->name;
      prototype->path = path;
      prototype->children = std::move(prim->children);
      prim->prototype = int(stage_.prototypes.size());
      prototypes_[prototypeKey] = prim->prototype;
      stage_.prototypes.push_back(std::move(prototype));
    }
    return prim;
  }

  void composeChildren(UsdPrim& prim, const std::vector<Opinion>& opinions, const std::string& path) {
    std::vector<std::string> names;
    for (const Opinion& o : opinions)
      for (const auto& c : o.spec->children)
        if (std::find(names.begin(), names.end(), c->name) == names.end()) names.push_back(c->name);
    for (const std::string& name : names) {
      std::vector<Opinion> child;
      for (const Opinion& o : opinions)
        if (const UsdPrimSpec* c = o.spec->child(name)) child.push_back({c, o.layer, o.path + "/" + name, o.maps});
      if (auto composed = composePrim(child, path + "/" + name)) prim.children.push_back(std::move(composed));
    }
  }

  UsdStage& stage_;
  const ModelFileReader& read_;
  std::string rootShown_;
  std::vector<const UsdLayer*> layerOrder_;
  std::map<std::string, const UsdLayer*> byPath_;
  std::map<const UsdLayer*, std::string> relOf_;
  std::vector<std::string> chain_;
  std::map<std::string, int> prototypes_;
};

}  // namespace

UsdStage composeUsdStage(std::string bytes, const std::string& shown, const ModelFileReader& read) {
  UsdStage stage;
  stage.layers.push_back(std::make_unique<UsdLayer>(parseUsda(bytes, shown)));
  std::string().swap(bytes);
  const UsdLayer& root = *stage.layers.front();
  if (const auto it = root.metadata.find("upAxis"); it != root.metadata.end()) {
    stage.upAxis = it->second.value.text;
    if (stage.upAxis != "Y" && stage.upAxis != "Z")
      throw InputError(shown, "upAxis: \"" + stage.upAxis + "\" is not \"Y\" or \"Z\"");
  }
  if (const auto it = root.metadata.find("metersPerUnit"); it != root.metadata.end()) {
    stage.metersPerUnit = it->second.value.number;
    if (!(stage.metersPerUnit > 0) || !std::isfinite(stage.metersPerUnit))
      throw InputError(shown, "metersPerUnit: must be a positive number");
  }
  stage.root.path = "/";
  Composer(stage, read, shown).compose();
  return stage;
}

}  // namespace lensfarm
