#include "common/scene/usd_import.h"

#include <cmath>
#include <filesystem>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include "common/scene/usd_stage.h"
#include "common/scene/usdz_package.h"
#include "common/texture/image_decode.h"
#include "common/texture/texture.h"
#include "common/util/error.h"

namespace lensfarm {

namespace {

using json = nlohmann::json;

// The prim types of USD's core schemas: rendered, or noted as not rendered. Any other type is
// refused (a typo, or a schema from a plugin lensfarm cannot know the meaning of).
const std::set<std::string> kRendered = {"Mesh", "Camera", "RectLight", "DiskLight", "SphereLight", "DistantLight"};
const std::set<std::string> kStructural = {"",          "Xform",       "Scope",    "Material",       "Shader",
                                           "NodeGraph", "GeomSubset",  "SkelRoot", "RenderSettings", "RenderProduct",
                                           "RenderVar", "PhysicsScene"};
const std::set<std::string> kNotRendered = {
    "Sphere",        "Cube",         "Cylinder",    "Cone",          "Capsule",    "Plane",          "Points",
    "BasisCurves",   "NurbsCurves",  "NurbsPatch",  "HermiteCurves", "TetMesh",    "PointInstancer", "Volume",
    "OpenVDBAsset",  "Field3DAsset", "Skeleton",    "SkelAnimation", "BlendShape", "DomeLight",      "CylinderLight",
    "GeometryLight", "PortalLight",  "PluginLight", "SpatialAudio",  "Backdrop",   "LightFilter"};

std::string num(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

json array3(const DVec3& v) { return {v.x, v.y, v.z}; }

class Importer {
 public:
  Importer(UsdStage& stage, std::string shown, const ModelFileReader& read)
      : stage_(stage), shown_(std::move(shown)), read_(read) {}

  ImportedModel run() {
    // Z up turned to lensfarm's Y up: (x, y, z) -> (x, z, -y).
    if (stage_.upAxis == "Z") root_ = glm::rotate(glm::dmat4(1.0), -glm::half_pi<double>(), glm::dvec3(1, 0, 0));
    for (const auto& child : stage_.root.children) visit(*child, root_, "");
    if (!model_.meshes.empty() || !model_.prototypes.empty()) {
      for (const MeshInput& m : model_.meshes)
        for (const DVec3& p : m.positions) model_.lo = glm::min(model_.lo, p), model_.hi = glm::max(model_.hi, p);
    }
    for (const auto& [what, prims] : notGrouped_) {
      std::string list;
      for (size_t i = 0; i < prims.size() && i < 5; ++i) list += (i ? ", " : "") + prims[i];
      if (prims.size() > 5) list += ", ... (" + std::to_string(prims.size()) + " in all)";
      model_.notes.push_back(what + ": " + list);
    }
    for (const std::string& n : notes_) model_.notes.push_back(n);
    return std::move(model_);
  }

 private:
  [[noreturn]] void fail(const UsdPrim& prim, const std::string& what) const {
    throw InputError(shown_, "<" + prim.path + ">: " + what);
  }
  void noteFor(const std::string& what, const UsdPrim& prim) { notGrouped_[what].push_back("<" + prim.path + ">"); }

  // ---- values -----------------------------------------------------------------------------------
  static const UsdValue* valueOf(const UsdPrim& prim, const std::string& name) {
    const UsdProperty* p = prim.property(name);
    if (!p) return nullptr;
    if (p->hasDefault) return &p->value;
    if (!p->timeSamples.empty()) return &p->timeSamples.front().second;  // the first sample: a still
    return nullptr;
  }
  double number(const UsdPrim& prim, const std::string& name, double fallback) const {
    const UsdValue* v = valueOf(prim, name);
    if (!v || v->kind == UsdValue::Kind::kNone) return fallback;
    if (v->kind == UsdValue::Kind::kIdentifier && (v->text == "true" || v->text == "false")) return v->text == "true";
    if (v->kind != UsdValue::Kind::kNumber || !std::isfinite(v->number))
      fail(prim, name + ": expected a finite number");
    return v->number;
  }
  std::string token(const UsdPrim& prim, const std::string& name, const std::string& fallback) const {
    const UsdValue* v = valueOf(prim, name);
    return v && (v->kind == UsdValue::Kind::kString || v->kind == UsdValue::Kind::kIdentifier) ? v->text : fallback;
  }
  DVec3 vec3(const UsdPrim& prim, const std::string& name, const DVec3& fallback) const {
    const UsdValue* v = valueOf(prim, name);
    if (!v || v->kind == UsdValue::Kind::kNone) return fallback;
    if (v->kind != UsdValue::Kind::kTuple || v->numbers.size() != 3) fail(prim, name + ": expected 3 numbers");
    const DVec3 out(v->numbers[0], v->numbers[1], v->numbers[2]);
    if (!std::isfinite(out.x) || !std::isfinite(out.y) || !std::isfinite(out.z))
      fail(prim, name + ": expected finite numbers");
    return out;
  }
  // A numeric array attribute: its numbers (`arity` per element), checked finite.
  const std::vector<double>* numbers(const UsdPrim& prim, const std::string& name, uint32_t arity) const {
    const UsdValue* v = valueOf(prim, name);
    if (!v || v->kind == UsdValue::Kind::kNone) return nullptr;
    if (v->kind != UsdValue::Kind::kArray) fail(prim, name + ": expected an array");
    if (v->size() == 0) return &empty_;
    if (v->arity != arity)
      fail(prim, name + ": expected an array of " + (arity == 1 ? "numbers" : std::to_string(arity) + "-tuples"));
    for (size_t i = 0; i < v->numbers.size(); ++i)
      if (!std::isfinite(v->numbers[i])) fail(prim, name + "[" + std::to_string(i / arity) + "]: not a finite number");
    return &v->numbers;
  }

  // ---- transforms -------------------------------------------------------------------------------
  // The prim's local transform from its xformOpOrder; `reset` set by !resetXformStack!.
  glm::dmat4 local(const UsdPrim& prim, bool& reset) const {
    reset = false;
    const UsdValue* order = valueOf(prim, "xformOpOrder");
    glm::dmat4 m(1.0);
    if (!order) return m;
    for (const UsdValue& item : order->items) {
      std::string op = item.text;
      if (op == "!resetXformStack!") {
        reset = true;
        m = glm::dmat4(1.0);
        continue;
      }
      const bool invert = op.rfind("!invert!", 0) == 0;
      if (invert) op = op.substr(8);
      glm::dmat4 t = opMatrix(prim, op);
      m = m * (invert ? glm::inverse(t) : t);
    }
    return m;
  }

  glm::dmat4 opMatrix(const UsdPrim& prim, const std::string& op) const {
    if (op.rfind("xformOp:", 0) != 0) fail(prim, "xformOpOrder: \"" + op + "\" is not an xformOp");
    const std::string kind = op.substr(8, op.find(':', 8) - 8);
    if (!prim.property(op)) fail(prim, "xformOpOrder names " + op + ", which the prim does not have");
    const auto axisAngle = [&](char axis, double degrees) {
      const glm::dvec3 a(axis == 'X', axis == 'Y', axis == 'Z');
      return glm::rotate(glm::dmat4(1.0), glm::radians(degrees), a);
    };
    if (kind == "translate") return glm::translate(glm::dmat4(1.0), vec3(prim, op, DVec3(0)));
    if (kind == "scale") {
      const UsdValue* v = valueOf(prim, op);
      if (v && v->kind == UsdValue::Kind::kNumber) return glm::scale(glm::dmat4(1.0), DVec3(v->number));
      return glm::scale(glm::dmat4(1.0), vec3(prim, op, DVec3(1)));
    }
    if (kind == "rotateX" || kind == "rotateY" || kind == "rotateZ") return axisAngle(kind[6], number(prim, op, 0));
    if (kind.size() == 9 && kind.rfind("rotate", 0) == 0) {
      // rotateXYZ: about X first, then Y, then Z (the first letter applies first to points).
      const DVec3 angles = vec3(prim, op, DVec3(0));
      glm::dmat4 r(1.0);
      for (int i = 0; i < 3; ++i) {
        const char axis = kind[6 + i];
        if (axis != 'X' && axis != 'Y' && axis != 'Z') fail(prim, op + ": not a rotation order");
        r = axisAngle(axis, angles[axis - 'X']) * r;
      }
      return r;
    }
    if (kind == "orient") {
      const UsdValue* v = valueOf(prim, op);
      if (!v || v->numbers.size() != 4) fail(prim, op + ": expected a quaternion (w, x, y, z)");
      const glm::dquat q(v->numbers[0], v->numbers[1], v->numbers[2], v->numbers[3]);  // USD writes the real part first
      if (!(glm::length(q) > 0)) fail(prim, op + ": a zero quaternion");
      return glm::mat4_cast(glm::normalize(q));
    }
    if (kind == "transform") {
      const UsdValue* v = valueOf(prim, op);
      std::vector<double> flat;
      if (v)
        for (const UsdValue& row : v->items) flat.insert(flat.end(), row.numbers.begin(), row.numbers.end());
      if (flat.size() != 16) fail(prim, op + ": expected a 4 x 4 matrix");
      for (double x : flat)
        if (!std::isfinite(x)) fail(prim, op + ": not finite");
      // USD's matrices act on row vectors (v' = v M, translation in the last row): written row by
      // row they are the column-vector matrix's columns, as glm stores them.
      return glm::make_mat4(flat.data());
    }
    fail(prim, "xformOpOrder: \"" + op + "\" is not a transform op lensfarm knows");
  }

  // ---- the walk ---------------------------------------------------------------------------------
  void visit(const UsdPrim& prim, const glm::dmat4& parent, const std::string& inheritedMaterial) {
    const std::string& type = prim.typeName;
    if (!kRendered.count(type) && !kStructural.count(type) && !kNotRendered.count(type))
      fail(prim, "unknown prim type \"" + type + "\" (USD's core schemas: Mesh, Xform, Scope, Camera, lights, ...)");
    if (token(prim, "visibility", "inherited") == "invisible") return;
    const std::string purpose = token(prim, "purpose", "default");
    if (purpose == "guide" || purpose == "proxy") return;
    if (prim.hasVariantSets) noteFor("variant sets not composed (each prim as written outside its variants)", prim);
    if (prim.hasInherits) noteFor("inherits and specializes not composed", prim);
    bool reset = false;
    const glm::dmat4 own = local(prim, reset);
    // !resetXformStack!: the prim's own ops alone, in the stage's (up-axis) frame.
    const glm::dmat4 placed = (reset ? root_ : parent) * own;
    const std::string material = bindingOf(prim, inheritedMaterial);
    if (kNotRendered.count(type)) {
      noteFor("not rendered (" + type + ")", prim);
      return;
    }
    if (type == "Mesh") mesh(prim, placed, material, false);
    if (type == "Camera") camera(prim, placed);
    if (type == "RectLight" || type == "DiskLight" || type == "SphereLight" || type == "DistantLight")
      light(prim, placed);
    if (prim.prototype >= 0) instance(prim, placed, material);
    for (const auto& child : prim.children) visit(*child, placed, material);
  }

  std::string bindingOf(const UsdPrim& prim, const std::string& inherited) const {
    const std::vector<std::string> t = prim.targets("material:binding");
    return t.empty() ? inherited : t.front();
  }

  // An instance of a prototype: its meshes built once in the prototype's space, then placed.
  void instance(const UsdPrim& prim, const glm::dmat4& world, const std::string& material) {
    auto [it, fresh] = prototypeMeshes_.try_emplace(prim.prototype);
    if (fresh) {
      const size_t first = model_.prototypes.size();
      collectPrototype(*stage_.prototypes[size_t(prim.prototype)], glm::dmat4(1.0), material);
      for (size_t i = first; i < model_.prototypes.size(); ++i) it->second.push_back(uint32_t(i));
    }
    for (uint32_t p : it->second) model_.instances.push_back({p, world, prim.path});
  }
  void collectPrototype(const UsdPrim& prim, const glm::dmat4& space, const std::string& material) {
    for (const auto& child : prim.children) {
      bool reset = false;
      const glm::dmat4 m = space * local(*child, reset);
      const std::string bound = bindingOf(*child, material);
      if (child->typeName == "Mesh")
        mesh(*child, m, bound, true);
      else if (!kStructural.count(child->typeName))
        noteFor("inside an instance, only meshes are rendered", *child);
      collectPrototype(*child, m, bound);
    }
  }

  // ---- meshes -----------------------------------------------------------------------------------
  // A primvar's values and how they are laid out.
  struct Primvar {
    const std::vector<double>* values = nullptr;
    std::vector<int64_t> indices;
    std::string interpolation;
    uint32_t arity = 0;
  };
  Primvar primvar(const UsdPrim& prim, const std::string& name, uint32_t arity, const std::string& fallback) const {
    Primvar out;
    out.arity = arity;
    out.values = numbers(prim, name, arity);
    if (!out.values) return out;
    const UsdProperty* p = prim.property(name);
    const auto it = p->metadata.find("interpolation");
    out.interpolation = it != p->metadata.end() ? it->second.text : fallback;
    if (const std::vector<double>* idx = numbers(prim, name + ":indices", 1)) {
      for (double i : *idx) {
        if (i < 0 || i >= double(out.values->size() / arity) || i != std::floor(i))
          fail(prim, name + ":indices: " + num(i) + " is not an index of its " +
                         std::to_string(out.values->size() / arity) + " values");
        out.indices.push_back(int64_t(i));
      }
    }
    return out;
  }
  // The value index of a primvar at face `face`, face-vertex `corner` (running over the mesh),
  // point `point`.
  static size_t primvarIndex(const Primvar& pv, size_t face, size_t corner, size_t point) {
    size_t i = pv.interpolation == "faceVarying" ? corner
               : pv.interpolation == "uniform"   ? face
               : pv.interpolation == "constant"  ? 0
                                                 : point;
    return pv.indices.empty() ? i : size_t(pv.indices[i]);
  }

  void mesh(const UsdPrim& prim, const glm::dmat4& world, const std::string& material, bool asPrototype) {
    const std::vector<double>* points = numbers(prim, "points", 3);
    const std::vector<double>* counts = numbers(prim, "faceVertexCounts", 1);
    const std::vector<double>* indices = numbers(prim, "faceVertexIndices", 1);
    if (!points || !counts || !indices) fail(prim, "a Mesh needs points, faceVertexCounts and faceVertexIndices");
    const size_t pointCount = points->size() / 3;
    size_t total = 0;
    for (size_t f = 0; f < counts->size(); ++f) {
      const double c = (*counts)[f];
      if (c < 0 || c != std::floor(c) || c > 1e9) fail(prim, "faceVertexCounts[" + std::to_string(f) + "] = " + num(c));
      total += size_t(c);
    }
    if (total != indices->size())
      fail(prim, "faceVertexCounts add up to " + std::to_string(total) + " but faceVertexIndices has " +
                     std::to_string(indices->size()));
    for (size_t i = 0; i < indices->size(); ++i) {
      const double v = (*indices)[i];
      if (v < 0 || v >= double(pointCount) || v != std::floor(v))
        fail(prim, "faceVertexIndices[" + std::to_string(i) + "] = " + num(v) + " is not a point (" +
                       std::to_string(pointCount) + " points)");
    }
    const std::string scheme = token(prim, "subdivisionScheme", "catmullClark");
    if (scheme != "none") noteFor("subdivision (" + scheme + ") not applied: rendered as the control mesh", prim);
    const bool leftHanded = token(prim, "orientation", "rightHanded") == "leftHanded";
    Primvar normals = primvar(prim, "primvars:normals", 3, "constant");
    if (!normals.values) normals = primvar(prim, "normals", 3, "vertex");
    Primvar st = primvar(prim, "primvars:st", 2, "constant");
    if (!st.values)
      for (const auto& [name, p] : prim.properties)
        if (name.rfind("primvars:", 0) == 0 && name.find(":indices") == std::string::npos &&
            (p.spec->typeName == "texCoord2f[]" || p.spec->typeName == "float2[]") && !st.values)
          st = primvar(prim, name, 2, "constant");
    for (const Primvar* pv : {&normals, &st}) {
      if (!pv->values) continue;
      const size_t need = pv->interpolation == "faceVarying" ? indices->size()
                          : pv->interpolation == "uniform"   ? counts->size()
                          : pv->interpolation == "constant"  ? 1
                                                             : pointCount;
      const size_t have = pv->indices.empty() ? pv->values->size() / pv->arity : pv->indices.size();
      if (have < need)
        fail(prim, std::string(pv == &normals ? "normals" : "texture coordinates") + " (" + pv->interpolation +
                       "): " + std::to_string(have) + " values for " + std::to_string(need));
    }
    // Materials per face: the mesh's binding, then its GeomSubsets of familyName materialBind.
    std::vector<uint32_t> faceMaterial(counts->size(), materialIndex(material, prim));
    for (const auto& child : prim.children) {
      if (child->typeName != "GeomSubset" || token(*child, "familyName", "") != "materialBind") continue;
      const std::vector<double>* faces = numbers(*child, "indices", 1);
      const std::vector<std::string> bind = child->targets("material:binding");
      if (!faces || bind.empty()) continue;
      const uint32_t id = materialIndex(bind.front(), *child);
      for (double f : *faces) {
        if (f < 0 || f >= double(counts->size()) || f != std::floor(f))
          fail(*child,
               "indices: " + num(f) + " is not a face of its mesh (" + std::to_string(counts->size()) + " faces)");
        faceMaterial[size_t(f)] = id;
      }
    }
    // Every face corner becomes a vertex (normals and uvs may differ per corner); fanned triangles.
    MeshInput in;
    in.mesh.name = prim.path;
    const glm::dmat3 normalMatrix = glm::transpose(glm::inverse(glm::dmat3(world)));
    size_t corner = 0;
    for (size_t f = 0; f < counts->size(); ++f) {
      const size_t n = size_t((*counts)[f]);
      if (n >= 3) {
        const uint32_t base = uint32_t(in.positions.size());
        for (size_t k = 0; k < n; ++k) {
          const size_t point = size_t((*indices)[corner + k]);
          in.positions.push_back(
              DVec3(world * glm::dvec4((*points)[3 * point], (*points)[3 * point + 1], (*points)[3 * point + 2], 1.0)));
          if (normals.values) {
            const size_t i = 3 * primvarIndex(normals, f, corner + k, point);
            in.mesh.normals.push_back(
                Vec3(normalMatrix * DVec3((*normals.values)[i], (*normals.values)[i + 1], (*normals.values)[i + 2])));
          }
          if (st.values) {
            const size_t i = 2 * primvarIndex(st, f, corner + k, point);
            // USD's t grows upwards, lensfarm's v downwards (as glTF's): v = 1 - t.
            in.mesh.uv[0].push_back(Vec2(float((*st.values)[i]), float(1.0 - (*st.values)[i + 1])));
          }
        }
        for (size_t k = 1; k + 1 < n; ++k) {
          const uint32_t a = base, b = base + uint32_t(k), c = base + uint32_t(k + 1);
          in.mesh.indices.insert(in.mesh.indices.end(), {a, leftHanded ? c : b, leftHanded ? b : c});
          in.mesh.materialIds.push_back(faceMaterial[f]);
        }
      } else if (n > 0) {
        noteFor("faces of fewer than 3 points skipped", prim);
      }
      corner += n;
    }
    if (in.mesh.indices.empty()) return;
    (asPrototype ? model_.prototypes : model_.meshes).push_back(std::move(in));
  }

  // ---- materials --------------------------------------------------------------------------------
  // The model material for a bound Material's path ("" or unreadable: the default grey).
  uint32_t materialIndex(const std::string& path, const UsdPrim& boundAt) {
    if (const auto it = materialIds_.find(path); it != materialIds_.end()) return it->second;
    const UsdPrim* m = path.empty() ? nullptr : primAt(path);
    if (!path.empty() && !m) fail(boundAt, "material:binding names <" + path + ">, which does not exist");
    uint32_t id;
    if (!m) {
      id = defaultMaterial(boundAt);
    } else {
      model_.materials.push_back(previewSurface(*m));
      id = uint32_t(model_.materials.size() - 1);
    }
    materialIds_[path] = id;
    return id;
  }

  uint32_t defaultMaterial(const UsdPrim& mesh) {
    // USD viewers show an unbound mesh in its displayColor (grey without one).
    DVec3 colour(0.18);
    const UsdValue* v = valueOf(mesh, "primvars:displayColor");
    if (v && v->kind == UsdValue::Kind::kArray && v->arity == 3 && v->numbers.size() >= 3)
      colour = DVec3(v->numbers[0], v->numbers[1], v->numbers[2]);
    auto t = std::make_shared<MaterialTextures>();
    t->factors.baseColor = Spectrum(float(glm::clamp(colour.x, 0.0, 1.0)), float(glm::clamp(colour.y, 0.0, 1.0)),
                                    float(glm::clamp(colour.z, 0.0, 1.0)));
    t->factors.metallic = 0.0f;
    t->factors.roughness = 0.5f;
    model_.materials.push_back(Material::textured("USD default (displayColor)", std::move(t)));
    return uint32_t(model_.materials.size() - 1);
  }

  const UsdPrim* primAt(const std::string& path) const {
    const UsdPrim* at = &stage_.root;
    size_t from = 1;
    while (at && from < path.size()) {
      const size_t end = std::min(path.find('/', from), path.size());
      const std::string name = path.substr(from, end - from);
      // Inside an instance, its prototype's prims (all instances of one prototype share them).
      const UsdPrim* container = at->prototype >= 0 ? stage_.prototypes[size_t(at->prototype)].get() : at;
      const UsdPrim* next = nullptr;
      for (const auto& c : container->children)
        if (c->name == name) next = c.get();
      at = next;
      from = end + 1;
    }
    return at == &stage_.root ? nullptr : at;
  }

  // A connection "</Path/Shader.outputs:rgb>" as (prim, property name).
  std::pair<const UsdPrim*, std::string> connected(const std::string& target) const {
    const size_t dot = target.rfind('.');
    if (dot == std::string::npos) return {nullptr, ""};
    return {primAt(target.substr(0, dot)), target.substr(dot + 1)};
  }

  // The shader input `name`: its value, following connections to interface inputs; a texture
  // when it is connected to a UsdUVTexture's output (`textureOutput` says which).
  const UsdValue* input(const UsdPrim& shader, const std::string& name, const UsdPrim** texture,
                        std::string* textureOutput) const {
    const UsdPrim* at = &shader;
    std::string property = name;
    for (int hops = 0; hops < 16; ++hops) {
      const UsdProperty* p = at->property(property);
      if (!p) return nullptr;
      const std::vector<std::string> targets = at->targets(property);
      if (targets.empty()) return p->hasDefault ? &p->value : nullptr;
      const auto [next, nextProperty] = connected(targets.front());
      if (!next) return nullptr;
      if (token(*next, "info:id", "") == "UsdUVTexture") {
        if (texture) *texture = next;
        if (textureOutput) *textureOutput = nextProperty;
        return nullptr;
      }
      at = next;
      property = nextProperty;
    }
    return nullptr;
  }

  double scalarInput(const UsdPrim& shader, const std::string& name, double fallback, double lo, double hi,
                     const std::string& label) {
    const UsdPrim* texture = nullptr;
    const UsdValue* v = input(shader, name, &texture, nullptr);
    if (texture) notes_.insert(label + ": a texture on " + name + " is not carried (its fallback value is used)");
    if (!v || v->kind != UsdValue::Kind::kNumber) return fallback;
    if (!(v->number >= lo && v->number <= hi))
      fail(shader, name + ": " + num(v->number) + " is outside [" + num(lo) + ", " + num(hi) + "]");
    return v->number;
  }

  DVec3 colourInput(const UsdPrim& shader, const std::string& name, const DVec3& fallback, TextureRef* texture,
                    ColorEncoding encoding) {
    const UsdPrim* tex = nullptr;
    std::string output;
    const UsdValue* v = input(shader, name, &tex, &output);
    if (tex && texture) {
      *texture = textureOf(*tex, encoding);
      return DVec3(1.0);
    }
    if (!v || v->kind != UsdValue::Kind::kTuple || v->numbers.size() != 3) return fallback;
    for (double c : v->numbers)
      if (!(c >= 0 && c <= 1e30)) fail(shader, name + ": " + num(c) + " is not a colour value in [0, 1e30]");
    return DVec3(v->numbers[0], v->numbers[1], v->numbers[2]);
  }

  Wrap wrapOf(const UsdPrim& tex, const std::string& name) {
    const std::string w = token(tex, name, "useMetadata");
    if (w == "clamp") return Wrap::kClampToEdge;
    if (w == "mirror") return Wrap::kMirroredRepeat;
    if (w == "black") notes_.insert("<" + tex.path + ">: " + name + " black rendered as clamp");
    return w == "black" ? Wrap::kClampToEdge : Wrap::kRepeat;
  }

  TextureRef textureOf(const UsdPrim& tex, ColorEncoding encoding) {
    const UsdProperty* file = tex.property("inputs:file");
    if (!file || !file->hasDefault || file->value.kind != UsdValue::Kind::kAsset)
      fail(tex, "a UsdUVTexture needs inputs:file (an asset path)");
    // Relative to the layer the path was written in (its path relative to the root layer's folder).
    const UsdLayer* layer = tex.layerOf("inputs:file");
    const std::string layerDir = layer && layer != stage_.layers.front().get()
                                     ? std::filesystem::path(layer->file).parent_path().generic_string()
                                     : "";
    const std::string rel = layerDir.empty() ? file->value.text : layerDir + "/" + file->value.text;
    const std::string space = token(tex, "inputs:sourceColorSpace", "auto");
    if (space == "raw") encoding = ColorEncoding::kLinear;
    if (space == "sRGB") encoding = ColorEncoding::kSrgb;
    const auto key = std::make_tuple(rel, int(encoding), tex.path);
    if (const auto it = textures_.find(key); it != textures_.end()) return it->second;
    const std::optional<std::string> bytes = read_(rel);
    if (!bytes) fail(tex, "inputs:file: cannot read \"" + file->value.text + "\"");
    TextureRef ref;
    ref.texture =
        std::make_shared<const Texture>(shown_ + ": " + rel, decodeImage(*bytes, shown_ + ": " + rel, encoding),
                                        wrapOf(tex, "inputs:wrapS"), wrapOf(tex, "inputs:wrapT"));
    textures_[key] = ref;
    return ref;
  }

  Material previewSurface(const UsdPrim& material) {
    const std::string label = "material <" + material.path + ">";
    auto t = std::make_shared<MaterialTextures>();
    PrincipledParams& f = t->factors;
    f.metallic = 0.0f;
    f.roughness = 0.5f;
    const std::vector<std::string> out = material.targets("outputs:surface");
    const UsdPrim* shader = out.empty() ? nullptr : connected(out.front()).first;
    if (!shader || token(*shader, "info:id", "") != "UsdPreviewSurface") {
      notes_.insert(label + ": no UsdPreviewSurface on outputs:surface; rendered grey");
      f.baseColor = Spectrum(0.18f);
      return Material::textured(material.path, std::move(t));
    }
    const DVec3 base = colourInput(*shader, "inputs:diffuseColor", DVec3(0.18), &t->baseColor, ColorEncoding::kSrgb);
    f.baseColor = Spectrum(float(std::min(base.x, 1.0)), float(std::min(base.y, 1.0)), float(std::min(base.z, 1.0)));
    f.roughness = float(scalarInput(*shader, "inputs:roughness", 0.5, 0, 1, label));
    f.ior = float(scalarInput(*shader, "inputs:ior", 1.5, 1, 10, label));
    if (scalarInput(*shader, "inputs:useSpecularWorkflow", 0, 0, 1, label) > 0) {
      notes_.insert(label + ": the specular workflow rendered as metallic 0 (its specularColor not carried)");
    } else {
      f.metallic = float(scalarInput(*shader, "inputs:metallic", 0, 0, 1, label));
    }
    const double opacity = scalarInput(*shader, "inputs:opacity", 1, 0, 1, label);
    const double threshold = scalarInput(*shader, "inputs:opacityThreshold", 0, 0, 1, label);
    if (threshold > 0) {
      t->alphaMode = AlphaMode::kMask;
      t->alphaCutoff = float(threshold);
      t->alphaFactor = float(opacity);
    } else if (opacity < 1) {
      // UsdPreviewSurface: opacity below 1 with an ior is a transparent, refracting surface.
      f.transmission = float(1 - opacity);
      f.thinWalled = false;
      notes_.insert(label + ": opacity " + num(opacity) + " rendered as transmission " + num(1 - opacity) +
                    " through a solid of index " + num(f.ior));
    }
    if (scalarInput(*shader, "inputs:clearcoat", 0, 0, 1, label) > 0) notes_.insert(label + ": clearcoat not carried");
    TextureRef normal;
    colourInput(*shader, "inputs:normal", DVec3(0, 0, 1), &normal, ColorEncoding::kLinear);
    t->normal = normal;
    const DVec3 emission = colourInput(*shader, "inputs:emissiveColor", DVec3(0), &t->emissive, ColorEncoding::kSrgb);
    return Material::textured(material.path, std::move(t),
                              Spectrum(float(emission.x), float(emission.y), float(emission.z)), false);
  }

  // ---- cameras and lights -----------------------------------------------------------------------
  void camera(const UsdPrim& prim, const glm::dmat4& world) {
    const DVec3 position(world[3]);
    const DVec3 forward = glm::normalize(DVec3(world * glm::dvec4(0, 0, -1, 0)));
    const DVec3 up = glm::normalize(DVec3(world * glm::dvec4(0, 1, 0, 0)));
    if (token(prim, "projection", "perspective") != "perspective") {
      noteFor("orthographic cameras are not rendered", prim);
      return;
    }
    // Lens numbers are in tenths of a scene unit (UsdGeomCamera); only their ratios and the
    // focal length for the aperture matter.
    const double focal = number(prim, "focalLength", 50.0), horizontal = number(prim, "horizontalAperture", 20.955),
                 vertical = number(prim, "verticalAperture", 15.2908);
    if (!(focal > 0 && horizontal > 0 && vertical > 0))
      fail(prim, "focalLength, horizontalAperture and verticalAperture must be positive");
    if (number(prim, "horizontalApertureOffset", 0) != 0 || number(prim, "verticalApertureOffset", 0) != 0)
      noteFor("aperture offsets (lens shift) not carried", prim);
    const double fStop = number(prim, "fStop", 0), focus = number(prim, "focusDistance", 0);
    json j = {{"name", prim.name},
              {"position", array3(position)},
              {"up", array3(up)},
              {"aspect_ratio", horizontal / vertical}};
    if (fStop > 0 && focus > 0) {
      // A thin lens whose view at the focal plane is the camera's (its sensor scaled by S2 / f, as
      // lensfarm's thin lens moves its sensor back to focus, docs/blender.md).
      const double f = focal / 10.0;
      if (!(focus > f)) fail(prim, "focusDistance " + num(focus) + " is within the focal length " + num(f));
      const double s2 = f * focus / (focus - f);
      j["type"] = "thin_lens";
      j["focal_length"] = f;
      j["sensor_width"] = horizontal / 10.0 * s2 / f;
      j["sensor_height"] = vertical / 10.0 * s2 / f;
      j["f_number"] = std::max(fStop, 0.5);
      j["focus_distance"] = focus;
      j["look_at"] = array3(position + forward * focus);
      if (fStop < 0.5) noteFor("fStop below 0.5 rendered at f/0.5", prim);
    } else {
      j["type"] = "pinhole";
      j["angle_of_view"] = glm::degrees(2.0 * std::atan(horizontal / (2.0 * focal)));
      j["fov_axis"] = "horizontal";
      j["look_at"] = array3(position + forward);
    }
    model_.cameras.push_back(std::move(j));
  }

  // UsdLux's radiance: intensity x 2^exposure x colour (divided by the area when normalized).
  DVec3 radiance(const UsdPrim& prim, double area) const {
    const double intensity = number(prim, "inputs:intensity", 1.0) * std::exp2(number(prim, "inputs:exposure", 0.0));
    DVec3 c = vec3(prim, "inputs:color", DVec3(1.0)) * intensity;
    if (number(prim, "inputs:normalize", 0) > 0 && area > 0) c /= area;
    if (!(c.x >= 0 && c.y >= 0 && c.z >= 0)) fail(prim, "inputs:intensity and inputs:color give a negative light");
    return c;
  }

  void light(const UsdPrim& prim, const glm::dmat4& world) {
    const DVec3 position(world[3]);
    const DVec3 axis = DVec3(world * glm::dvec4(0, 0, -1, 0));  // lights shine along their -Z
    json j = {{"name", prim.name}};
    const std::string& type = prim.typeName;
    if (type == "RectLight" || type == "DiskLight") {
      double w = number(prim, "inputs:width", 1.0), h = number(prim, "inputs:height", 1.0);
      if (type == "DiskLight") {
        const double r = number(prim, "inputs:radius", 0.5);
        w = h = r * std::sqrt(glm::pi<double>());  // the square of the disk's area
        noteFor("disk lights rendered as the square of the same area", prim);
      }
      if (!(w > 0 && h > 0)) fail(prim, "a light's width, height and radius must be positive");
      const DVec3 ex = DVec3(world * glm::dvec4(w, 0, 0, 0)), ey = DVec3(world * glm::dvec4(0, h, 0, 0));
      // edge1 x edge2 along -Z, the side it lights: y x x.
      j["type"] = "quad";
      j["corner"] = array3(position - ex * 0.5 - ey * 0.5);
      j["edge1"] = array3(ey);
      j["edge2"] = array3(ex);
      j["radiance"] = array3(radiance(prim, glm::length(glm::cross(ex, ey))));
    } else if (type == "SphereLight") {
      const double r = number(prim, "inputs:radius", 0.5);
      if (r < 0) fail(prim, "inputs:radius must not be negative");
      // Seen from afar a sphere of radiance L has intensity L pi r^2 (a point light when r = 0).
      const double area = std::max(glm::pi<double>() * r * r, r > 0 ? 0.0 : 1.0);
      if (r > 0 && number(prim, "treatAsPoint", 0) == 0) noteFor("sphere lights rendered as points", prim);
      j["type"] = "point";
      j["position"] = array3(position);
      j["intensity"] = array3(radiance(prim, 4 * area) * area);
      const double cone = number(prim, "inputs:shaping:cone:angle", 90.0);
      if (cone < 90.0) {
        if (!(cone > 0)) fail(prim, "inputs:shaping:cone:angle must be in (0, 90]");
        const double softness = glm::clamp(number(prim, "inputs:shaping:cone:softness", 0.0), 0.0, 1.0);
        j["type"] = "spot";
        j["look_at"] = array3(position + axis);
        j["cone_angle"] = cone;
        j["falloff_start"] = cone * (1.0 - softness);
      }
    } else {
      const double angle = glm::clamp(number(prim, "inputs:angle", 0.53), 0.0, 90.0);
      const double s = std::sin(glm::radians(angle) / 2.0);
      // Radiance L over a disk of the angle gives irradiance L pi sin^2(angle / 2).
      j["type"] = "directional";
      j["direction"] = array3(-axis);
      j["irradiance"] = array3(radiance(prim, 0) * (angle > 0 ? glm::pi<double>() * s * s : 1.0));
      if (angle > 0) j["angular_diameter"] = angle;
    }
    model_.lights.push_back(std::move(j));
  }

  UsdStage& stage_;
  std::string shown_;
  const ModelFileReader& read_;
  ImportedModel model_;
  std::map<std::string, uint32_t> materialIds_;
  std::map<int, std::vector<uint32_t>> prototypeMeshes_;
  std::map<std::tuple<std::string, int, std::string>, TextureRef> textures_;
  std::map<std::string, std::vector<std::string>> notGrouped_;
  std::set<std::string> notes_;
  const std::vector<double> empty_;
  glm::dmat4 root_{1.0};
};

}  // namespace

ImportedModel importUsd(std::string bytes, const std::string& shown, const ModelFileReader& read) {
  if (!isZip(bytes)) {
    UsdStage stage = composeUsdStage(std::move(bytes), shown, read);
    return Importer(stage, shown, read).run();
  }
  // A .usdz: its root layer, and every file it names served from the package (relative to the
  // root layer's folder inside it); a file the package lacks is none.
  const UsdzPackage package = readUsdz(bytes, shown);
  std::string().swap(bytes);
  const std::filesystem::path rootDir = std::filesystem::path(package.rootLayer).parent_path();
  const ModelFileReader inside = [&](const std::string& rel) -> std::optional<std::string> {
    const auto it = package.files.find((rootDir / rel).lexically_normal().generic_string());
    if (it == package.files.end()) return std::nullopt;
    return it->second;
  };
  const std::string& root = package.files.at(package.rootLayer);
  if (isUsdCrate(root))
    throw InputError(shown + ": " + package.rootLayer,
                     "is a binary USD crate file (usdc): lensfarm reads USD's text format; convert the package with "
                     "`usdcat --flatten -o scene.usda scene.usdz`");
  UsdStage stage = composeUsdStage(root, shown + ": " + package.rootLayer, inside);
  return Importer(stage, shown, inside).run();
}

}  // namespace lensfarm
