#include "common/scene/obj_import.h"

#include <sys/mman.h>
#include <tiny_obj_loader.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <string_view>
#include <type_traits>

#include "common/scene/obj_check.h"
#include "common/texture/image_decode.h"
#include "common/util/error.h"

namespace lensfarm {

namespace {

namespace fs = std::filesystem;

static_assert(std::is_same_v<tinyobj::real_t, double>, "link tinyobjloader_double");

std::string quote(const std::string& s) { return "\"" + s + "\""; }

std::string shortNumber(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", x);
  return text;
}

// `rel` (relative to a file in directory `dir`, itself relative to the OBJ file) as the reader
// takes it, relative to the OBJ file.
std::string joined(const std::string& dir, const std::string& rel) {
  return dir.empty() ? rel : (fs::path(dir) / rel).generic_string();
}

std::string directoryOf(const std::string& path) { return fs::path(path).parent_path().generic_string(); }

// Calls f(lineNumber, keyword, rest, statement) for each statement of `text` (lines numbered from
// 1; blanks around the statement removed, as tinyobjloader does).
template <typename F>
void forEachStatement(std::string_view text, F&& f) {
  size_t line = 0, pos = 0;
  while (pos < text.size()) {
    // (A plain loop: string_view::find_first_of calls memchr on the set for every character.)
    size_t end = pos;
    while (end < text.size() && text[end] != '\n' && text[end] != '\r') ++end;
    std::string_view s = text.substr(pos, end - pos);
    pos = end + ((end + 1 < text.size() && text[end] == '\r' && text[end + 1] == '\n') ? 2 : 1);
    ++line;
    const size_t lead = s.find_first_not_of(" \t");
    if (lead == std::string_view::npos || s[lead] == '#') continue;
    s.remove_prefix(lead);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
    const size_t keywordEnd = std::min(s.find_first_of(" \t"), s.size());
    std::string_view rest = s.substr(keywordEnd);
    rest.remove_prefix(std::min(rest.find_first_not_of(" \t"), rest.size()));
    f(line, s.substr(0, keywordEnd), rest, s);
  }
}

// ---------------------------------------------------------------------------------------------
// The OBJ text, before tinyobjloader: what checkObjText leaves to us.

struct ObjScan {
  struct Library {
    std::string name;
    size_t line;
  };
  std::vector<Library> libraries;          // mtllib files in order of first mention
  std::vector<std::string> materialNames;  // usemtl names, in order of first use
  bool faceTexcoords = false, faceNormals = false;
};

// The texture coordinate and normal references of faces (checkObjText checks the vertex ones):
// each must name a vt / vn defined before it, as tinyobjloader resolves them. Also collects the
// mtllib and usemtl names.
ObjScan scanObj(const std::string& text, const std::string& shown) {
  ObjScan scan;
  size_t texcoords = 0, normals = 0;
  std::set<std::string> libraries, materials;
  forEachStatement(text, [&](size_t line, std::string_view keyword, std::string_view rest, std::string_view) {
    if (keyword == "vt") {
      ++texcoords;
    } else if (keyword == "vn") {
      ++normals;
    } else if (keyword == "mtllib") {
      // As tinyobjloader splits it: at spaces, a backslash escaping the next character.
      std::string name;
      auto add = [&]() {
        if (!name.empty() && libraries.insert(name).second) scan.libraries.push_back({name, line});
        name.clear();
      };
      for (size_t k = 0; k < rest.size(); ++k) {
        if (rest[k] == '\\' && k + 1 < rest.size())
          name += rest[++k];
        else if (rest[k] == ' ')
          add();
        else
          name += rest[k];
      }
      add();
    } else if (keyword == "usemtl") {
      // tinyobjloader's name: the first word.
      const std::string name(rest.substr(0, std::min(rest.find_first_of(" \t"), rest.size())));
      if (materials.insert(name).second) scan.materialNames.push_back(name);
    } else if (keyword == "f") {
      size_t k = 0;
      while (k < rest.size()) {
        size_t end = k;
        while (end < rest.size() && rest[end] != ' ' && rest[end] != '\t') ++end;
        const std::string_view ref = rest.substr(k, end - k);
        k = end;
        while (k < rest.size() && (rest[k] == ' ' || rest[k] == '\t')) ++k;
        const size_t slash1 = ref.find('/');
        if (slash1 == std::string_view::npos) continue;
        const size_t slash2 = ref.find('/', slash1 + 1);
        const std::string_view parts[2] = {
            ref.substr(slash1 + 1, slash2 == std::string_view::npos ? std::string_view::npos : slash2 - slash1 - 1),
            slash2 == std::string_view::npos ? std::string_view() : ref.substr(slash2 + 1)};
        for (int p = 0; p < 2; ++p) {
          std::string_view digits = parts[p];
          if (digits.empty()) continue;
          if (digits[0] == '+') digits.remove_prefix(1);
          int64_t index = 0;
          std::from_chars(digits.data(), digits.data() + digits.size(), index);
          const size_t defined = p == 0 ? texcoords : normals;
          (p == 0 ? scan.faceTexcoords : scan.faceNormals) = true;
          if (index != 0 && (index > 0 ? uint64_t(index) : uint64_t(-index)) <= defined) continue;
          const std::string what = p == 0 ? "texture coordinate" : "normal";
          throw InputError(shown, "line " + std::to_string(line) + ": face refers to " + what + " " +
                                      std::to_string(index) + ", but " +
                                      (defined == 0   ? "no " + what + " is"
                                       : defined == 1 ? "only 1 " + what + " is"
                                                      : "only " + std::to_string(defined) + " " + what + "s are") +
                                      " defined before it");
        }
      }
    }
  });
  return scan;
}

// ---------------------------------------------------------------------------------------------
// MTL libraries.

struct MtlLibrary {
  std::string name;   // as the mtllib statement names it, for notes
  std::string shown;  // for messages
  std::string dir;    // its directory relative to the OBJ file, for the reader
  // Per material: the line of each statement (its first), so that values can be told from
  // tinyobjloader's defaults and messages can name lines.
  std::map<std::string, std::map<std::string, size_t>> statements;
};

// Hands tinyobjloader the materials read beforehand. All the libraries are read before parsing
// the OBJ (importObj): a missing one is one error naming its mtllib line, and every file of an
// `mtllib a.mtl b.mtl` statement is read (tinyobjloader stops at the first it can open).
class PreloadedMaterials final : public tinyobj::MaterialReader {
 public:
  PreloadedMaterials(const std::vector<tinyobj::material_t>& materials, const std::map<std::string, int>& index)
      : materials_(materials), index_(index) {}
  bool operator()(const std::string& /*matId*/, std::vector<tinyobj::material_t>* materials,
                  std::map<std::string, int>* index, std::string* /*warn*/, std::string* /*err*/) override {
    if (!given_) {
      *materials = materials_;
      *index = index_;
      given_ = true;
    }
    return true;
  }

 private:
  const std::vector<tinyobj::material_t>& materials_;
  const std::map<std::string, int>& index_;
  bool given_ = false;
};

void checkMtlText(const std::string& bytes, const std::string& shown) {
  for (size_t k = 0; k < bytes.size(); ++k) {
    const unsigned char c = static_cast<unsigned char>(bytes[k]);
    if ((c < 0x20 && c != '\t' && c != '\n' && c != '\r' && c != '\v' && c != '\f') || c == 0x7F)
      throw InputError(shown, "binary data (byte " + std::to_string(unsigned(c)) + " at offset " + std::to_string(k) +
                                  "), not an MTL text file");
  }
}

// ---------------------------------------------------------------------------------------------
// MTL materials onto MaterialTextures (docs/scene-format.md, "OBJ and MTL").

// The roughness (glTF's perceptual roughness, alpha = roughness^2) of a Blinn-Phong exponent:
// Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces", section 5.2,
// relate the Phong exponent to the Beckmann width by Ns = 2 / alpha^2 - 2, so
// alpha = sqrt(2 / (Ns + 2)); the same alpha is used for GGX.
float roughnessOfExponent(double ns) { return float(std::pow(2.0 / (std::max(ns, 0.0) + 2.0), 0.25)); }

class MaterialBuilder {
 public:
  // `objDir`: the OBJ file's directory as messages show it.
  MaterialBuilder(const ModelFileReader& read, std::string objDir, std::vector<std::string>& notes)
      : read_(read), objDir_(std::move(objDir)), notes_(notes) {}

  Material build(const tinyobj::material_t& m, const MtlLibrary& lib) {
    lib_ = &lib;
    const auto found = lib.statements.find(m.name);
    static const std::map<std::string, size_t> kNone;
    lines_ = found == lib.statements.end() ? &kNone : &found->second;
    where_ = "material " + quote(m.name);

    auto t = std::make_shared<MaterialTextures>();
    PrincipledParams& p = t->factors;
    const Spectrum kd = color("Kd", m.diffuse), ks = color("Ks", m.specular), ke = color("Ke", m.emission);
    const Spectrum tf = color(has("Tf") ? "Tf" : "Kt", m.transmittance);
    const std::string dKey = has("d") ? "d" : "Tr";
    const float ns = number("Ns", m.shininess), ni = number("Ni", m.ior), d = number(dKey, m.dissolve);
    const int illum = has("illum") ? m.illum : 2;  // tinyobjloader's default is 0
    const bool glass = illum == 4 || illum == 6 || illum == 7 || illum == 9;
    const bool mirror = illum == 3 || illum == 5 || illum == 8;
    const bool hasKdMap = !m.diffuse_texname.empty();

    // Base colour: Kd (map_Kd multiplies it; without Kd the map alone, not tinyobjloader's 0.6).
    Spectrum base = has("Kd") ? kd : Spectrum(hasKdMap ? 1.0f : 0.8f);
    // Glass: the transmission filter colour if there is one (exporters write Tf 0 0 0 for none).
    if (glass) base = !isBlack(tf) ? tf : isBlack(base) ? Spectrum(1.0f) : base;
    if (mirror && isBlack(base) && !hasKdMap) base = ks;  // "Kd 0 0 0, Ks 1 1 1, illum 3": a mirror
    if (glm::any(glm::greaterThan(base, Spectrum(1.0f)))) {
      note("base colour " + shortNumber(base.r) + " " + shortNumber(base.g) + " " + shortNumber(base.b) +
           " clamped to 1 (a surface reflects at most what it receives)");
      base = glm::min(base, Spectrum(1.0f));
    }
    p.baseColor = base;
    p.metallic = mirror ? 1.0f : 0.0f;
    if (has("Pm")) p.metallic = std::clamp(number("Pm", m.metallic), 0.0f, 1.0f);
    p.roughness = has("Pr") ? std::clamp(number("Pr", m.roughness), 0.0f, 1.0f) : roughnessOfExponent(ns);
    p.transmission = glass ? 1.0f : 0.0f;
    // Ni is the optical density for refraction; in MTL, reflection strength comes from Ks. A
    // non-refracting material's Ni of 1 (or none) would remove its specular layer: 1.5 instead.
    if (glass) {
      p.ior = has("Ni") ? std::clamp(ni, 1.0f, 10.0f) : 1.5f;
      if (has("Ni") && p.ior != ni) note("Ni " + shortNumber(ni) + " clamped to " + shortNumber(p.ior));
    } else {
      p.ior = has("Ni") && ni > 1.0f ? std::min(ni, 10.0f) : 1.5f;
    }
    p.specular = glass || mirror            ? 1.0f
                 : illum == 0 || illum == 1 ? 0.0f
                                            : std::clamp(std::max({ks.r, ks.g, ks.b}), 0.0f, 1.0f);

    // Textures.
    const TextureRef kdMap = texture("map_Kd", m.diffuse_texname, m.diffuse_texopt, ColorEncoding::kSrgb);
    t->baseColor = kdMap;
    dissolve(m, glass, illum, d, dKey, kdMap, *t);
    if (!m.roughness_texname.empty() || !m.metallic_texname.empty()) {
      const TextureRef pr = texture("map_Pr", m.roughness_texname, m.roughness_texopt, ColorEncoding::kLinear);
      const TextureRef pm = texture("map_Pm", m.metallic_texname, m.metallic_texopt, ColorEncoding::kLinear);
      // glTF's layout: G roughness, B metallic; each map alone multiplies its factor, 1 if unset.
      if (pr && !has("Pr")) p.roughness = 1.0f;
      if (pm && !has("Pm")) p.metallic = 1.0f;
      t->metallicRoughness =
          combine(TextureRef{}, {pr, channelOf(m.roughness_texopt, pr)}, 1, "map_Pr+map_Pm",
                  wrapOf(pr ? m.roughness_texopt : m.metallic_texopt), {pm, channelOf(m.metallic_texopt, pm)}, 2);
    }
    normalMap(m, *t);
    if (!m.emissive_texname.empty()) {
      t->emissive = texture("map_Ke", m.emissive_texname, m.emissive_texopt, ColorEncoding::kSrgb);
    }
    const Spectrum emission = has("Ke") ? ke : Spectrum(t->emissive ? 1.0f : 0.0f);
    noteIgnoredMaps(m);
    if (illum > 10 || illum < 0) note("illum " + std::to_string(illum) + " unknown: rendered as illum 2");
    return Material::textured(m.name, std::move(t), emission);
  }

 private:
  // Dissolve (`d`, from statement `dKey`, and map_d) as a cut-out in `t`'s alpha; noted as
  // ignored on glass.
  void dissolve(const tinyobj::material_t& m, bool glass, int illum, float d, const std::string& dKey,
                const TextureRef& kdMap, MaterialTextures& t) {
    const bool hasAlphaMap = !m.alpha_texname.empty();
    if (glass && (d < 1.0f || hasAlphaMap)) {
      note("d / map_d ignored: glass (illum " + std::to_string(illum) + ") is rendered as transmission");
    } else if (d < 1.0f || hasAlphaMap) {
      if (d < 0.0f || d > 1.0f) throw error(dKey, "dissolve " + shortNumber(d) + " is outside [0, 1]");
      t.alphaFactor = d;
      t.alphaMode = AlphaMode::kMask;
      t.alphaCutoff = 0.5f;
      if (hasAlphaMap) {
        const TextureRef alpha = texture("map_d", m.alpha_texname, m.alpha_texopt, ColorEncoding::kLinear);
        t.baseColor = combine(kdMap, {alpha, channelOf(m.alpha_texopt, alpha)}, -1, "map_Kd+map_d",
                              wrapOf(kdMap ? m.diffuse_texopt : m.alpha_texopt));
      }
      note("dissolve " + shortNumber(d) + " (" + dKey + ")" + (hasAlphaMap ? " with map_d" : "") +
           ": rendered as a cut-out, fully transparent where alpha < 0.5 and opaque elsewhere" +
           (d == 0.0f && !hasAlphaMap ? " (here: invisible; some exporters write Tr 1 meaning opaque)" : ""));
    }
  }

  // Notes each map this importer does not read (map_Ka, map_Ks, map_Ns, disp, refl, map_Ps).
  void noteIgnoredMaps(const tinyobj::material_t& m) {
    for (const auto& [key, name] : {std::pair<const char*, const std::string*>{"map_Ka", &m.ambient_texname},
                                    {"map_Ks", &m.specular_texname},
                                    {"map_Ns", &m.specular_highlight_texname},
                                    {"disp", &m.displacement_texname},
                                    {"refl", &m.reflection_texname},
                                    {"map_Ps", &m.sheen_texname}})
      if (!name->empty()) note(std::string(key) + " " + quote(*name) + " ignored (not supported)");
  }

  bool has(const std::string& key) const { return lines_->count(key) > 0; }
  std::string at(const std::string& key) const {
    const auto it = lines_->find(key);
    return it == lines_->end() ? "" : "line " + std::to_string(it->second) + ": ";
  }
  InputError error(const std::string& key, const std::string& what) const {
    return InputError(lib_->shown, at(key) + where_ + ": " + key + ": " + what);
  }
  // Notes name the library as the mtllib statement does (the scene loader prefixes the OBJ).
  void note(const std::string& what) { notes_.push_back(lib_->name + ": " + where_ + ": " + what); }

  float number(const std::string& key, double value) const {
    if (!std::isfinite(value) || std::abs(value) > 1e30) throw error(key, "is not a finite number");
    return float(value);
  }
  Spectrum color(const std::string& key, const double (&c)[3]) const {
    const Spectrum s(number(key, c[0]), number(key, c[1]), number(key, c[2]));
    if (s.r < 0.0f || s.g < 0.0f || s.b < 0.0f) throw error(key, "negative colour component");
    return s;
  }

  // The texture of statement `key`, decoded for `encoding`, or none when `name` is empty.
  TextureRef texture(const std::string& key, const std::string& name, const tinyobj::texture_option_t& opt,
                     ColorEncoding encoding) {
    if (name.empty()) return {};
    if (opt.colorspace == "linear") encoding = ColorEncoding::kLinear;
    if (opt.colorspace == "sRGB" || opt.colorspace == "srgb") encoding = ColorEncoding::kSrgb;
    const Wrap wrap = wrapOf(opt);
    // Relative to the MTL file, then to the OBJ file; Windows exporters' backslashes as slashes.
    std::vector<std::string> candidates = {joined(lib_->dir, name), name};
    if (name.find('\\') != std::string::npos) {
      std::string slashes = name;
      std::replace(slashes.begin(), slashes.end(), '\\', '/');
      candidates.push_back(joined(lib_->dir, slashes));
      candidates.push_back(slashes);
    }
    candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
    TextureRef ref;
    for (const std::string& rel : candidates) {
      const auto key3 = std::make_tuple(rel, encoding, wrap);
      if (auto it = cache_.find(key3); it != cache_.end()) {
        ref.texture = it->second;
        break;
      }
      std::optional<std::string> bytes = read_(rel);
      if (!bytes) continue;
      const std::string what = lib_->shown + ": " + at(key) + where_ + ": " + key + " " + quote(name);
      ref.texture =
          std::make_shared<const Texture>(joined(objDir_, rel), decodeImage(*bytes, what, encoding), wrap, wrap);
      cache_[key3] = ref.texture;
      break;
    }
    if (!ref) throw error(key, "cannot read texture " + quote(joined(objDir_, candidates.front())));
    // MTL's -o and -s act on MTL's texture space, whose v grows upwards: with v' = 1 - v,
    // s v + o becomes s v' + (1 - s - o).
    for (int c = 0; c < 2; ++c)
      if (!std::isfinite(opt.origin_offset[c]) || !std::isfinite(opt.scale[c]))
        throw error(key, "-o / -s option is not finite");
    ref.transform.scale = Vec2(float(opt.scale[0]), float(opt.scale[1]));
    ref.transform.offset = Vec2(float(opt.origin_offset[0]), float(1.0 - opt.scale[1] - opt.origin_offset[1]));
    return ref;
  }

  static Wrap wrapOf(const tinyobj::texture_option_t& opt) { return opt.clamp ? Wrap::kClampToEdge : Wrap::kRepeat; }

  // Which channel a scalar map (map_d, map_Pr, map_Pm) is read from: -imfchan r, g, b, l
  // (luminance) or m (matte: alpha when the image has any, else luminance, the default).
  static int channelOf(const tinyobj::texture_option_t& opt, const TextureRef& ref) {
    switch (opt.imfchan) {
      case 'r': return 0;
      case 'g': return 1;
      case 'b': return 2;
      case 'l': return -1;
      default: {
        if (!ref) return -1;
        const std::vector<float>& texels = ref.texture->level(0).texels;
        for (size_t k = 3; k < texels.size(); k += 4)
          if (texels[k] != 1.0f) return 3;
        return -1;
      }
    }
  }

  struct ScalarSource {
    TextureRef ref;
    int channel;  // 0-3, or -1 for luminance
  };

  // A texture of `base`'s RGBA (1 without it) whose channel `slotA` is `a` (and `slotB` `b`),
  // resampled to the largest of the images: MTL keeps in separate files what glTF packs in one.
  TextureRef combine(const TextureRef& base, const ScalarSource& a, int slotA, const std::string& what, Wrap wrap,
                     const ScalarSource& b = {}, int slotB = -1) {
    const TextureRef* first = base ? &base : a.ref ? &a.ref : &b.ref;
    int width = 0, height = 0;
    for (const TextureRef* r : {&base, &a.ref, &b.ref})
      if (*r) width = std::max(width, r->texture->width()), height = std::max(height, r->texture->height());
    RgbaImage out;
    out.width = width;
    out.height = height;
    out.texels.resize(4 * size_t(width) * size_t(height));
    auto scalar = [](const ScalarSource& s, Vec2 uv) {
      const Vec4 v = s.ref.texture->bilinear(uv, 0);
      if (s.channel >= 0) return v[s.channel];
      return v.r == v.g && v.g == v.b ? v.r : 0.2126f * v.r + 0.7152f * v.g + 0.0722f * v.b;
    };
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const Vec2 uv((float(x) + 0.5f) / float(width), (float(y) + 0.5f) / float(height));
        Vec4 v = base ? base.texture->bilinear(uv, 0) : Vec4(1.0f);
        if (a.ref) v[slotA < 0 ? 3 : slotA] = scalar(a, uv);
        if (b.ref) v[slotB] = scalar(b, uv);
        const size_t k = 4 * (size_t(y) * size_t(width) + size_t(x));
        for (int c = 0; c < 4; ++c) out.texels[k + size_t(c)] = v[c];
      }
    TextureRef ref = *first;
    for (const TextureRef* r : {&a.ref, &b.ref})
      if (*r && r != first &&
          (r->transform.offset != first->transform.offset || r->transform.scale != first->transform.scale))
        note(what + ": the maps' -o / -s differ; the first one's is used for both");
    std::string name;
    for (const TextureRef* r : {&base, &a.ref, &b.ref})
      if (*r) name += (name.empty() ? "" : " + ") + r->texture->name();
    ref.texture = std::make_shared<const Texture>(name, std::move(out), wrap, wrap);
    return ref;
  }

  // norm (a tangent-space normal map) or map_bump / bump: read as a normal map, which is what
  // exporters such as Blender write there; a grey image there is a height map, which is ignored.
  void normalMap(const tinyobj::material_t& m, MaterialTextures& t) {
    const bool norm = !m.normal_texname.empty();
    const std::string key = norm ? "norm" : has("map_bump") ? "map_bump" : has("map_Bump") ? "map_Bump" : "bump";
    const std::string& name = norm ? m.normal_texname : m.bump_texname;
    const tinyobj::texture_option_t& opt = norm ? m.normal_texopt : m.bump_texopt;
    if (name.empty()) return;
    TextureRef ref = texture(key, name, opt, ColorEncoding::kLinear);
    const std::vector<float>& texels = ref.texture->level(0).texels;
    bool grey = true;
    for (size_t k = 0; k < texels.size() && grey; k += 4)
      grey = texels[k] == texels[k + 1] && texels[k] == texels[k + 2];
    if (grey) {
      note(key + " " + quote(name) +
           " is a grey height map: bump mapping is not supported, ignored (use a normal map)");
      return;
    }
    if (!std::isfinite(opt.bump_multiplier)) throw error(key, "-bm is not a finite number");
    t.normal = ref;
    t.normalScale = float(opt.bump_multiplier);
  }

  const ModelFileReader& read_;
  std::string objDir_;
  std::vector<std::string>& notes_;
  std::map<std::tuple<std::string, ColorEncoding, Wrap>, std::shared_ptr<const Texture>> cache_;
  const MtlLibrary* lib_ = nullptr;
  const std::map<std::string, size_t>* lines_ = nullptr;
  std::string where_;
};

// ---------------------------------------------------------------------------------------------
// Geometry.

// The vertex made for each distinct (v, vt, vn) corner: per position v, a chain of the vertices
// made for it with their (vt, vn). Flat arrays (a 10^7-triangle mesh has millions of corners):
// 4 bytes per position and 16 per vertex, and a lookup walks a chain of one or a few entries.
class CornerVertices {
 public:
  static constexpr uint32_t kNone = UINT32_MAX;
  explicit CornerVertices(size_t positions) : first_(positions, kNone) {}
  uint32_t find(int v, int vt, int vn) const {
    for (uint32_t i = first_[size_t(v)]; i != kNone; i = made_[i].next)
      if (made_[i].vt == vt && made_[i].vn == vn) return made_[i].vertex;
    return kNone;
  }
  void add(int v, int vt, int vn, uint32_t vertex) {
    made_.push_back(Made{vt, vn, vertex, first_[size_t(v)]});
    first_[size_t(v)] = uint32_t(made_.size() - 1);
  }

 private:
  struct Made {
    int vt, vn;
    uint32_t vertex, next;
  };
  std::vector<uint32_t> first_;  // per position: its chain's head in made_
  std::vector<Made> made_;
};

// An input stream over a string's bytes, without copying them (std::istringstream would), that
// hands the pages it has passed back to the system as it goes (madvise MADV_DONTNEED; they read
// as zeros afterwards): tinyobjloader reads the text once, so a big file's text is not held while
// the mesh is built from it. The string must not be read again, only freed.
class ConsumingStreamBuf : public std::streambuf {
 public:
  explicit ConsumingStreamBuf(std::string& text)
      : end_(text.data() + text.size()), released_(pageAbove(uintptr_t(text.data()))) {
    window(text.data());
  }

 protected:
  int_type underflow() override {
    if (gptr() < egptr()) return traits_type::to_int_type(*gptr());
    if (egptr() == end_) return traits_type::eof();
#ifdef MADV_DONTNEED
    const uintptr_t upTo = uintptr_t(egptr()) / pageSize() * pageSize();
    if (upTo > released_) {
      madvise(reinterpret_cast<void*>(released_), upTo - released_, MADV_DONTNEED);
      released_ = upTo;
    }
#endif
    window(egptr());
    return traits_type::to_int_type(*gptr());
  }

 private:
  static constexpr size_t kWindow = size_t(1) << 22;  // 4 MiB read between releases
  static uintptr_t pageSize() {
    static const uintptr_t size = uintptr_t(sysconf(_SC_PAGESIZE));
    return size;
  }
  static uintptr_t pageAbove(uintptr_t at) { return (at + pageSize() - 1) / pageSize() * pageSize(); }
  void window(char* from) { setg(from, from, from + std::min<size_t>(kWindow, size_t(end_ - from))); }

  char* end_;
  uintptr_t released_;  // pages below this address (from the first whole page of the text) are released
};

// ---------------------------------------------------------------------------------------------
// The import, step by step (importCheckedObj).

// The MTL libraries an OBJ names, each read through the reader relative to the OBJ file and
// parsed by tinyobjloader before the OBJ is: a missing one is an error naming its mtllib line.
struct ObjMaterials {
  std::vector<tinyobj::material_t> materials;
  std::map<std::string, int> materialIndex;
  std::vector<MtlLibrary> libraries;
  std::vector<size_t> libraryOf;  // per material
};

ObjMaterials readMtlLibraries(const ObjScan& scan, const std::string& shown, const ModelFileReader& read) {
  ObjMaterials out;
  for (const ObjScan::Library& library : scan.libraries) {
    const std::optional<std::string> bytes = read(library.name);
    MtlLibrary lib;
    lib.dir = directoryOf(library.name);
    lib.name = library.name;
    lib.shown = joined(directoryOf(shown), library.name);
    if (!bytes)
      throw InputError(shown, "line " + std::to_string(library.line) + ": mtllib " + quote(library.name) +
                                  ": cannot read " + quote(lib.shown));
    checkMtlText(*bytes, lib.shown);
    // tinyobjloader would take a byte-order mark for part of the first statement.
    const std::string mtl = bytes->rfind("\xEF\xBB\xBF", 0) == 0 ? bytes->substr(3) : *bytes;
    std::string current;
    forEachStatement(mtl, [&](size_t line, std::string_view keyword, std::string_view, std::string_view statement) {
      // The material's name as tinyobjloader takes it: all of the statement after "newmtl ".
      if (keyword == "newmtl") current = std::string(statement.substr(std::min<size_t>(7, statement.size())));
      lib.statements[current].emplace(std::string(keyword), line);
    });
    std::istringstream stream(mtl);
    std::string warn, err;
    tinyobj::LoadMtl(&out.materialIndex, &out.materials, &stream, &warn, &err);
    out.libraryOf.resize(out.materials.size(), out.libraries.size());
    out.libraries.push_back(std::move(lib));
  }
  return out;
}

// The OBJ text parsed by tinyobjloader (triangulated) into `attrib` and `shapes`, with the
// materials read beforehand; the text's memory is handed back as it is read, and the rest after.
void loadObj(std::string& text, const std::string& shown, const ObjMaterials& mtl, tinyobj::attrib_t& attrib,
             std::vector<tinyobj::shape_t>& shapes) {
  std::vector<tinyobj::material_t> parsedMaterials;
  std::string warn, err;
  {
    ConsumingStreamBuf buffer(text);
    std::istream stream(&buffer);
    PreloadedMaterials reader(mtl.materials, mtl.materialIndex);
    if (!tinyobj::LoadObj(&attrib, &shapes, &parsedMaterials, &warn, &err, &stream, &reader, /*triangulate=*/true,
                          /*default_vcols_fallback=*/false))
      throw InputError(shown, "not a valid OBJ file: " + err);
  }
  std::string().swap(text);  // parsed (and released as it was read): the rest goes now
}

// Vertex v's position (0-based), in double as it is in the file.
DVec3 objPosition(const tinyobj::attrib_t& attrib, int v) {
  return DVec3(attrib.vertices[3 * size_t(v)], attrib.vertices[3 * size_t(v) + 1], attrib.vertices[3 * size_t(v) + 2]);
}

// The triangle's own normal, for corners without one (a unit vector even at zero area).
Vec3 faceNormal(const tinyobj::attrib_t& attrib, const tinyobj::index_t* corner) {
  const DVec3 p0 = objPosition(attrib, corner[0].vertex_index);
  const DVec3 cross =
      glm::cross(objPosition(attrib, corner[1].vertex_index) - p0, objPosition(attrib, corner[2].vertex_index) - p0);
  return glm::length(cross) > 0.0 ? Vec3(glm::normalize(cross)) : Vec3(0.0f, 0.0f, 1.0f);
}

// The three corners of a triangle of a file whose faces have vt or vn: each distinct (v, vt, vn)
// is one vertex, made once; a corner without a normal (or with a zero one) takes the face's
// normal on a vertex of its own, and one without vt reads uv (0, 0). The triangles with such
// corners are counted.
void addCornerTriangle(const ObjScan& scan, const tinyobj::attrib_t& attrib, const tinyobj::index_t* corner,
                       CornerVertices& corners, MeshInput& in, size_t& withoutTexcoords, size_t& withoutNormals) {
  TriangleMesh& mesh = in.mesh;
  bool missingTexcoord = false, missingNormal = false;
  for (size_t c = 0; c < 3; ++c) {
    const tinyobj::index_t& index = corner[c];
    Vec3 normal(0.0f);
    bool ownNormal = false;  // this corner takes the face's normal: not shared
    if (scan.faceNormals) {
      if (index.normal_index >= 0) {
        const size_t n = 3 * size_t(index.normal_index);
        normal = Vec3(float(attrib.normals[n]), float(attrib.normals[n + 1]), float(attrib.normals[n + 2]));
      }
      if (!(glm::length(normal) > 0.0f)) {
        normal = faceNormal(attrib, corner);
        ownNormal = missingNormal = true;
      }
    }
    if (!ownNormal) {
      if (const uint32_t made = corners.find(index.vertex_index, index.texcoord_index, index.normal_index);
          made != CornerVertices::kNone) {
        mesh.indices.push_back(made);
        continue;
      }
    }
    const uint32_t vertex = uint32_t(in.positions.size());
    if (!ownNormal) corners.add(index.vertex_index, index.texcoord_index, index.normal_index, vertex);
    in.positions.push_back(objPosition(attrib, index.vertex_index));
    if (scan.faceNormals) mesh.normals.push_back(normal);
    if (scan.faceTexcoords) {
      Vec2 uv(0.0f);
      if (index.texcoord_index >= 0) {
        const size_t t = 2 * size_t(index.texcoord_index);
        uv = Vec2(float(attrib.texcoords[t]), float(1.0 - attrib.texcoords[t + 1]));
      } else {
        missingTexcoord = true;
      }
      mesh.uv[0].push_back(uv);
    }
    mesh.indices.push_back(vertex);
  }
  withoutTexcoords += missingTexcoord;
  withoutNormals += missingNormal;
}

// The whole file as one mesh, model.meshes[0], its triangles in file order with their groups and
// materials (tinyobjloader's material index -> its number in the order of first use, in
// `usedMaterials`); every vertex finite and every face reference defined; the model's bounds.
void buildObjMesh(const ObjScan& scan, const tinyobj::attrib_t& attrib, const std::vector<tinyobj::shape_t>& shapes,
                  size_t materialCount, const std::string& shown, ImportedObj& result,
                  std::map<int, uint32_t>& usedMaterials) {
  ImportedModel& model = result.model;
  // Positions in double, as they are in the file.
  for (size_t k = 0; k < attrib.vertices.size(); k += 3) {
    const DVec3 v(attrib.vertices[k], attrib.vertices[k + 1], attrib.vertices[k + 2]);
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
      throw InputError(shown, "vertex " + std::to_string(k / 3 + 1) + " is not finite");
  }
  const size_t vertexCount = attrib.vertices.size() / 3, texcoordCount = attrib.texcoords.size() / 2,
               normalCount = attrib.normals.size() / 3;

  model.meshes.emplace_back();
  MeshInput& in = model.meshes.back();
  TriangleMesh& mesh = in.mesh;
  const bool byCorner = scan.faceTexcoords || scan.faceNormals;
  if (!byCorner)
    for (size_t v = 0; v < vertexCount; ++v) in.positions.push_back(objPosition(attrib, int(v)));
  CornerVertices corners(byCorner ? vertexCount : 0);
  size_t withoutTexcoords = 0, withoutNormals = 0;
  for (const tinyobj::shape_t& shape : shapes) {
    const uint32_t group = uint32_t(result.groupNames.size());
    result.groupNames.push_back(shape.name);
    const auto& indices = shape.mesh.indices;
    for (size_t tri = 0; tri < indices.size() / 3; ++tri) {
      for (size_t c = 0; c < 3; ++c) {
        const tinyobj::index_t& index = indices[3 * tri + c];
        if (index.vertex_index < 0 || size_t(index.vertex_index) >= vertexCount)
          throw InputError(shown, "face refers to a missing vertex");
        if (index.texcoord_index >= 0 && size_t(index.texcoord_index) >= texcoordCount)
          throw InputError(shown, "face refers to a missing texture coordinate");
        if (index.normal_index >= 0 && size_t(index.normal_index) >= normalCount)
          throw InputError(shown, "face refers to a missing normal");
      }
      if (!byCorner) {
        for (size_t c = 0; c < 3; ++c) mesh.indices.push_back(uint32_t(indices[3 * tri + c].vertex_index));
      } else {
        addCornerTriangle(scan, attrib, &indices[3 * tri], corners, in, withoutTexcoords, withoutNormals);
      }
      const int material = tri < shape.mesh.material_ids.size() ? shape.mesh.material_ids[tri] : -1;
      uint32_t id = kNoObjMaterial;
      if (material >= 0 && size_t(material) < materialCount)
        id = usedMaterials.emplace(material, uint32_t(usedMaterials.size())).first->second;
      mesh.materialIds.push_back(id);
      result.triangleGroups.push_back(group);
    }
  }
  if (withoutTexcoords > 0)
    model.notes.push_back(std::to_string(withoutTexcoords) +
                          " triangles have corners without texture coordinates (vt): those read uv (0, 0)");
  if (withoutNormals > 0)
    model.notes.push_back(std::to_string(withoutNormals) +
                          " triangles have corners without a normal (vn) or with a zero one: those take the "
                          "triangle's own normal");
  for (const DVec3& p : in.positions) {
    model.lo = glm::min(model.lo, p);
    model.hi = glm::max(model.hi, p);
  }
}

}  // namespace

ImportedObj importObj(const std::string& text, const std::string& shown, const ModelFileReader& read) {
  // tinyobjloader skips what it does not understand: check first that this is an OBJ at all.
  ObjCheck check = checkObjText(text);
  if (!check.ok()) throw InputError(shown, check.problem);
  return importCheckedObj(std::move(check.text), shown, read);
}

ImportedObj importCheckedObj(std::string text, const std::string& shown, const ModelFileReader& read) {
  const ObjScan scan = scanObj(text, shown);
  ImportedObj result;
  ImportedModel& model = result.model;

  // The material libraries, read through the reader relative to the OBJ file.
  const ObjMaterials mtl = readMtlLibraries(scan, shown, read);

  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  loadObj(text, shown, mtl, attrib, shapes);
  for (const std::string& name : scan.materialNames)
    if (!mtl.materialIndex.count(name))
      model.notes.push_back("usemtl " + quote(name) +
                            " names no material of the mtllib files: the scene's material is used");

  std::map<int, uint32_t> usedMaterials;  // tinyobjloader's index -> model.materials
  buildObjMesh(scan, attrib, shapes, mtl.materials.size(), shown, result, usedMaterials);

  // The materials the triangles use, in the order of first use.
  std::vector<std::pair<int, uint32_t>> order(usedMaterials.begin(), usedMaterials.end());
  std::sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  MaterialBuilder builder(read, directoryOf(shown), model.notes);
  for (const auto& [index, id] : order)
    model.materials.push_back(builder.build(mtl.materials[size_t(index)], mtl.libraries[mtl.libraryOf[size_t(index)]]));
  return result;
}

}  // namespace lensfarm
