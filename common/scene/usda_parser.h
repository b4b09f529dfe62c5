#pragma once
// USD's text format (.usda), read into a layer of prim specs as the USD specification writes it
// (Pixar, "Universal Scene Description: USDA file format"; openusd.org "Terms and Concepts"):
//
//   #usda 1.0
//   ( upAxis = "Y"  metersPerUnit = 0.01  defaultPrim = "World" )
//   def Xform "World" { def Mesh "Box" ( prepend apiSchemas = ["MaterialBindingAPI"] ) {
//       point3f[] points = [(0, 0, 0), ...]   int[] faceVertexCounts = [4]   rel material:binding = </Looks/Red>
//       texCoord2f[] primvars:st = [...] ( interpolation = "faceVarying" ) } }
//
// The parser keeps what a renderer needs: every prim (specifier, type, name, metadata, children),
// every attribute (type name, default value, connections, time samples) and relationship
// (targets); values as numbers, strings, tokens, asset paths, paths, tuples, arrays and
// dictionaries. Numeric arrays (points, indices) are held flat, one double per number.
// Composition (references, sublayers) is usd_stage.h's; meaning (meshes, materials) usd_import.h's.
//
// Errors throw InputError naming the file, line and column: "scene.usda: line 12, column 5:
// expected '=' after the attribute name points". Nesting deeper than kMaxUsdNesting is refused.
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace lensfarm {

inline constexpr int kMaxUsdNesting = 256;

struct UsdEntry;

struct UsdValue {
  enum class Kind { kNone, kNumber, kString, kIdentifier, kAsset, kPath, kTuple, kArray, kDictionary };
  Kind kind = Kind::kNone;
  double number = 0.0;
  // kString, kIdentifier (a bare word: true, false, a type name), kAsset (the path between @s),
  // kPath (between < and >).
  std::string text;
  // kTuple and kArray of anything but numbers; kAsset: its prim path, when one follows (a reference).
  std::vector<UsdValue> items;
  // kArray of numbers or of tuples of numbers, flattened; `arity` numbers per element.
  std::vector<double> numbers;
  uint32_t arity = 0;
  std::vector<UsdEntry> entries;  // kDictionary

  size_t size() const { return kind == Kind::kArray ? (arity > 0 ? numbers.size() / arity : items.size()) : 0; }
};

// One entry of a dictionary value (a struct, not a std::pair: a value holds entries that hold values).
struct UsdEntry {
  std::string key;
  UsdValue value;
};

// "prepend", "append", "add", "delete", "reorder" or "" before a metadata key or a property.
struct UsdListOp {
  std::string op;
  UsdValue value;
};

struct UsdProperty {
  std::string name;      // "points", "primvars:st", "xformOp:translate", "material:binding"
  std::string typeName;  // "point3f[]", "token", ...; "rel" for a relationship
  bool uniform = false;
  bool hasDefault = false;
  UsdValue value;                                        // the default value (relationship: its target or targets)
  std::vector<std::string> connections;                  // attribute.connect targets
  std::vector<std::pair<double, UsdValue>> timeSamples;  // in time order as written
  std::map<std::string, UsdValue> metadata;              // interpolation, elementSize, ...
};

struct UsdPrimSpec {
  std::string specifier;  // "def", "over", "class"
  std::string typeName;   // "Mesh", "Xform", "" (typeless)
  std::string name;
  std::map<std::string, UsdListOp> metadata;  // references, payload, instanceable, kind, active, apiSchemas
  std::vector<UsdProperty> properties;        // in the order written (a later one of a name wins)
  std::vector<std::unique_ptr<UsdPrimSpec>> children;
  bool hasVariantSets = false;

  const UsdProperty* property(const std::string& propertyName) const;
  UsdPrimSpec* child(const std::string& childName) const;
};

struct UsdLayer {
  std::string file;                           // shown in messages
  std::map<std::string, UsdListOp> metadata;  // upAxis, metersPerUnit, defaultPrim, subLayers
  std::vector<std::unique_ptr<UsdPrimSpec>> prims;
};

// Whether `bytes` start as USD's binary crate file does ("PXR-USDC"), or as a zip (.usdz) does.
bool isUsdCrate(const std::string& bytes);
bool isZip(const std::string& bytes);

// Parses a .usda file's text; `shown` names it in errors.
UsdLayer parseUsda(const std::string& text, const std::string& shown);

}  // namespace lensfarm
