#include "common/scene/gltf_import.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <iomanip>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>
#include <utility>

#include "common/light/light_source.h"
#include "common/medium/medium.h"
#include "common/scene/asset_path.h"
#include "common/texture/image_decode.h"
#include "common/util/error.h"

// How the importer uses tinygltf (libtinygltf-dev 2.7.0):
//  - The document is parsed and checked here first (nesting depth, asset.version,
//    extensionsRequired, image bufferViews inside their buffers), because tinygltf reads an
//    image's bufferView without checking it against its buffer and converts extensions
//    recursively.
//  - Every external file goes through the ModelFileReader: tinygltf looks for a uri's file at
//    "<kBaseDir>/<decoded uri>" through our FsCallbacks, which map that back to the uri's
//    percent-decoded path (tinygltf also turns '+' into a space; a path is not a query string).
//  - Images are not decoded by tinygltf: keepImageBytes keeps a uri image's bytes, and images in
//    bufferViews are read from the buffer here. decodeImage decodes them per colour role.
//  - tinygltf checks syntax; every index, accessor range, value range and vertex is checked here
//    before use, so a bad file ends in one InputError naming the element.
namespace lensfarm {
namespace {

using json = nlohmann::json;

// Extensions the importer maps (docs/scene-format.md, "glTF 2.0"); a model requiring another is refused.
constexpr const char* kSupportedExtensions[] = {
    "KHR_lights_punctual",    "KHR_materials_emissive_strength", "KHR_materials_ior",
    "KHR_materials_specular", "KHR_materials_transmission",      "KHR_materials_unlit",
    "KHR_materials_volume",   "KHR_mesh_quantization",           "KHR_texture_transform"};

constexpr int kMaxNesting = 64;  // as the scene loader allows
constexpr uint32_t kJsonChunk = 0x4E4F534A, kBinChunk = 0x004E4942;
// The base directory handed to tinygltf: a name no real directory has, so that the file
// callbacks recognise (and only serve) the paths tinygltf builds from the model's uris.
const std::string kBaseDir = "\x1flensfarm-gltf";

std::string indexed(const std::string& array, size_t i) { return array + "[" + std::to_string(i) + "]"; }
std::string labelled(const std::string& array, size_t i, const std::string& name) {
  return name.empty() ? indexed(array, i) : indexed(array, i) + " \"" + name + "\"";
}
std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}
std::string plural(size_t n, const std::string& word) {
  return std::to_string(n) + " " + (n == 1 ? word : word == "vertex" ? "vertices" : word + "s");
}
// A byte position, which may lie beyond 2^64 in a bad file.
std::string bytePosition(long double at) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(0) << at;
  return s.str();
}
bool isFinite(const DVec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
json array3(const DVec3& v) { return json::array({v.x, v.y, v.z}); }

uint32_t u32le(const std::string& bytes, size_t at) {
  uint32_t v = 0;
  for (size_t k = 0; k < 4; ++k) v |= uint32_t(static_cast<unsigned char>(bytes[at + k])) << (8 * k);
  return v;
}

// A uri's path: percent-decoded (RFC 3986), or as tinygltf decodes it before asking for the file
// ('+' also becomes a space, a '%' always takes the next two characters).
std::string decodeUri(const std::string& uri, bool asTinygltf) {
  auto hex = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  std::string out;
  for (size_t i = 0; i < uri.size(); ++i) {
    if (asTinygltf && uri[i] == '+') {
      out += ' ';
    } else if (uri[i] == '%' && i + 2 < uri.size() && (asTinygltf || (hex(uri[i + 1]) >= 0 && hex(uri[i + 2]) >= 0))) {
      out += char((std::max(hex(uri[i + 1]), 0) << 4) | std::max(hex(uri[i + 2]), 0));
      i += 2;
    } else {
      out += uri[i];
    }
  }
  return out;
}
bool isDataUri(const std::string& uri) { return uri.rfind("data:", 0) == 0; }

// end = offset + stride * (count - 1) + element, false on overflow (count > 0).
bool accessorEnd(size_t offset, size_t stride, size_t count, size_t element, size_t& end) {
  size_t span = 0;
  return !__builtin_mul_overflow(stride, count - 1, &span) && !__builtin_add_overflow(span, offset, &end) &&
         !__builtin_add_overflow(end, element, &end);
}

json parseJson(const std::string& text, const std::string& where) {
  const json::parser_callback_t limitDepth = [&where](int depth, json::parse_event_t event, json&) {
    if ((event == json::parse_event_t::object_start || event == json::parse_event_t::array_start) &&
        depth >= kMaxNesting)
      throw InputError(where, "nested deeper than " + std::to_string(kMaxNesting) + " levels");
    return true;
  };
  try {
    return json::parse(text, limitDepth);
  } catch (const json::exception& e) {
    // nlohmann's message ("[json.exception.parse_error.101] parse error at line 1, column 2: ...")
    // without its prefix.
    std::string what = e.what();
    const size_t end = what.find("] ");
    throw InputError(where, "malformed JSON: " + (end == std::string::npos ? what : what.substr(end + 2)));
  }
}

const char* typeName(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return "SCALAR";
    case TINYGLTF_TYPE_VEC2: return "VEC2";
    case TINYGLTF_TYPE_VEC3: return "VEC3";
    case TINYGLTF_TYPE_VEC4: return "VEC4";
    case TINYGLTF_TYPE_MAT2: return "MAT2";
    case TINYGLTF_TYPE_MAT3: return "MAT3";
    case TINYGLTF_TYPE_MAT4: return "MAT4";
    default: return "an unknown type";
  }
}
const char* componentName(int componentType) {
  switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: return "BYTE";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return "UNSIGNED_BYTE";
    case TINYGLTF_COMPONENT_TYPE_SHORT: return "SHORT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return "UNSIGNED_SHORT";
    case TINYGLTF_COMPONENT_TYPE_INT: return "INT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return "UNSIGNED_INT";
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return "FLOAT";
    case TINYGLTF_COMPONENT_TYPE_DOUBLE: return "DOUBLE";
    default: return "an unknown component type";
  }
}
size_t componentSize(int componentType) {
  switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_INT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    case TINYGLTF_COMPONENT_TYPE_DOUBLE: return 8;
    default: return 0;
  }
}
int componentCount(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4:
    case TINYGLTF_TYPE_MAT2: return 4;
    case TINYGLTF_TYPE_MAT3: return 9;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
  }
}

// What a vertex attribute or the indices may be stored as (glTF 2.0 §3.7.2.1; KHR_mesh_quantization
// widens it).
enum class Semantic { kPosition, kNormal, kTangent, kTexcoord, kIndices };

bool storable(Semantic s, int componentType, bool normalized, bool quantized) {
  const bool f = componentType == TINYGLTF_COMPONENT_TYPE_FLOAT && !normalized;
  const bool i8 = componentType == TINYGLTF_COMPONENT_TYPE_BYTE,
             u8 = componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
  const bool i16 = componentType == TINYGLTF_COMPONENT_TYPE_SHORT,
             u16 = componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
  switch (s) {
    case Semantic::kPosition: return f || (quantized && (i8 || u8 || i16 || u16));
    case Semantic::kNormal:
    case Semantic::kTangent: return f || (quantized && normalized && (i8 || i16));
    case Semantic::kTexcoord: return f || (normalized && (u8 || u16)) || (quantized && (i8 || u8 || i16 || u16));
    case Semantic::kIndices: return !normalized && (u8 || u16 || componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
  }
  return false;
}
int semanticType(Semantic s) {
  switch (s) {
    case Semantic::kPosition:
    case Semantic::kNormal: return TINYGLTF_TYPE_VEC3;
    case Semantic::kTangent: return TINYGLTF_TYPE_VEC4;
    case Semantic::kTexcoord: return TINYGLTF_TYPE_VEC2;
    case Semantic::kIndices: return TINYGLTF_TYPE_SCALAR;
  }
  return 0;
}
std::string expected(Semantic s, bool quantized) {
  const std::string integers = quantized ? " or of (normalized) BYTE, UNSIGNED_BYTE, SHORT or UNSIGNED_SHORT" : "";
  const std::string normalized = quantized ? " or of normalized BYTE or SHORT" : "";
  switch (s) {
    case Semantic::kPosition: return "VEC3 of FLOAT" + integers;
    case Semantic::kNormal: return "VEC3 of FLOAT" + normalized;
    case Semantic::kTangent: return "VEC4 of FLOAT" + normalized;
    case Semantic::kTexcoord: return "VEC2 of FLOAT, normalized UNSIGNED_BYTE or normalized UNSIGNED_SHORT" + integers;
    case Semantic::kIndices: return "SCALAR of UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT";
  }
  return "";
}

// An accessor's elements after its bounds were checked: element i's component c, as a number
// (normalized integers mapped to [0, 1] or [-1, 1] as glTF 2.0 §3.11 says).
struct AccessorData {
  const unsigned char* base = nullptr;
  size_t stride = 0, count = 0, size = 0;  // size: one component's bytes
  int componentType = 0;
  bool normalized = false;

  double get(size_t i, int c) const {
    const unsigned char* p = base + i * stride + size_t(c) * size;
    switch (componentType) {
      case TINYGLTF_COMPONENT_TYPE_BYTE: return scaled(load<int8_t>(p), 127.0);
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return scaled(load<uint8_t>(p), 255.0);
      case TINYGLTF_COMPONENT_TYPE_SHORT: return scaled(load<int16_t>(p), 32767.0);
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return scaled(load<uint16_t>(p), 65535.0);
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return load<uint32_t>(p);
      case TINYGLTF_COMPONENT_TYPE_FLOAT: return load<float>(p);
      default: return 0.0;
    }
  }
  template <class T>
  static double load(const unsigned char* p) {
    T v;
    std::memcpy(&v, p, sizeof v);
    return double(v);
  }
  // A normalized integer's value: max(v / largest, -1).
  double scaled(double v, double largest) const { return normalized ? std::max(v / largest, -1.0) : v; }
  DVec3 vec3(size_t i) const { return DVec3(get(i, 0), get(i, 1), get(i, 2)); }
};

// One primitive's triangles in the mesh's own space; attributes empty when it has none.
struct PrimitiveData {
  std::vector<DVec3> positions, normals;
  std::vector<glm::dvec4> tangents;
  std::vector<Vec2> uv[2];
  std::vector<uint32_t> indices;  // 3 per triangle
  uint32_t material = 0;
};

// A glTF mesh, all its primitives together, in its own space: what each node using it transforms.
struct LocalMesh {
  std::string name;
  std::vector<DVec3> positions, normals;
  std::vector<glm::dvec4> tangents;
  std::vector<Vec2> uv[2];
  std::vector<uint32_t> indices, materialIds;
};

// A primitive without normals in a mesh whose other primitives have them: each triangle gets its
// own three vertices with the face's normal (glTF 2.0 §3.7.2.1: flat normals when none are given).
void flatShade(PrimitiveData& d) {
  PrimitiveData flat;
  flat.material = d.material;
  for (size_t k = 0; k < d.indices.size(); ++k) {
    const uint32_t i = d.indices[k];
    flat.positions.push_back(d.positions[i]);
    for (int set = 0; set < 2; ++set)
      if (!d.uv[set].empty()) flat.uv[set].push_back(d.uv[set][i]);
    if (!d.tangents.empty()) flat.tangents.push_back(d.tangents[i]);
    flat.indices.push_back(uint32_t(k));
    if (k % 3 == 2) {
      const DVec3* p = &flat.positions[k - 2];
      DVec3 n = glm::cross(p[1] - p[0], p[2] - p[0]);
      const double length = glm::length(n);
      if (length > 0.0 && std::isfinite(length)) n /= length;
      flat.normals.insert(flat.normals.end(), 3, n);
    }
  }
  d = std::move(flat);
}

DVec3 normalizedOrZero(const DVec3& v) {
  const double length = glm::length(v);
  return length > 0.0 && std::isfinite(length) ? v / length : DVec3(0.0);
}

class GltfImporter {
 public:
  GltfImporter(std::string bytes, const std::string& shown, const ModelFileReader& read)
      : bytes_(std::move(bytes)), shown_(shown), read_(read) {}

  ImportedModel run() {
    binary_ = isGlb();
    root_ = binary_ ? parseJson(glbJson(), shown_) : parseJson(bytes_, shown_);
    checkDocument();
    load();
    std::string().swap(bytes_);  // tinygltf holds the buffers now
    root_ = json();
    quantized_ = std::count(gltf_.extensionsUsed.begin(), gltf_.extensionsUsed.end(), "KHR_mesh_quantization") ||
                 std::count(gltf_.extensionsRequired.begin(), gltf_.extensionsRequired.end(), "KHR_mesh_quantization");
    for (size_t i = 0; i < gltf_.materials.size(); ++i) model_.materials.push_back(material(i));
    meshes_.resize(gltf_.meshes.size());
    meshUses_.assign(gltf_.meshes.size(), 0);
    traverse();
    for (const Placed& c : cameras_) camera(c);
    for (const Placed& l : lights_) light(l);
    finalNotes();
    return std::move(model_);
  }

 private:
  // A node's camera or light with the node's world transform.
  struct Placed {
    size_t node, index;
    glm::dmat4 world;
  };

  [[noreturn]] void fail(const std::string& element, const std::string& what) const {
    throw InputError(shown_ + ": " + element, what);
  }
  [[noreturn]] void failFile(const std::string& what) const { throw InputError(shown_, what); }
  void noteOnce(const std::string& key, const std::string& text) {
    if (noted_.insert(key).second) model_.notes.push_back(text);
  }
  // "<what> does not exist (the model has N <what>s)" unless 0 <= index < count.
  void checkIndex(int64_t index, size_t count, const std::string& element, const std::string& what) const {
    if (index < 0 || uint64_t(index) >= count)
      fail(element, what + " " + std::to_string(index) + " does not exist (the model has " + plural(count, what) + ")");
  }

  // ---------------------------------------------------------------------------------------------
  // The file: .glb (recognised by its magic) or .gltf text.

  // Recognised by its magic; a file named .glb without it is refused unless it is JSON.
  bool isGlb() const {
    if (bytes_.size() > std::numeric_limits<uint32_t>::max()) failFile("larger than 4 GiB: not supported");
    if (bytes_.rfind("glTF", 0) == 0) return true;
    const bool named = shown_.size() >= 4 && (shown_.compare(shown_.size() - 4, 4, ".glb") == 0 ||
                                              shown_.compare(shown_.size() - 4, 4, ".GLB") == 0);
    const size_t first = bytes_.find_first_not_of(" \t\r\n");
    if (named && first != std::string::npos && bytes_[first] != '{') {
      std::ostringstream s;
      s << "not a glTF binary: it starts with" << std::hex;
      for (size_t k = 0; k < std::min<size_t>(4, bytes_.size()); ++k)
        s << " " << int(static_cast<unsigned char>(bytes_[k]));
      failFile(s.str() + ", not the magic \"glTF\"");
    }
    return false;
  }

  // The JSON chunk of a .glb, after checking its header and chunks (glTF 2.0 §4.4).
  std::string glbJson() {
    const size_t size = bytes_.size();
    if (size < 12) failFile("truncated glTF binary: " + plural(size, "byte") + ", shorter than its 12-byte header");
    const uint32_t version = u32le(bytes_, 4);
    if (version != 2) failFile("glTF binary version " + std::to_string(version) + " is not supported (only version 2)");
    glbLength_ = u32le(bytes_, 8);
    if (glbLength_ > size)
      failFile("truncated glTF binary: its header says " + plural(glbLength_, "byte") + ", the file has " +
               std::to_string(size));
    if (glbLength_ < 20) failFile("glTF binary of " + plural(glbLength_, "byte") + ": no room for its JSON chunk");
    const uint32_t jsonLength = u32le(bytes_, 12);
    if (u32le(bytes_, 16) != kJsonChunk) failFile("glTF binary: its first chunk is not JSON");
    if (jsonLength == 0) failFile("glTF binary: its JSON chunk is empty");
    if (uint64_t(20) + jsonLength > glbLength_)
      failFile("truncated glTF binary: its JSON chunk of " + plural(jsonLength, "byte") + " runs past its end (" +
               std::to_string(glbLength_) + " bytes)");
    const uint64_t bin = uint64_t(20) + jsonLength;
    if (bin + 8 <= glbLength_) {
      binLength_ = u32le(bytes_, size_t(bin));
      if (u32le(bytes_, size_t(bin) + 4) != kBinChunk) failFile("glTF binary: its second chunk is not BIN");
      if (bin + 8 + binLength_ > glbLength_)
        failFile("truncated glTF binary: its BIN chunk of " + plural(binLength_, "byte") + " runs past its end (" +
                 std::to_string(glbLength_) + " bytes)");
    } else if (bin != glbLength_) {
      failFile("truncated glTF binary: " + plural(glbLength_ - bin, "byte") +
               " after the JSON chunk, not a whole chunk");
    }
    return bytes_.substr(20, jsonLength);
  }

  // What tinygltf would accept but must not see, or what deserves a clearer message.
  void checkDocument() {
    if (!root_.is_object()) failFile("not a glTF model: its JSON is not an object");
    const json* asset = member(root_, "asset");
    if (!asset || !asset->is_object()) fail("asset", "missing: not a glTF 2.0 model");
    const json* version = member(*asset, "version");
    if (!version || !version->is_string()) fail("asset.version", "missing: not a glTF 2.0 model");
    if (version->get<std::string>().rfind("2.", 0) != 0)
      fail("asset.version", "\"" + version->get<std::string>() + "\": only glTF 2.0 is supported");
    if (const json* minVersion = member(*asset, "minVersion");
        minVersion && minVersion->is_string() && minVersion->get<std::string>() != "2.0")
      fail("asset.minVersion", "\"" + minVersion->get<std::string>() + "\": only glTF 2.0 is supported");

    const auto supported = [](const std::string& name) {
      return std::find(std::begin(kSupportedExtensions), std::end(kSupportedExtensions), name) !=
             std::end(kSupportedExtensions);
    };
    if (const json* required = member(root_, "extensionsRequired"); required && required->is_array())
      for (const json& e : *required)
        if (e.is_string() && !supported(e.get<std::string>()))
          fail("extensionsRequired", e.get<std::string>() + " is not supported");
    std::string unsupported;
    if (const json* used = member(root_, "extensionsUsed"); used && used->is_array())
      for (const json& e : *used)
        if (e.is_string() && !supported(e.get<std::string>()))
          unsupported += (unsupported.empty() ? "" : ", ") + e.get<std::string>();
    if (!unsupported.empty()) model_.notes.push_back("extensionsUsed: " + unsupported + " not supported: ignored");

    const json* buffers = member(root_, "buffers");
    const json* views = member(root_, "bufferViews");
    if (buffers && buffers->is_array())
      for (size_t i = 0; i < buffers->size(); ++i) {
        const json* uri = member((*buffers)[i], "uri");
        if (!binary_ && (!uri || !uri->is_string()))
          fail(indexed("buffers", i), "has no uri (only a .glb's buffer may leave it out, for its BIN chunk)");
        if (uri && uri->is_string()) addUri(uri->get<std::string>(), indexed("buffers", i) + ".uri");
      }
    if (const json* images = member(root_, "images"); images && images->is_array())
      for (size_t i = 0; i < images->size(); ++i) {
        const json* uri = member((*images)[i], "uri");
        if (uri && uri->is_string()) addUri(uri->get<std::string>(), indexed("images", i) + ".uri");
        const json* view = member((*images)[i], "bufferView");
        if (view && view->is_number_integer()) checkImageView(i, view->get<int64_t>(), buffers, views);
      }
    checkPrimitives(views);
  }

  // tinygltf drops a primitive without attributes (renumbering the rest) and refuses an indices
  // accessor without a valid bufferView in its own words.
  void checkPrimitives(const json* views) const {
    const json* meshes = member(root_, "meshes");
    if (!meshes || !meshes->is_array()) return;
    const json* accessors = member(root_, "accessors");
    const size_t accessorCount = accessors && accessors->is_array() ? accessors->size() : 0;
    const size_t viewCount = views && views->is_array() ? views->size() : 0;
    for (size_t m = 0; m < meshes->size(); ++m) {
      const json* primitives = member((*meshes)[m], "primitives");
      if (!primitives || !primitives->is_array()) continue;
      for (size_t p = 0; p < primitives->size(); ++p) {
        const std::string where = indexed("meshes", m) + "." + indexed("primitives", p);
        const json* attributes = member((*primitives)[p], "attributes");
        if (!attributes || !attributes->is_object()) fail(where + ".attributes", "missing or not an object");
        const json* indices = member((*primitives)[p], "indices");
        if (!indices || !indices->is_number_integer()) continue;
        checkIndex(indices->get<int64_t>(), accessorCount, where + ".indices", "accessor");
        const json* view = member((*accessors)[indices->get<size_t>()], "bufferView");
        const std::string field = indexed("accessors", indices->get<size_t>()) + ".bufferView";
        if (!view || !view->is_number_integer()) fail(field, "missing: an indices accessor needs a bufferView");
        checkIndex(view->get<int64_t>(), viewCount, field, "bufferView");
      }
    }
  }

  static const json* member(const json& object, const char* key) {
    if (!object.is_object()) return nullptr;
    const auto it = object.find(key);
    return it == object.end() ? nullptr : &*it;
  }
  static std::optional<uint64_t> unsignedMember(const json& object, const char* key) {
    const json* v = member(object, key);
    if (!v || !v->is_number_unsigned()) return std::nullopt;
    return v->get<uint64_t>();
  }

  // A uri that names a file: refused at once if it can name none (a remote URL, an absolute path:
  // scene/asset_path.h); the reader decides whether a relative one stays inside the asset root.
  void addUri(const std::string& uri, const std::string& where) {
    if (isDataUri(uri)) return;
    const std::string path = decodeUri(uri, false);
    if (const std::optional<std::string> problem = unreadablePathProblem(path))
      fail(where, "\"" + uri + "\" " + *problem);
    uriPaths_[decodeUri(uri, true)] = path;
  }

  // tinygltf reads an image's bufferView from its buffer unchecked: it must lie inside it.
  void checkImageView(size_t image, int64_t view, const json* buffers, const json* views) const {
    const std::string where = indexed("images", image);
    const size_t viewCount = views && views->is_array() ? views->size() : 0;
    checkIndex(view, viewCount, where + ".bufferView", "bufferView");
    const json& v = (*views)[size_t(view)];
    const json* buffer = member(v, "buffer");
    if (!buffer || !buffer->is_number_integer()) return;  // tinygltf refuses it
    const size_t bufferCount = buffers && buffers->is_array() ? buffers->size() : 0;
    checkIndex(buffer->get<int64_t>(), bufferCount, indexed("bufferViews", size_t(view)) + ".buffer", "buffer");
    const auto length = unsignedMember(v, "byteLength");
    const auto bufferLength = unsignedMember((*buffers)[buffer->get<size_t>()], "byteLength");
    if (!length || !bufferLength) return;  // tinygltf refuses them
    const uint64_t offset = unsignedMember(v, "byteOffset").value_or(0);
    uint64_t end = 0;
    if (__builtin_add_overflow(offset, *length, &end) || end > *bufferLength)
      fail(where, "bufferView " + std::to_string(view) + " reads past the end of buffer " +
                      std::to_string(buffer->get<int64_t>()) + " (it ends at byte " +
                      bytePosition((long double)offset + (long double)*length) + ", the buffer has " +
                      std::to_string(*bufferLength) + ")");
  }

  // ---------------------------------------------------------------------------------------------
  // tinygltf, with our file callbacks.

  void load() {
    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(&GltfImporter::keepImageBytes, this);
    loader.SetFsCallbacks(tinygltf::FsCallbacks{&GltfImporter::fileExists, &GltfImporter::expandFilePath,
                                                &GltfImporter::readWholeFile, &GltfImporter::writeWholeFile, this});
    std::string err, warn;
    const bool ok =
        binary_ ? loader.LoadBinaryFromMemory(
                      &gltf_, &err, &warn, reinterpret_cast<const unsigned char*>(bytes_.data()), glbLength_, kBaseDir)
                : loader.LoadASCIIFromString(&gltf_, &err, &warn, bytes_.data(), unsigned(bytes_.size()), kBaseDir);
    if (pending_) std::rethrow_exception(pending_);
    if (!ok) {
      diagnoseBuffers();
      failFile("not a valid glTF model: " + cleaned(err.empty() ? warn : err));
    }
    files_.clear();
  }

  // Why tinygltf refused the buffers, in our words, if a buffer is the reason.
  void diagnoseBuffers() const {
    const json* buffers = member(root_, "buffers");
    if (!buffers || !buffers->is_array()) return;
    for (size_t i = 0; i < buffers->size(); ++i) {
      const std::string where = indexed("buffers", i);
      const auto length = unsignedMember((*buffers)[i], "byteLength");
      if (!length) fail(where + ".byteLength", "missing or not an unsigned integer");
      const json* uri = member((*buffers)[i], "uri");
      if (!uri || !uri->is_string()) {
        if (binLength_ == 0) fail(where, "has no uri and the glTF binary has no BIN chunk");
        if (*length > binLength_)
          fail(where,
               "byteLength " + std::to_string(*length) + " exceeds the BIN chunk (" + plural(binLength_, "byte") + ")");
        continue;
      }
      const std::string text = uri->get<std::string>();
      if (isDataUri(text)) {
        std::vector<unsigned char> data;
        std::string mime;
        if (!tinygltf::DecodeDataURI(&data, mime, text, 0, false))
          fail(where + ".uri",
               "a data URI tinygltf cannot decode (base64 application/octet-stream or "
               "application/gltf-buffer expected)");
        if (data.size() != *length)
          fail(where + ".uri",
               "the data URI holds " + plural(data.size(), "byte") + ", byteLength says " + std::to_string(*length));
        continue;
      }
      const std::string path = decodeUri(text, false);
      const auto file = files_.find(path);
      if (file == files_.end()) continue;  // not asked for: tinygltf stopped earlier
      if (!file->second) fail(where, "cannot read \"" + path + "\"");
      if (file->second->size() != *length)
        fail(where, "\"" + path + "\" has " + plural(file->second->size(), "byte") + ", byteLength says " +
                        std::to_string(*length));
    }
  }

  std::string cleaned(std::string message) const {
    for (size_t at; (at = message.find(kBaseDir + "/")) != std::string::npos;) message.erase(at, kBaseDir.size() + 1);
    std::replace(message.begin(), message.end(), '\n', ' ');
    while (!message.empty() && message.back() == ' ') message.pop_back();
    if (message.size() > 300) message = message.substr(0, 300) + "...";
    return message.empty() ? "tinygltf gave no reason" : message;
  }

  // The bytes of the file a uri names, read once through the reader.
  const std::optional<std::string>* file(const std::string& tinygltfPath) {
    const std::string prefix = kBaseDir + "/";
    if (tinygltfPath.rfind(prefix, 0) != 0) return nullptr;  // tinygltf's other guess, "./<uri>"
    const auto uri = uriPaths_.find(tinygltfPath.substr(prefix.size()));
    if (uri == uriPaths_.end()) return nullptr;
    auto it = files_.find(uri->second);
    if (it == files_.end()) {
      std::optional<std::string> bytes;
      try {
        if (read_) bytes = read_(uri->second);
      } catch (...) {
        if (!pending_) pending_ = std::current_exception();
      }
      it = files_.emplace(uri->second, std::move(bytes)).first;
    }
    return &it->second;
  }

  static bool fileExists(const std::string& path, void* self) {
    const std::optional<std::string>* bytes = static_cast<GltfImporter*>(self)->file(path);
    return bytes && bytes->has_value();
  }
  static std::string expandFilePath(const std::string& path, void*) { return path; }
  static bool readWholeFile(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* self) {
    const std::optional<std::string>* bytes = static_cast<GltfImporter*>(self)->file(path);
    if (!bytes || !bytes->has_value()) {
      if (err) *err = "cannot read it";
      return false;
    }
    out->assign((*bytes)->begin(), (*bytes)->end());
    return true;
  }
  static bool writeWholeFile(std::string*, const std::string&, const std::vector<unsigned char>&, void*) {
    return false;
  }
  // Keeps a uri image's bytes undecoded (decodeImage decodes them per colour role); images in a
  // bufferView are read from their buffer later, after checks.
  static bool keepImageBytes(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                             const unsigned char* bytes, int size, void*) {
    if (image->bufferView < 0 && bytes && size > 0) image->image.assign(bytes, bytes + size);
    return true;
  }

  // ---------------------------------------------------------------------------------------------
  // Materials and textures.

  // A number of an extension's object: `fallback` if absent, else within [lo, hi].
  double extensionNumber(const tinygltf::Value& object, const char* key, double fallback, double lo, double hi,
                         const std::string& where) const {
    if (!object.Has(key)) return fallback;
    const tinygltf::Value& v = object.Get(key);
    if (!v.IsNumber()) fail(where + "." + key, "must be a number");
    return inRange(v.GetNumberAsDouble(), lo, hi, where + "." + key);
  }
  Vec2 extensionVec2(const tinygltf::Value& object, const char* key, Vec2 fallback, const std::string& where) const {
    if (!object.Has(key)) return fallback;
    const tinygltf::Value& v = object.Get(key);
    if (!v.IsArray() || v.ArrayLen() != 2 || !v.Get(0).IsNumber() || !v.Get(1).IsNumber())
      fail(where + "." + key, "must be 2 numbers");
    return Vec2(float(v.Get(0).GetNumberAsDouble()), float(v.Get(1).GetNumberAsDouble()));
  }
  double inRange(double x, double lo, double hi, const std::string& field) const {
    if (!(x >= lo && x <= hi)) fail(field, "must be in [" + num(lo) + ", " + num(hi) + "], got " + num(x));
    return x;
  }
  static const tinygltf::Value* extension(const tinygltf::ExtensionMap& extensions, const char* name) {
    const auto it = extensions.find(name);
    return it != extensions.end() && it->second.IsObject() ? &it->second : nullptr;
  }

  Material material(size_t i) {
    const tinygltf::Material& m = gltf_.materials[i];
    const std::string where = indexed("materials", i), label = labelled("materials", i, m.name);
    auto t = std::make_shared<MaterialTextures>();
    PrincipledParams& f = t->factors;
    coreFactorsAndTextures(m, where, label, *t);

    if (m.emissiveFactor.size() != 3) fail(where + ".emissiveFactor", "must be 3 numbers");
    DVec3 emission(0.0);
    for (int c = 0; c < 3; ++c) emission[c] = inRange(m.emissiveFactor[size_t(c)], 0.0, 1.0, where + ".emissiveFactor");

    readAlphaMode(m, where, label, *t);

    const std::string ext = where + ".extensions.";
    if (const tinygltf::Value* e = extension(m.extensions, "KHR_materials_emissive_strength"))
      emission *= extensionNumber(*e, "emissiveStrength", 1.0, 0.0, 1e30, ext + "KHR_materials_emissive_strength");
    if (const tinygltf::Value* e = extension(m.extensions, "KHR_materials_transmission")) {
      const std::string w = ext + "KHR_materials_transmission";
      f.transmission = float(extensionNumber(*e, "transmissionFactor", 0.0, 0.0, 1.0, w));
      if (e->Has("transmissionTexture"))
        model_.notes.push_back(label + ": transmissionTexture ignored (transmissionFactor used everywhere)");
    }
    if (const tinygltf::Value* e = extension(m.extensions, "KHR_materials_ior"))
      f.ior = float(extensionNumber(*e, "ior", 1.5, 1.0, 10.0, ext + "KHR_materials_ior"));
    if (const tinygltf::Value* e = extension(m.extensions, "KHR_materials_specular"))
      specularExtension(*e, ext + "KHR_materials_specular", label, f);
    if (extension(m.extensions, "KHR_materials_unlit")) {
      // Unlit: the base colour as it is, whatever the light. A path tracer has no such surface;
      // the nearest is a Lambertian of the base colour (lit by the scene like any other).
      f.metallic = 0.0f;
      f.roughness = 1.0f;
      f.specular = 0.0f;
      f.transmission = 0.0f;
      t->metallicRoughness = TextureRef();
      t->normal = TextureRef();
      model_.notes.push_back(label +
                             ": KHR_materials_unlit rendered as a Lambertian surface of its base colour "
                             "(lit by the scene's lights)");
    }
    std::shared_ptr<const Medium> interior;
    if (const tinygltf::Value* e = extension(m.extensions, "KHR_materials_volume")) {
      // thicknessFactor > 0 makes the surface a volume's boundary: a solid that refracts
      // (KHR_materials_volume: "the material is thin-walled" only where it is 0).
      f.thinWalled = !(f.transmission > 0.0f &&
                       extensionNumber(*e, "thicknessFactor", 0.0, 0.0, 1e30, ext + "KHR_materials_volume") > 0.0);
      interior = volumeOf(*e, f.transmission, label, ext + "KHR_materials_volume");
    }
    // doubleSided: lit (and emitting) on both faces, as rasterisers and Cycles show it; one-sided
    // emission otherwise (glTF 2.0 §3.9.5).
    Material out = Material::textured(m.name.empty() ? where : m.name, std::move(t),
                                      Spectrum(float(emission.x), float(emission.y), float(emission.z)), m.doubleSided);
    out.interior = std::move(interior);
    return out;
  }

  // The pbrMetallicRoughness factors and textures, the normal and emissive textures, and a note
  // of an occlusion texture, checked into `t`.
  void coreFactorsAndTextures(const tinygltf::Material& m, const std::string& where, const std::string& label,
                              MaterialTextures& t) {
    PrincipledParams& f = t.factors;
    const auto& pbr = m.pbrMetallicRoughness;
    const std::string pbrWhere = where + ".pbrMetallicRoughness";
    if (pbr.baseColorFactor.size() != 4) fail(pbrWhere + ".baseColorFactor", "must be 4 numbers");
    for (int c = 0; c < 4; ++c) inRange(pbr.baseColorFactor[size_t(c)], 0.0, 1.0, pbrWhere + ".baseColorFactor");
    f.baseColor = Spectrum(float(pbr.baseColorFactor[0]), float(pbr.baseColorFactor[1]), float(pbr.baseColorFactor[2]));
    t.alphaFactor = float(pbr.baseColorFactor[3]);
    f.metallic = float(inRange(pbr.metallicFactor, 0.0, 1.0, pbrWhere + ".metallicFactor"));
    f.roughness = float(inRange(pbr.roughnessFactor, 0.0, 1.0, pbrWhere + ".roughnessFactor"));
    if (pbr.baseColorTexture.index >= 0)
      t.baseColor = textureRef(pbr.baseColorTexture, ColorEncoding::kSrgb, pbrWhere + ".baseColorTexture");
    if (pbr.metallicRoughnessTexture.index >= 0)
      t.metallicRoughness =
          textureRef(pbr.metallicRoughnessTexture, ColorEncoding::kLinear, pbrWhere + ".metallicRoughnessTexture");
    if (m.normalTexture.index >= 0) {
      const tinygltf::NormalTextureInfo& n = m.normalTexture;
      t.normal = textureRef(n.index, n.texCoord, n.extensions, ColorEncoding::kLinear, where + ".normalTexture");
      if (!std::isfinite(n.scale)) fail(where + ".normalTexture.scale", "must be a finite number");
      t.normalScale = float(n.scale);
    }
    if (m.emissiveTexture.index >= 0)
      t.emissive = textureRef(m.emissiveTexture, ColorEncoding::kSrgb, where + ".emissiveTexture");
    if (m.occlusionTexture.index >= 0) occluded_.push_back(label);
  }

  // The material's alphaMode (and alphaCutoff) into `t`; BLEND is noted as rendered as MASK.
  void readAlphaMode(const tinygltf::Material& m, const std::string& where, const std::string& label,
                     MaterialTextures& t) {
    if (m.alphaMode == "MASK") {
      t.alphaMode = AlphaMode::kMask;
      t.alphaCutoff = float(inRange(m.alphaCutoff, 0.0, 1.0, where + ".alphaCutoff"));
    } else if (m.alphaMode == "BLEND") {
      t.alphaMode = AlphaMode::kBlend;
      t.alphaCutoff = 0.5f;
      model_.notes.push_back(label + ": alphaMode BLEND rendered as MASK with cutoff 0.5");
    } else if (m.alphaMode != "OPAQUE") {
      fail(where + ".alphaMode", "\"" + m.alphaMode + "\" is not OPAQUE, MASK or BLEND");
    }
  }

  // KHR_materials_specular (object `e`, at `w`) into `f`: its factor and an untinted colour factor.
  void specularExtension(const tinygltf::Value& e, const std::string& w, const std::string& label,
                         PrincipledParams& f) {
    f.specular = float(extensionNumber(e, "specularFactor", 1.0, 0.0, 1.0, w));
    if (e.Has("specularTexture")) model_.notes.push_back(label + ": specularTexture ignored (specularFactor used)");
    if (e.Has("specularColorFactor")) {
      const tinygltf::Value& v = e.Get("specularColorFactor");
      if (!v.IsArray() || v.ArrayLen() != 3) fail(w + ".specularColorFactor", "must be 3 numbers");
      Spectrum c;
      for (int k = 0; k < 3; ++k) {
        if (!v.Get(k).IsNumber()) fail(w + ".specularColorFactor", "must be 3 numbers");
        c[k] = float(inRange(v.Get(k).GetNumberAsDouble(), 0.0, 1e6, w + ".specularColorFactor"));
      }
      f.specularColor = luminance(c);  // F0 scaled, untinted
      if (c.r != c.g || c.g != c.b)
        model_.notes.push_back(label + ": specularColorFactor approximated: F0 is scaled by its luminance, untinted");
    }
    if (e.Has("specularColorTexture"))
      model_.notes.push_back(label + ": specularColorTexture ignored (specularColorFactor used)");
  }

  // KHR_materials_volume: the absorbing medium behind a transmitting surface (docs/media.md):
  // sigma_t = -ln(attenuationColor) / attenuationDistance per channel. The extension applies to
  // transmitting materials with thicknessFactor > 0 (0 means thin-walled: no volume); elsewhere
  // it is noted and ignored. The mesh's real geometry gives the distances (thicknessFactor and
  // thicknessTexture are for rasterisers' approximations and are not read).
  std::shared_ptr<const Medium> volumeOf(const tinygltf::Value& e, float transmission, const std::string& label,
                                         const std::string& w) {
    const double thickness = extensionNumber(e, "thicknessFactor", 0.0, 0.0, 1e30, w);
    const double distance =
        extensionNumber(e, "attenuationDistance", std::numeric_limits<double>::infinity(), 0.0, 1e300, w);
    if (e.Has("attenuationDistance") && !(distance > 0.0)) fail(w + ".attenuationDistance", "must be > 0");
    Spectrum color(1.0f);
    if (e.Has("attenuationColor")) {
      const tinygltf::Value& v = e.Get("attenuationColor");
      if (!v.IsArray() || v.ArrayLen() != 3) fail(w + ".attenuationColor", "must be 3 numbers");
      for (int c = 0; c < 3; ++c) {
        if (!v.Get(c).IsNumber()) fail(w + ".attenuationColor", "must be 3 numbers");
        // 0 (black) is the strongest absorption the extension can say: 1e-6 after one distance.
        color[c] = std::max(1e-6f, float(inRange(v.Get(c).GetNumberAsDouble(), 0.0, 1.0, w + ".attenuationColor")));
      }
    }
    if (!(transmission > 0.0f) || !(thickness > 0.0)) {
      model_.notes.push_back(label + ": KHR_materials_volume ignored (" +
                             (transmission > 0.0f ? std::string("thicknessFactor 0: thin-walled")
                                                  : std::string("the material transmits no light")) +
                             ")");
      return nullptr;
    }
    if (color == Spectrum(1.0f) || std::isinf(distance)) return nullptr;  // a clear volume: nothing to simulate
    return std::make_shared<const Medium>(
        label, HomogeneousMedium::fromAttenuation(color, float(distance), Spectrum(0.0f), 0.0f));
  }

  TextureRef textureRef(const tinygltf::TextureInfo& info, ColorEncoding encoding, const std::string& where) {
    return textureRef(info.index, info.texCoord, info.extensions, encoding, where);
  }

  TextureRef textureRef(int index, int texCoord, const tinygltf::ExtensionMap& extensions, ColorEncoding encoding,
                        const std::string& where) {
    TextureRef ref;
    checkIndex(index, gltf_.textures.size(), where + ".index", "texture");
    if (const tinygltf::Value* e = extension(extensions, "KHR_texture_transform")) {
      const std::string w = where + ".extensions.KHR_texture_transform";
      ref.transform.offset = extensionVec2(*e, "offset", Vec2(0.0f), w);
      ref.transform.scale = extensionVec2(*e, "scale", Vec2(1.0f), w);
      ref.transform.rotation = float(extensionNumber(*e, "rotation", 0.0, -1e30, 1e30, w));
      if (e->Has("texCoord")) {
        if (!e->Get("texCoord").IsInt()) fail(w + ".texCoord", "must be an integer");
        texCoord = e->Get("texCoord").GetNumberAsInt();
      }
    }
    if (texCoord < 0 || texCoord > 1)
      fail(where + ".texCoord",
           "TEXCOORD_" + std::to_string(texCoord) + " is not supported (only TEXCOORD_0 and TEXCOORD_1)");
    ref.uvSet = texCoord;

    const size_t t = size_t(index);
    const tinygltf::Texture& texture = gltf_.textures[t];
    const std::string texWhere = indexed("textures", t);
    if (texture.source == -1) {
      noteOnce("source " + texWhere, labelled("textures", t, texture.name) +
                                         ": no image in a format lensfarm reads (PNG, JPEG, HDR, EXR): ignored");
      return TextureRef();
    }
    checkIndex(texture.source, gltf_.images.size(), texWhere + ".source", "image");
    Wrap wrapS = Wrap::kRepeat, wrapT = Wrap::kRepeat;
    TextureFilter filter = TextureFilter::kLinear;
    if (texture.sampler != -1) {
      checkIndex(texture.sampler, gltf_.samplers.size(), texWhere + ".sampler", "sampler");
      const tinygltf::Sampler& s = gltf_.samplers[size_t(texture.sampler)];
      const std::string sw = indexed("samplers", size_t(texture.sampler));
      wrapS = wrap(s.wrapS, sw + ".wrapS");
      wrapT = wrap(s.wrapT, sw + ".wrapT");
      if (s.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST)
        filter = TextureFilter::kNearest;
      else if (s.magFilter != -1 && s.magFilter != TINYGLTF_TEXTURE_FILTER_LINEAR)
        fail(sw + ".magFilter", std::to_string(s.magFilter) + " is not NEAREST (9728) or LINEAR (9729)");
    }
    ref.texture = decodedTexture(size_t(texture.source), wrapS, wrapT, filter, encoding);
    return ref;
  }

  Wrap wrap(int mode, const std::string& field) const {
    switch (mode) {
      case TINYGLTF_TEXTURE_WRAP_REPEAT: return Wrap::kRepeat;
      case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT: return Wrap::kMirroredRepeat;
      case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE: return Wrap::kClampToEdge;
      default:
        fail(field, std::to_string(mode) + " is not REPEAT (10497), MIRRORED_REPEAT (33648) or CLAMP_TO_EDGE (33071)");
    }
  }

  // One Texture per (image, wrap modes, filter, encoding); one decode per (image, encoding).
  std::shared_ptr<const Texture> decodedTexture(size_t image, Wrap wrapS, Wrap wrapT, TextureFilter filter,
                                                ColorEncoding encoding) {
    const auto key = std::make_tuple(image, int(wrapS), int(wrapT), int(filter), int(encoding));
    if (const auto it = textures_.find(key); it != textures_.end()) return it->second;
    const std::string name = shown_ + ": " + indexed("images", image);
    std::shared_ptr<const RgbaImage>& decoded = images_[std::make_pair(image, int(encoding))];
    if (!decoded) decoded = std::make_shared<const RgbaImage>(decodeImage(imageBytes(image), name, encoding));
    auto texture = std::make_shared<const Texture>(name, *decoded, wrapS, wrapT, filter);
    textures_.emplace(key, texture);
    return texture;
  }

  std::string imageBytes(size_t i) const {
    const tinygltf::Image& image = gltf_.images[i];
    const std::string where = indexed("images", i);
    if (image.bufferView >= 0) {
      checkIndex(image.bufferView, gltf_.bufferViews.size(), where + ".bufferView", "bufferView");
      const tinygltf::BufferView& view = gltf_.bufferViews[size_t(image.bufferView)];
      const size_t end = checkedView(size_t(image.bufferView), where);
      const std::vector<unsigned char>& data = gltf_.buffers[size_t(view.buffer)].data;
      return std::string(data.begin() + std::ptrdiff_t(view.byteOffset), data.begin() + std::ptrdiff_t(end));
    }
    if (!image.image.empty()) return std::string(image.image.begin(), image.image.end());
    if (image.uri.empty() || isDataUri(image.uri))
      fail(where, "holds no image data (a data URI must be base64 PNG, JPEG, BMP or GIF)");
    fail(where, "cannot read \"" + decodeUri(image.uri, false) + "\"");
  }

  // ---------------------------------------------------------------------------------------------
  // Accessors and primitives.

  // Checks that bufferView `v` lies in its buffer; returns its end (byteOffset + byteLength).
  size_t checkedView(size_t v, const std::string& where) const {
    const tinygltf::BufferView& view = gltf_.bufferViews[v];
    checkIndex(view.buffer, gltf_.buffers.size(), indexed("bufferViews", v) + ".buffer", "buffer");
    const size_t bufferSize = gltf_.buffers[size_t(view.buffer)].data.size();
    size_t end = 0;
    if (__builtin_add_overflow(view.byteOffset, view.byteLength, &end) || end > bufferSize)
      fail(where, "bufferView " + std::to_string(v) + " reads past the end of buffer " + std::to_string(view.buffer) +
                      " (it ends at byte " + bytePosition((long double)view.byteOffset + (long double)view.byteLength) +
                      " of " + std::to_string(bufferSize) + ")");
    return end;
  }

  // Accessor `index`, read for `what` (an attribute's name, or "indices") of the primitive at
  // `where`: its kind checked against `semantic`, then its whole extent against its bufferView
  // and buffer, before anything is read.
  AccessorData accessor(int index, Semantic semantic, const std::string& what, const std::string& where) const {
    const std::string field = where + (semantic == Semantic::kIndices ? ".indices" : ".attributes." + what);
    checkIndex(index, gltf_.accessors.size(), field, "accessor");
    const tinygltf::Accessor& a = gltf_.accessors[size_t(index)];
    const std::string name = "accessor " + std::to_string(index);
    if (a.type != semanticType(semantic) || !storable(semantic, a.componentType, a.normalized, quantized_))
      fail(field, name + " is " + typeName(a.type) + " of " + componentName(a.componentType) +
                      (a.normalized ? " (normalized)" : "") + "; " + what + " must be " +
                      expected(semantic, quantized_));
    if (a.sparse.isSparse) fail(where, name + " (" + what + ") is sparse: sparse accessors are not supported");
    if (a.bufferView < 0) fail(where, name + " (" + what + ") has no bufferView (all zeros): not supported");
    checkIndex(a.bufferView, gltf_.bufferViews.size(), indexed("accessors", size_t(index)) + ".bufferView",
               "bufferView");
    const size_t v = size_t(a.bufferView);
    const tinygltf::BufferView& view = gltf_.bufferViews[v];
    checkIndex(view.buffer, gltf_.buffers.size(), indexed("bufferViews", v) + ".buffer", "buffer");
    const std::vector<unsigned char>& buffer = gltf_.buffers[size_t(view.buffer)].data;

    AccessorData d;
    d.componentType = a.componentType;
    d.normalized = a.normalized;
    d.size = componentSize(a.componentType);
    d.count = a.count;
    const size_t element = d.size * size_t(componentCount(a.type));
    d.stride = view.byteStride ? view.byteStride : element;
    if (d.stride < element)
      fail(where, name + " (" + what + "): bufferView " + std::to_string(v) + "'s byteStride " +
                      std::to_string(view.byteStride) + " is shorter than one element (" + plural(element, "byte") +
                      ")");
    if (d.count > 0) {
      size_t end = 0;  // within the bufferView
      const bool overflow = !accessorEnd(a.byteOffset, d.stride, d.count, element, end);
      const std::string extent =
          " (" + what + ": " + plural(d.count, "element") + " end at byte " +
          bytePosition((long double)view.byteOffset + (long double)a.byteOffset +
                       (long double)d.stride * (long double)(d.count - 1) + (long double)element);
      if (overflow || end > buffer.size() || view.byteOffset > buffer.size() - end)
        fail(where, name + " reads past the end of buffer " + std::to_string(view.buffer) + extent + " of " +
                        std::to_string(buffer.size()) + ")");
      checkedView(v, where);
      if (end > view.byteLength)
        fail(where, name + " reads past the end of bufferView " + std::to_string(v) + extent + ", the bufferView has " +
                        plural(view.byteLength, "byte") + ")");
      d.base = buffer.data() + view.byteOffset + a.byteOffset;
    }
    return d;
  }

  uint32_t defaultMaterial() {
    if (!defaultMaterial_) {
      // glTF 2.0 §3.9.6: a primitive without a material is rendered with the default material,
      // PrincipledParams' defaults (white, metallic 1, roughness 1).
      defaultMaterial_ = uint32_t(model_.materials.size());
      model_.materials.push_back(
          Material::textured("glTF default material", std::make_shared<MaterialTextures>(), Spectrum(0.0f), false));
    }
    return *defaultMaterial_;
  }

  std::optional<PrimitiveData> primitive(size_t m, size_t p) {
    const tinygltf::Primitive& prim = gltf_.meshes[m].primitives[p];
    const std::string where = indexed("meshes", m) + "." + indexed("primitives", p);
    static const char* const kModes[] = {"POINTS", "LINES", "LINE_LOOP", "LINE_STRIP"};
    if (prim.mode >= 0 && prim.mode <= 3) {
      model_.notes.push_back(where + ": mode " + kModes[prim.mode] + " skipped: only triangles are rendered");
      return std::nullopt;
    }
    if (prim.mode < 4 || prim.mode > 6)
      fail(where + ".mode", std::to_string(prim.mode) + " is not a glTF primitive mode (0 to 6)");
    PrimitiveData d;
    if (prim.material == -1) {
      d.material = defaultMaterial();
    } else {
      checkIndex(prim.material, gltf_.materials.size(), where + ".material", "material");
      d.material = uint32_t(prim.material);
    }

    const auto attribute = [&](const char* name) -> const int* {
      const auto it = prim.attributes.find(name);
      return it == prim.attributes.end() ? nullptr : &it->second;
    };
    const int* position = attribute("POSITION");
    if (!position) fail(where + ".attributes", "has no POSITION");
    const AccessorData positions = accessor(*position, Semantic::kPosition, "POSITION", where);
    if (positions.count > std::numeric_limits<uint32_t>::max())
      fail(where, "POSITION has " + plural(positions.count, "vertex") + ": at most 2^32 - 1 are supported");
    const size_t count = positions.count;
    const auto sameCount = [&](const AccessorData& a, const std::string& what) {
      if (a.count != count)
        fail(where + ".attributes." + what,
             "has " + plural(a.count, "element") + ", POSITION has " + std::to_string(count));
    };
    // (The value is formatted only for the message: never for the millions of good ones.)
    const auto notFinite = [&](const std::string& what, size_t i, const std::string& value) {
      fail(where, what + " (accessor " + std::to_string(prim.attributes.at(what)) + "): element " + std::to_string(i) +
                      " is not finite (" + value + ")");
    };
    // The first three components of attribute `what`'s elements, each finite.
    const auto vectors = [&](const AccessorData& a, const std::string& what) {
      std::vector<DVec3> out(count);
      for (size_t i = 0; i < count; ++i) {
        out[i] = a.vec3(i);
        if (!isFinite(out[i])) notFinite(what, i, num(out[i].x) + ", " + num(out[i].y) + ", " + num(out[i].z));
      }
      return out;
    };
    d.positions = vectors(positions, "POSITION");
    if (const int* normal = attribute("NORMAL")) {
      const AccessorData a = accessor(*normal, Semantic::kNormal, "NORMAL", where);
      sameCount(a, "NORMAL");
      d.normals = vectors(a, "NORMAL");
    }
    if (const int* tangent = attribute("TANGENT")) {
      const AccessorData a = accessor(*tangent, Semantic::kTangent, "TANGENT", where);
      sameCount(a, "TANGENT");
      const std::vector<DVec3> xyz = vectors(a, "TANGENT");
      for (size_t i = 0; i < count; ++i) d.tangents.emplace_back(xyz[i], a.get(i, 3) < 0.0 ? -1.0 : 1.0);
    }
    for (int set = 0; set < 2; ++set) {
      const std::string name = "TEXCOORD_" + std::to_string(set);
      const int* texcoord = attribute(name.c_str());
      if (!texcoord) continue;
      const AccessorData a = accessor(*texcoord, Semantic::kTexcoord, name, where);
      sameCount(a, name);
      d.uv[set].resize(count);
      for (size_t i = 0; i < count; ++i) {
        const double u = a.get(i, 0), v = a.get(i, 1);
        if (!std::isfinite(float(u)) || !std::isfinite(float(v))) notFinite(name, i, num(u) + ", " + num(v));
        d.uv[set][i] = Vec2(float(u), float(v));
      }
    }
    noteIgnoredAttributes(prim, where);

    triangles(prim.mode, primitiveVertices(prim, count, where), d.indices, where);
    return d;
  }

  // Notes (once each) the primitive's attributes and morph targets that are not read.
  void noteIgnoredAttributes(const tinygltf::Primitive& prim, const std::string& where) {
    for (const auto& [name, index] : prim.attributes) {
      (void)index;
      if (name.rfind("TEXCOORD_", 0) == 0 && name != "TEXCOORD_0" && name != "TEXCOORD_1")
        noteOnce("texcoord", where + ": " + name + " ignored (only TEXCOORD_0 and TEXCOORD_1 are read)");
      if (name.rfind("COLOR_", 0) == 0) noteOnce("color", where + ": vertex colours (" + name + ") ignored");
    }
    if (!prim.targets.empty()) noteOnce("targets", where + ": morph targets ignored (the base shape is rendered)");
  }

  // The primitive's vertex indices in primitive order, before its mode makes triangles: its
  // indices accessor, each checked against `count` positions, or else 0 to count - 1.
  std::vector<uint32_t> primitiveVertices(const tinygltf::Primitive& prim, size_t count, const std::string& where) {
    std::vector<uint32_t> vertices;  // in primitive order, before the mode makes triangles
    if (prim.indices != -1) {
      const AccessorData a = accessor(prim.indices, Semantic::kIndices, "indices", where);
      vertices.resize(a.count);
      for (size_t k = 0; k < a.count; ++k) {
        const double i = a.get(k, 0);
        if (i >= double(count))
          fail(where, "indices (accessor " + std::to_string(prim.indices) + "): index " + num(i) + " at position " +
                          std::to_string(k) + " is out of range (POSITION has " + plural(count, "vertex") + ")");
        vertices[k] = uint32_t(i);
      }
    } else {
      vertices.resize(count);
      for (size_t k = 0; k < count; ++k) vertices[k] = uint32_t(k);
    }
    return vertices;
  }

  // glTF 2.0 §3.7.2.1: TRIANGLES (4) as they are; TRIANGLE_STRIP (5) {v_i, v_(i+1+i%2),
  // v_(i+2-i%2)}; TRIANGLE_FAN (6) {v_(i+1), v_(i+2), v_0}.
  void triangles(int mode, std::vector<uint32_t> v, std::vector<uint32_t>& out, const std::string& where) {
    const size_t n = v.size();
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      if (n % 3 != 0)
        model_.notes.push_back(where + ": " + plural(n % 3, "vertex") + " after the last whole triangle ignored");
      v.resize(n - n % 3);
      out = std::move(v);
      return;
    }
    for (size_t i = 0; i + 2 < n; ++i) {
      if (mode == TINYGLTF_MODE_TRIANGLE_STRIP)
        out.insert(out.end(), {v[i], v[i + 1 + i % 2], v[i + 2 - i % 2]});
      else
        out.insert(out.end(), {v[i + 1], v[i + 2], v[0]});
    }
  }

  // Mesh m with all its primitives, read once whatever the number of nodes using it. Each part's
  // arrays are moved into the mesh (the first part's) or appended to it, then freed: a big mesh
  // is never held twice. Once every mesh the scene uses is read, the buffers are released.
  LocalMesh& localMesh(size_t m) {
    if (meshes_[m]) return *meshes_[m];
    const tinygltf::Mesh& mesh = gltf_.meshes[m];
    std::vector<PrimitiveData> parts;
    for (size_t p = 0; p < mesh.primitives.size(); ++p)
      if (auto d = primitive(m, p)) parts.push_back(std::move(*d));
    bool anyNormals = false, anyUv[2] = {false, false}, anyTangents = false, allTangents = !parts.empty();
    for (const PrimitiveData& d : parts) {
      anyNormals |= !d.normals.empty();
      for (int set = 0; set < 2; ++set) anyUv[set] |= !d.uv[set].empty();
      anyTangents |= !d.tangents.empty();
      allTangents &= !d.tangents.empty();
    }
    auto out = std::make_unique<LocalMesh>();
    out->name = mesh.name.empty() ? indexed("meshes", m) : mesh.name;
    if (anyTangents && !allTangents)
      model_.notes.push_back(labelled("meshes", m, mesh.name) +
                             ": TANGENT missing on some primitives: tangents derived from texture coordinates");
    for (PrimitiveData& d : parts) {
      if (anyNormals && d.normals.empty()) flatShade(d);
      const size_t base = out->positions.size();
      if (base + d.positions.size() > std::numeric_limits<uint32_t>::max())
        fail(indexed("meshes", m), "more than 2^32 - 1 vertices");
      const size_t vertices = d.positions.size();
      appendAndFree(out->positions, d.positions);
      appendAndFree(out->normals, d.normals);
      if (allTangents) appendAndFree(out->tangents, d.tangents);
      for (int set = 0; set < 2; ++set) {
        if (!anyUv[set]) continue;
        if (d.uv[set].empty()) d.uv[set].assign(vertices, Vec2(0.0f));
        appendAndFree(out->uv[set], d.uv[set]);
      }
      out->materialIds.insert(out->materialIds.end(), d.indices.size() / 3, d.material);
      for (uint32_t& i : d.indices) i += uint32_t(base);
      appendAndFree(out->indices, d.indices);
    }
    meshes_[m] = std::move(out);
    if (meshesToRead_ > 0 && --meshesToRead_ == 0)
      for (tinygltf::Buffer& buffer : gltf_.buffers) std::vector<unsigned char>().swap(buffer.data);
    return *meshes_[m];
  }

  // One use of mesh m by node n: its vertices in world space. The mesh's last use takes its
  // arrays rather than copying them.
  void placeMesh(size_t n, size_t m, const glm::dmat4& world) {
    LocalMesh& local = localMesh(m);
    ++meshUses_[m];
    if (totalUses_[m] > 1) return instanceMesh(n, m, world, local);
    const bool last = --usesLeft_[m] == 0;
    const auto take = [last](auto& from) {
      std::remove_reference_t<decltype(from)> out;
      if (last)
        out.swap(from);
      else
        out = from;
      return out;
    };
    if (local.indices.empty()) return;
    const tinygltf::Node& node = gltf_.nodes[n];
    MeshInput in;
    TriangleMesh& mesh = in.mesh;
    mesh.name = node.name.empty() ? local.name : node.name;
    const glm::dmat3 linear(world);
    const double det = glm::determinant(linear);
    const glm::dmat3 normals = cofactorMatrix(linear) * (det < 0.0 ? -1.0 : 1.0);
    in.positions = take(local.positions);
    for (DVec3& p : in.positions) {
      const DVec3 q = DVec3(world * glm::dvec4(p, 1.0));
      if (!isFinite(q))
        fail(indexed("nodes", n),
             "its world transform takes a vertex of " + indexed("meshes", m) + " to a non-finite position");
      p = q;
      model_.lo = glm::min(model_.lo, q);
      model_.hi = glm::max(model_.hi, q);
    }
    mesh.normals.reserve(local.normals.size());
    for (const DVec3& v : local.normals) mesh.normals.push_back(Vec3(normalizedOrZero(normals * v)));
    mesh.tangents.reserve(local.tangents.size());
    for (const glm::dvec4& t : local.tangents)
      mesh.tangents.push_back(glm::vec4(Vec3(normalizedOrZero(linear * DVec3(t))), float(det < 0.0 ? -t.w : t.w)));
    if (last) std::vector<DVec3>().swap(local.normals), std::vector<glm::dvec4>().swap(local.tangents);
    for (int set = 0; set < 2; ++set) mesh.uv[set] = take(local.uv[set]);
    mesh.indices = take(local.indices);
    // A mirroring transform turns faces inside out: swap the winding to keep their facing.
    if (det < 0.0)
      for (size_t k = 0; k < mesh.indices.size(); k += 3) std::swap(mesh.indices[k + 1], mesh.indices[k + 2]);
    mesh.materialIds = take(local.materialIds);
    model_.meshes.push_back(std::move(in));
  }

  // One use of mesh m, which several nodes use, by node n: an instance of the mesh, which is
  // stored once in its own space (ImportedModel::prototypes). A node whose transform collapses
  // a dimension (a zero scale, as animations use to hide a part) draws nothing.
  void instanceMesh(size_t n, size_t m, const glm::dmat4& world, LocalMesh& local) {
    if (prototypeOf_[m] == UINT32_MAX && local.indices.empty()) return;  // a mesh without triangles
    const tinygltf::Node& node = gltf_.nodes[n];
    const double det = glm::determinant(glm::dmat3(world));
    if (!std::isfinite(det)) fail(indexed("nodes", n), "its world transform is not finite");
    if (det == 0.0) {
      noteOnce(
          "collapsed" + std::to_string(n),
          labelled("nodes", n, node.name) + ": its world transform has a zero scale: the mesh it places is not drawn");
      return;
    }
    if (prototypeOf_[m] == UINT32_MAX) {
      prototypeOf_[m] = uint32_t(model_.prototypes.size());
      MeshInput in;
      TriangleMesh& mesh = in.mesh;
      mesh.name = local.name;
      in.positions = std::move(local.positions);
      for (const DVec3& v : local.normals) mesh.normals.push_back(Vec3(v));
      for (const glm::dvec4& t : local.tangents) mesh.tangents.push_back(glm::vec4(t));
      for (int set = 0; set < 2; ++set) mesh.uv[set] = std::move(local.uv[set]);
      mesh.indices = std::move(local.indices);
      mesh.materialIds = std::move(local.materialIds);
      local = LocalMesh{};  // (its arrays are the prototype's now)
      prototypeBoxes_.push_back(boundsOf(in.positions));
      model_.prototypes.push_back(std::move(in));
    }
    const uint32_t prototype = prototypeOf_[m];
    // The model's bounds: the box of the prototype's box transformed (a framing camera needs no
    // tighter one, and the vertices are not visited once per use).
    const auto& [lo, hi] = prototypeBoxes_[prototype];
    for (int c = 0; c < 8; ++c) {
      const DVec3 q = DVec3(world * glm::dvec4(boxCorner(lo, hi, c), 1.0));
      if (!isFinite(q))
        fail(indexed("nodes", n),
             "its world transform takes a vertex of " + indexed("meshes", m) + " to a non-finite position");
      model_.lo = glm::min(model_.lo, q);
      model_.hi = glm::max(model_.hi, q);
    }
    model_.instances.push_back(
        ModelInstance{prototype, world, node.name.empty() ? model_.prototypes[prototype].mesh.name : node.name});
  }

  // ---------------------------------------------------------------------------------------------
  // Scenes and nodes.

  glm::dmat4 localTransform(size_t n) const {
    const tinygltf::Node& node = gltf_.nodes[n];
    const std::string where = indexed("nodes", n);
    const auto finite = [&](const std::vector<double>& values, size_t size, const char* field) {
      if (!values.empty() && values.size() != size)
        fail(where + "." + field, "must have " + plural(size, "number") + ", has " + std::to_string(values.size()));
      for (double v : values)
        if (!std::isfinite(v)) fail(where + "." + field, "must be finite numbers");
    };
    finite(node.matrix, 16, "matrix");
    if (!node.matrix.empty()) return glm::make_mat4(node.matrix.data());  // both column-major
    finite(node.translation, 3, "translation");
    finite(node.rotation, 4, "rotation");
    finite(node.scale, 3, "scale");
    glm::dmat4 m(1.0);
    if (!node.translation.empty()) m[3] = glm::dvec4(glm::make_vec3(node.translation.data()), 1.0);
    if (!node.rotation.empty()) {
      const auto& r = node.rotation;  // [x, y, z, w]
      const glm::dquat q(r[3], r[0], r[1], r[2]);
      const double length = glm::length(q);
      if (!(length > 0.0) || !std::isfinite(length))
        fail(where + ".rotation", "must be a unit quaternion [x, y, z, w], got [0, 0, 0, 0]");
      m = m * glm::mat4_cast(q / length);
    }
    if (!node.scale.empty())
      for (int c = 0; c < 3; ++c) m[c] *= node.scale[size_t(c)];
    return m;
  }

  void traverse() {
    const size_t count = gltf_.nodes.size();
    std::vector<int64_t> parent(count, -1);
    for (size_t n = 0; n < count; ++n)
      for (int c : gltf_.nodes[n].children) {
        checkIndex(c, count, indexed("nodes", n) + ".children", "node");
        if (parent[size_t(c)] >= 0)
          fail(indexed("nodes", size_t(c)), "is a child of both nodes[" + std::to_string(parent[size_t(c)]) +
                                                "] and nodes[" + std::to_string(n) +
                                                "]: a node has at most one parent");
        parent[size_t(c)] = int64_t(n);
      }
    std::vector<size_t> roots;
    if (!gltf_.scenes.empty()) {
      int scene = gltf_.defaultScene;
      if (scene != -1) checkIndex(scene, gltf_.scenes.size(), "scene", "scene");
      scene = std::max(scene, 0);
      const tinygltf::Scene& s = gltf_.scenes[size_t(scene)];
      if (gltf_.scenes.size() > 1)
        model_.notes.push_back("scenes: the model has " + std::to_string(gltf_.scenes.size()) + " scenes; " +
                               labelled("scenes", size_t(scene), s.name) + " is rendered");
      const std::string where = indexed("scenes", size_t(scene)) + ".nodes";
      std::vector<bool> listed(count, false);
      for (int r : s.nodes) {
        checkIndex(r, count, where, "node");
        if (parent[size_t(r)] >= 0)
          fail(where, "node " + std::to_string(r) + " is a child of nodes[" + std::to_string(parent[size_t(r)]) +
                          "], not a root node");
        if (listed[size_t(r)]) fail(where, "lists node " + std::to_string(r) + " twice");
        listed[size_t(r)] = true;
        roots.push_back(size_t(r));
      }
    } else {
      if (gltf_.defaultScene != -1) checkIndex(gltf_.defaultScene, 0, "scene", "scene");
      for (size_t n = 0; n < count; ++n)
        if (parent[n] < 0) roots.push_back(n);
    }
    // How many nodes use each mesh, so that its last use can take its arrays (placeMesh) and
    // the buffers can go once every mesh used is read (localMesh).
    usesLeft_.assign(gltf_.meshes.size(), 0);
    for (std::vector<size_t> pending(roots.rbegin(), roots.rend()); !pending.empty();) {
      const tinygltf::Node& node = gltf_.nodes[pending.back()];
      pending.pop_back();
      if (node.mesh >= 0 && size_t(node.mesh) < gltf_.meshes.size() && usesLeft_[size_t(node.mesh)]++ == 0)
        ++meshesToRead_;
      for (int c : node.children) pending.push_back(size_t(c));
    }
    totalUses_ = usesLeft_;
    prototypeOf_.assign(gltf_.meshes.size(), UINT32_MAX);
    // Depth first, children in order, without recursion (a chain of nodes may be long). Every
    // node has at most one parent and roots have none, so no node is reached twice.
    std::vector<std::pair<size_t, glm::dmat4>> stack;
    for (auto r = roots.rbegin(); r != roots.rend(); ++r) stack.emplace_back(*r, glm::dmat4(1.0));
    while (!stack.empty()) {
      const auto [n, parentWorld] = stack.back();
      stack.pop_back();
      const glm::dmat4 world = parentWorld * localTransform(n);
      visit(n, world);
      const std::vector<int>& children = gltf_.nodes[n].children;
      for (auto c = children.rbegin(); c != children.rend(); ++c) stack.emplace_back(size_t(*c), world);
    }
  }

  void visit(size_t n, const glm::dmat4& world) {
    const tinygltf::Node& node = gltf_.nodes[n];
    const std::string where = indexed("nodes", n);
    if (node.mesh != -1) {
      checkIndex(node.mesh, gltf_.meshes.size(), where + ".mesh", "mesh");
      placeMesh(n, size_t(node.mesh), world);
    }
    if (node.skin != -1)
      noteOnce("skin", labelled("nodes", n, node.name) + ": skin ignored: the mesh is rendered unskinned, as stored");
    if (node.camera != -1) {
      checkIndex(node.camera, gltf_.cameras.size(), where + ".camera", "camera");
      cameras_.push_back(Placed{n, size_t(node.camera), world});
    }
    if (const tinygltf::Value* e = extension(node.extensions, "KHR_lights_punctual")) {
      const std::string field = where + ".extensions.KHR_lights_punctual.light";
      if (!e->Get("light").IsInt()) fail(field, "must be an integer");
      checkIndex(e->Get("light").GetNumberAsInt(), gltf_.lights.size(), field, "light");
      lights_.push_back(Placed{n, size_t(e->Get("light").GetNumberAsInt()), world});
    }
  }

  // A node's -Z (where cameras look and lights shine) and +Y in world space, unit length.
  std::pair<DVec3, DVec3> axes(const Placed& p, const std::string& what) const {
    const glm::dmat3 linear(p.world);
    const DVec3 forward = normalizedOrZero(linear * DVec3(0.0, 0.0, -1.0)),
                up = normalizedOrZero(linear * DVec3(0.0, 1.0, 0.0));
    if (forward == DVec3(0.0) || up == DVec3(0.0))
      fail(indexed("nodes", p.node), "its world transform collapses the " + what + "'s direction (a zero scale)");
    return {forward, up};
  }

  void camera(const Placed& p) {
    const tinygltf::Camera& c = gltf_.cameras[p.index];
    const std::string where = indexed("cameras", p.index), label = labelled("cameras", p.index, c.name);
    const DVec3 position(p.world[3]);
    const auto [forward, up] = axes(p, "camera");
    // look_at only gives the direction (and a thin lens's default focus): the model's centre's
    // distance, at least 1.
    double distance = 1.0;
    if (!model_.meshes.empty()) {
      const double d = glm::length((model_.lo + model_.hi) * 0.5 - position);
      if (std::isfinite(d)) distance = std::max(d, 1.0);
    }
    const std::string& nodeName = gltf_.nodes[p.node].name;
    json j = {{"name", !c.name.empty()     ? c.name
                       : !nodeName.empty() ? nodeName
                                           : where},
              {"position", array3(position)},
              {"look_at", array3(position + forward * distance)},
              {"up", array3(up)}};
    if (c.type == "perspective") {
      j["type"] = "pinhole";
      const double yfov = c.perspective.yfov;
      if (!(yfov > 0.0 && yfov < glm::pi<double>()))
        fail(where + ".perspective.yfov", "must be in (0, pi) radians, got " + num(yfov));
      const double aspect = c.perspective.aspectRatio;
      if (aspect < 0.0 || !std::isfinite(aspect))
        fail(where + ".perspective.aspectRatio", "must be > 0, got " + num(aspect));
      // yfov is the vertical field of view whatever the output's aspect ratio (glTF 2.0, 3.10.2;
      // Blender's importer reads it so too); aspectRatio only says what the author framed for,
      // which the scene loader compares with the resolution (a note when they differ).
      j["angle_of_view"] = glm::degrees(yfov);
      j["fov_axis"] = "vertical";
      if (aspect > 0.0) j["aspect_ratio"] = aspect;
    } else {
      // lensfarm has no orthographic camera: the scene loader refuses this one by its type if chosen.
      j["type"] = "orthographic";
      j["xmag"] = c.orthographic.xmag;
      j["ymag"] = c.orthographic.ymag;
      model_.notes.push_back(label + ": orthographic: not supported (refused if chosen as the camera)");
    }
    model_.cameras.push_back(std::move(j));
  }

  void light(const Placed& p) {
    const tinygltf::Light& l = gltf_.lights[p.index];
    const std::string where = "extensions.KHR_lights_punctual." + indexed("lights", p.index);
    const std::string label = "KHR_lights_punctual." + labelled("lights", p.index, l.name);
    DVec3 color(1.0);
    if (!l.color.empty()) {
      if (l.color.size() != 3) fail(where + ".color", "must be 3 numbers");
      for (int c = 0; c < 3; ++c) color[c] = inRange(l.color[size_t(c)], 0.0, 1e30, where + ".color");
    }
    // Candela (point, spot) and lux (directional) to W/sr and W/m^2 (light/light_source.h).
    const DVec3 power = color * (inRange(l.intensity, 0.0, 1e30, where + ".intensity") / kLumensPerWatt);
    noteOnce("photometric", "KHR_lights_punctual: intensities in candela and lux converted to W/sr and W/m^2 at " +
                                num(kLumensPerWatt) + " lm/W (as Blender's glTF exporter writes them)");
    if (l.range > 0.0) noteOnce("range", label + ": range ignored (inverse-square fall-off without a cut-off)");
    const DVec3 position(p.world[3]);
    const std::string& nodeName = gltf_.nodes[p.node].name;
    json j = {{"name", !l.name.empty()     ? l.name
                       : !nodeName.empty() ? nodeName
                                           : "KHR_lights_punctual." + indexed("lights", p.index)}};
    if (l.type == "point") {
      j["type"] = "point";
      j["position"] = array3(position);
      j["intensity"] = array3(power);
    } else if (l.type == "spot") {
      const double outer = l.spot.outerConeAngle, inner = l.spot.innerConeAngle;
      if (!(outer > 0.0 && outer <= glm::half_pi<double>()))
        fail(where + ".spot.outerConeAngle", "must be in (0, pi/2] radians, got " + num(outer));
      if (!(inner >= 0.0 && inner <= outer))
        fail(where + ".spot.innerConeAngle", "must be in [0, outerConeAngle] radians, got " + num(inner));
      const double cone = std::min(glm::degrees(outer), 90.0);
      j["type"] = "spot";
      j["position"] = array3(position);
      j["look_at"] = array3(position + axes(p, "light").first);
      j["intensity"] = array3(power);
      j["cone_angle"] = cone;
      j["falloff_start"] = std::min(glm::degrees(inner), cone);
    } else if (l.type == "directional") {
      j["type"] = "directional";
      j["direction"] = array3(-axes(p, "light").first);  // lensfarm's points towards the light
      j["irradiance"] = array3(power);
    } else {
      fail(where + ".type", "\"" + l.type + "\" is not point, spot or directional");
    }
    model_.lights.push_back(std::move(j));
  }

  void finalNotes() {
    if (!occluded_.empty())
      model_.notes.push_back(occluded_.front() +
                             (occluded_.size() > 1 ? " and " + plural(occluded_.size() - 1, "other material") : "") +
                             ": occlusionTexture ignored (the path tracer computes occlusion)");
    for (size_t m = 0; m < meshUses_.size(); ++m)
      if (meshUses_[m] > 1)
        model_.notes.push_back(labelled("meshes", m, gltf_.meshes[m].name) + ": used by " +
                               std::to_string(meshUses_[m]) + " nodes: stored once and instanced");
    if (!gltf_.animations.empty())
      model_.notes.push_back("animations: " + std::to_string(gltf_.animations.size()) +
                             " ignored (the model is rendered as its nodes place it)");
  }

  std::string bytes_;  // the file, until tinygltf has read it
  const std::string shown_;
  const ModelFileReader& read_;
  bool binary_ = false;
  uint32_t glbLength_ = 0, binLength_ = 0;
  json root_;
  bool quantized_ = false;
  std::map<std::string, std::string> uriPaths_;              // tinygltf's path -> the path read
  std::map<std::string, std::optional<std::string>> files_;  // path -> its bytes, while loading
  std::exception_ptr pending_;                               // thrown by the reader in a callback
  tinygltf::Model gltf_;
  std::map<std::pair<size_t, int>, std::shared_ptr<const RgbaImage>> images_;
  std::map<std::tuple<size_t, int, int, int, int>, std::shared_ptr<const Texture>> textures_;
  std::vector<std::unique_ptr<LocalMesh>> meshes_;
  std::vector<size_t> meshUses_;
  std::vector<size_t> usesLeft_;                         // per mesh: the nodes still to place it
  std::vector<size_t> totalUses_;                        // per mesh: the nodes that place it (more than one: instanced)
  std::vector<uint32_t> prototypeOf_;                    // per mesh: its index in model_.prototypes, if instanced
  std::vector<std::pair<DVec3, DVec3>> prototypeBoxes_;  // per prototype: its box in its own space
  size_t meshesToRead_ = 0;                              // meshes used and not read yet
  std::optional<uint32_t> defaultMaterial_;
  std::vector<Placed> cameras_, lights_;
  std::vector<std::string> occluded_;
  std::set<std::string> noted_;
  ImportedModel model_;
};

}  // namespace

ImportedModel importGltf(std::string bytes, const std::string& shown, const ModelFileReader& read) {
  return GltfImporter(std::move(bytes), shown, read).run();
}

}  // namespace lensfarm
