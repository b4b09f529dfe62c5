#pragma once
// A USD stage composed from its layers (usda_parser.h), the part of USD's composition a renderer
// of interchange files needs (openusd.org, "Composition"; the LIVRPS strength order):
//   * the root layer's subLayers, weaker than the root layer, in their order;
//   * references and payloads (external, @file.usda@</Prim> or the file's defaultPrim, and
//     internal, </Prim>), weaker than the prim that refers, their children merged by name;
//   * instanceable prims with references: the referenced prim is composed once, as a prototype,
//     and every instance points at it (usd_import.h makes them instances).
// Inherits, specializes and variant sets are not composed (the importer says so); inactive prims
// (active = false) are dropped. A reference that leads back to a prim it came from is an error
// naming the chain ("references form a cycle: a.usda</A> -> b.usda</B> -> a.usda</A>"); so is a
// stage of more than kMaxUsdComposedPrims prims, a reference to a missing file or prim, and a file
// that is not USD text.
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/scene/imported_model.h"
#include "common/scene/usda_parser.h"

namespace lensfarm {

inline constexpr size_t kMaxUsdComposedPrims = size_t(1) << 20;

// How paths written in a referenced layer read on the stage: each (from, to) replaces the prefix
// `from` by `to`, innermost reference first (a reference maps its target prim onto the prim that
// refers to it, so </Box/Looks/Red> in box.usda is </World/A/Looks/Red> on the stage).
using UsdPathMaps = std::vector<std::pair<std::string, std::string>>;
std::string mapUsdPath(std::string path, const UsdPathMaps& maps);

// A property with the layer it was written in (asset paths are relative to that layer's file) and
// the path maps of the arcs it came through (its connections and targets read through them).
struct UsdComposedProperty {
  const UsdProperty* spec = nullptr;
  const UsdLayer* layer = nullptr;
  std::shared_ptr<const UsdPathMaps> maps;
};

struct UsdPrim {
  std::string name, path, typeName;
  std::map<std::string, UsdComposedProperty> properties;  // the strongest opinion of each name
  std::map<std::string, UsdValue> metadata;               // likewise
  std::vector<std::unique_ptr<UsdPrim>> children;
  // An instanceable prim's prototype (an index into UsdStage::prototypes), or -1; an instance has
  // no children of its own.
  int prototype = -1;
  bool hasVariantSets = false;
  bool hasInherits = false;

  const UsdProperty* property(const std::string& name) const;
  const UsdLayer* layerOf(const std::string& name) const;
  // The property's connections or relationship targets as stage paths.
  std::vector<std::string> targets(const std::string& name) const;
};

struct UsdStage {
  std::vector<std::unique_ptr<UsdLayer>> layers;  // the root layer first
  UsdPrim root;                                   // the pseudo-root: its children are the root prims
  std::vector<std::unique_ptr<UsdPrim>> prototypes;
  std::string upAxis = "Y";
  double metersPerUnit = 0.01;  // USD's default (centimetres)
  size_t primCount = 0;
};

// `bytes` is the root layer's content (USD text), `shown` its path for messages; the files it
// refers to (sublayers, references) are read through `read`, relative to the root layer.
UsdStage composeUsdStage(std::string bytes, const std::string& shown, const ModelFileReader& read);

}  // namespace lensfarm
