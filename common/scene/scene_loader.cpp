// The scene loader's entry points (scene_loader.h: parseScene, loadScene, modelScene...) and
// SceneParser's top-level flow (its constructor, parse()); the parser's sections are in the
// parse_*.cpp files beside this one (scene_parser.h lists them).
#include "common/scene/scene_loader.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "common/scene/asset_path.h"
#include "common/scene/coplanar.h"
#include "common/scene/keyframes.h"
#include "common/scene/scene_parser.h"
#include "common/util/error.h"
#include "common/util/field_reader.h"
#include "common/util/file_contents.h"

namespace lensfarm {

namespace fs = std::filesystem;

std::string SceneParser::shortNumber(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

std::string SceneParser::showVec3(const DVec3& v) {
  return "[" + shortNumber(v.x) + ", " + shortNumber(v.y) + ", " + shortNumber(v.z) + "]";
}

SceneParser::SceneParser(json& root, const fs::path& file, AssetReader readAsset, std::optional<double> frame)
    : root_(root), file_(file), fileName_(file.string()), readAsset_(std::move(readAsset)), frame_(frame) {}

Scene SceneParser::parse() {
  FieldReader top(root_, "", fileName_);
  const std::string format = top.string("format");
  if (format != kSceneFormat)
    top.fail("format", "unsupported format \"" + format + "\" (this renderer reads \"" + kSceneFormat + "\")");
  scene_.file = file_;
  hash_.update(root_.dump());  // the file as written: one hash for every frame of an animation
  scene_.frame = frame_.value_or(0.0);
  if (std::optional<Animation> animation = applyKeyframes(root_, frame_, fileName_)) {
    scene_.keyframeRange = animation->range;
    scene_.frame = animation->frame;
  }

  parseRender(top);
  parseMedia(top);
  parseMaterials(top);
  importModels(top);
  parseCamera(top);
  placeMedia(top);
  parseShapes(top);
  parseLights(top);
  addModelLights();
  parseEnvironment(top);
  top.finish();
  bringFlushLightsForward(scene_);  // the coplanar rule (scene/coplanar.h)

  if (shapeTriangles_ == 0 && instancedTriangles_ == 0)
    top.fail("shapes", "the scene has no triangles (lights alone show nothing)");
  size_t stored = shapeTriangles_;
  for (const TriangleMesh& mesh : scene_.prototypes) stored += mesh.triangleCount();
  if (stored > kMaxTriangles)
    top.fail("shapes", std::to_string(stored) + " triangles exceed the limit of " + std::to_string(kMaxTriangles));
  if (scene_.instances.size() > kMaxInstances)
    top.fail("shapes", std::to_string(scene_.instances.size()) + " instances exceed the limit of " +
                           std::to_string(kMaxInstances));
  scene_.hash = hash_.hexDigest();
  scene_.notes = std::move(notes_);
  return std::move(scene_);
}

namespace {
// Finds the field that holds the first non-finite number (e.g. 1e999, which JSON allows but a
// double cannot hold) by replaying the text through nlohmann's SAX interface.
class NonFiniteNumberFinder : public nlohmann::json_sax<json> {
 public:
  std::string path;  // set when found

  bool number_float(number_float_t, const string_t&) override { return advance(); }
  bool null() override { return advance(); }
  bool boolean(bool) override { return advance(); }
  bool number_integer(number_integer_t) override { return advance(); }
  bool number_unsigned(number_unsigned_t) override { return advance(); }
  bool string(string_t&) override { return advance(); }
  bool binary(binary_t&) override { return advance(); }
  bool start_object(std::size_t) override {
    frames_.push_back(Frame{false, 0, ""});
    return true;
  }
  bool key(string_t& k) override {
    frames_.back().key = k;
    return true;
  }
  bool end_object() override { return close(); }
  bool start_array(std::size_t) override {
    frames_.push_back(Frame{true, 0, ""});
    return true;
  }
  bool end_array() override { return close(); }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception& e) override {
    if (e.id == 406) path = currentPath();  // nlohmann reports an overflowing number here
    return false;
  }

 private:
  struct Frame {
    bool array;
    size_t index;
    std::string key;
  };
  bool advance() {
    if (!frames_.empty() && frames_.back().array) ++frames_.back().index;
    return true;
  }
  bool close() {
    frames_.pop_back();
    return advance();
  }
  std::string currentPath() const {
    std::string out;
    for (const Frame& f : frames_) {
      if (f.array)
        out += "[" + std::to_string(f.index) + "]";
      else
        out += (out.empty() ? "" : ".") + f.key;
    }
    return out;
  }
  std::vector<Frame> frames_;
};
}  // namespace

AssetReader fileAssetReader(const fs::path& sceneFile, const std::vector<fs::path>& allowed) {
  const fs::path dir = sceneFile.parent_path();
  return [dir, allowed](const std::string& rel) { return readWholeFile(confinedFile(dir, rel, allowed)); };
}

namespace {
// JSON nesting deeper than any scene needs is refused before parsing (a 10^6-deep array would
// otherwise cost stack in the JSON library's recursive destructor).
constexpr int kMaxNesting = 64;

void checkNesting(const std::string& text, const fs::path& file) {
  int depth = 0, line = 1;
  bool inString = false, escaped = false;
  for (char c : text) {
    if (c == '\n') ++line;
    if (inString) {
      if (escaped)
        escaped = false;
      else if (c == '\\')
        escaped = true;
      else if (c == '"')
        inString = false;
    } else if (c == '"') {
      inString = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxNesting)
        throw InputError(file.string(), "line " + std::to_string(line) + ": nested deeper than " +
                                            std::to_string(kMaxNesting) + " levels");
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
}
}  // namespace

namespace {
// What a binary file given as a scene is, by its magic bytes; nothing for text.
std::optional<std::string> binaryKind(const std::string& text) {
  static const std::pair<std::string, const char*> kMagic[] = {
      {"\x89PNG\r\n\x1a\n", "a PNG image"},
      {"\xff\xd8\xff", "a JPEG image"},
      {"\x76\x2f\x31\x01", "an OpenEXR image"},
      {"glTF", "a binary glTF model (.glb): give it a .glb name"},
      {"%PDF", "a PDF document"},
      {"PK\x03\x04", "a zip archive"},
      {"\x1f\x8b", "a gzip archive"},
      {"\x7f"
       "ELF",
       "a program"},
      {"BM", "a BMP image"},
      {"GIF8", "a GIF image"}};
  for (const auto& [magic, kind] : kMagic)
    if (text.compare(0, magic.size(), magic) == 0) return std::string(kind);
  const size_t head = std::min<size_t>(text.size(), 4096);
  if (text.find('\0') < head) return std::string("a binary file");
  return std::nullopt;
}
}  // namespace

Scene parseScene(const std::string& text, const fs::path& file, const AssetReader& readAsset,
                 std::optional<double> frame) {
  if (const std::optional<std::string> kind = binaryKind(text))
    throw InputError(file.string(), "is " + *kind +
                                        ", not a scene: a scene is a JSON file (docs/scene-format.md), a "
                                        "model a .gltf, .glb or .obj file");
  checkNesting(text, file);
  json root;
  try {
    root = json::parse(text);
  } catch (const json::parse_error& e) {
    // nlohmann's message carries the line and column.
    std::string what = e.what();
    const auto pos = what.find("parse error");
    throw InputError(file.string(), "malformed JSON: " + (pos == std::string::npos ? what : what.substr(pos)));
  } catch (const json::exception& e) {
    // A number too large for a double (406 "number overflow").
    NonFiniteNumberFinder finder;
    json::sax_parse(text, &finder);
    if (!finder.path.empty()) throw InputError(file.string(), finder.path + ": must be a finite number");
    throw InputError(file.string(), std::string("invalid JSON: ") + e.what());
  }
  return SceneParser(root, file, readAsset ? readAsset : fileAssetReader(file), frame).parse();
}

Scene loadScene(const fs::path& file, std::optional<double> frame) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) throw InputError(file.string(), "no such scene file");
  if (isModelFile(file)) {
    std::string text;
    return modelScene(file, text);
  }
  return parseScene(readWholeFileOrThrow(file, file.string()), file, {}, frame);
}

// The registration point of model file formats: each shape type, its extensions and importer
// (scene/parse_models.cpp).
std::string modelShapeTypeOf(const fs::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext == ".gltf" || ext == ".glb") return "gltf";
  if (ext == ".obj") return "obj";
  if (ext == ".usda" || ext == ".usd" || ext == ".usdc" || ext == ".usdz") return "usd";
  return "";
}

bool isModelShapeType(const std::string& type) { return type == "obj" || type == "gltf" || type == "usd"; }

bool isModelFile(const fs::path& file) { return !modelShapeTypeOf(file).empty(); }

std::string withModelCamera(const std::string& text, const fs::path& file, const std::string& camera) {
  json root = json::parse(text, nullptr, false);
  if (!root.is_object()) throw InputError(file.string(), "is not a JSON object (the scene format)");
  root["camera"] = camera;
  return root.dump(2);
}

Scene modelScene(const fs::path& modelFile, std::string& text, const AssetReader& readAsset,
                 const std::optional<std::string>& camera) {
  std::string ext = modelFile.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  json scene = {{"format", kSceneFormat},
                {"render", {{"resolution", {1280, 720}}, {"samples_per_pixel", 64}, {"max_bounces", 4}}},
                {"shapes", {{{"type", modelShapeTypeOf(modelFile)}, {"file", modelFile.filename().string()}}}}};
  if (camera) scene["camera"] = *camera;
  if (ext == ".obj") {
    // Faces without a usemtl material (or whose .mtl is missing) are a light grey diffuse.
    scene["materials"] = {{"default grey", {{"type", "lambertian"}, {"albedo", 0.7}}}};
    scene["shapes"][0]["fallback_material"] = "default grey";
  }
  // The scene file the model's JSON stands for sits beside the model, so its assets resolve there;
  // its errors name the model, the file the user gave (the scene's own fields, "shapes[0]", are
  // left out: the user never wrote them).
  const fs::path asFile = modelFile.parent_path() / (modelFile.filename().string() + ".scene.json");
  const auto parse = [&]() {
    try {
      return parseScene(text, asFile, readAsset);
    } catch (const InputError& e) {
      std::string what = e.what();
      const std::string written = asFile.string() + ": ";
      if (what.rfind(written, 0) != 0) throw;
      what.erase(0, written.size());
      for (const std::string field : {"shapes[0] ", "shapes[0].", "shapes[0]: "})
        if (what.rfind(field, 0) == 0) what.erase(0, field.size());
      throw InputError(modelFile.string(), what);
    }
  };
  text = scene.dump(2);
  Scene s = parse();
  bool lit = !s.lights.empty();
  for (const Material& m : s.materials) lit |= m.isEmissive();
  if (lit) return s;
  // A studio look that shows the shape: a key light from 45 degrees above and to the left of the
  // camera (irradiance 3: a white surface facing it has radiance 3 / pi ~ 1), so the faces turned
  // up, left and right differ, and a dim uniform fill (radiance 0.15), which is also the
  // background; key to fill about 6:1.
  const ThinLensCamera view = s.camera();
  const Vec3 towardKey = glm::normalize(-1.0f * view.right() + 1.0f * view.up() - 1.4f * view.forward());
  scene["environment"] = {{"radiance", {0.15, 0.15, 0.15}}};
  scene["lights"] = {{{"type", "directional"},
                      {"name", "studio key"},
                      {"direction", {towardKey.x, towardKey.y, towardKey.z}},
                      {"irradiance", {3.0, 3.0, 3.0}}}};
  text = scene.dump(2);
  s = parse();
  s.notes.push_back(
      "lights: the model has none; lit as in a studio: a directional key light from 45 degrees above "
      "the camera's left (irradiance 3) and a uniform grey environment (radiance 0.15) as fill and background");
  return s;
}

}  // namespace lensfarm
