#pragma once
// Writes small glTF 2.0 models for tests: a document with one buffer, as a .gltf with an external
// .bin, as a .gltf with a data URI, or as a .glb assembled byte by byte (glTF 2.0 §4.4).
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace lensfarm::test {

using json = nlohmann::json;

// glTF componentType values (glTF 2.0 §3.6.2.2).
constexpr int kFloat = 5126, kUnsignedByte = 5121, kUnsignedShort = 5123, kUnsignedInt = 5125;

inline std::string base64(const std::string& bytes) {
  static const char* kDigits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    uint32_t v = uint32_t(static_cast<unsigned char>(bytes[i])) << 16;
    if (i + 1 < bytes.size()) v |= uint32_t(static_cast<unsigned char>(bytes[i + 1])) << 8;
    if (i + 2 < bytes.size()) v |= uint32_t(static_cast<unsigned char>(bytes[i + 2]));
    out += kDigits[(v >> 18) & 63];
    out += kDigits[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? kDigits[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kDigits[v & 63] : '=';
  }
  return out;
}

inline void appendU32(std::string& out, uint32_t v) {
  for (int k = 0; k < 4; ++k) out += char((v >> (8 * k)) & 0xff);
}

// A .glb (glTF 2.0 §4.4): the 12-byte header, the JSON chunk padded with spaces, the BIN chunk
// padded with zeros.
inline std::string glbOf(std::string text, std::string bin) {
  while (text.size() % 4 != 0) text += ' ';
  while (bin.size() % 4 != 0) bin += '\0';
  std::string out = "glTF";
  appendU32(out, 2);
  appendU32(out, uint32_t(12 + 8 + text.size() + (bin.empty() ? 0 : 8 + bin.size())));
  appendU32(out, uint32_t(text.size()));
  appendU32(out, 0x4E4F534A);  // JSON
  out += text;
  if (!bin.empty()) {
    appendU32(out, uint32_t(bin.size()));
    appendU32(out, 0x004E4942);  // BIN
    out += bin;
  }
  return out;
}

template <class T>
std::string bytesOf(const std::vector<T>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}

// A glTF model under construction: one buffer, the document around it.
struct Builder {
  json doc = {{"asset", {{"version", "2.0"}}}, {"bufferViews", json::array()}, {"accessors", json::array()}};
  std::string bin;

  int view(const std::string& bytes, int stride = 0) {
    while (bin.size() % 4 != 0) bin += '\0';
    json v = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes.size()}};
    if (stride != 0) v["byteStride"] = stride;
    bin += bytes;
    doc["bufferViews"].push_back(v);
    return int(doc["bufferViews"].size()) - 1;
  }
  int accessor(int bufferView, int componentType, size_t count, const std::string& type, json extra = json::object()) {
    json a = {{"bufferView", bufferView}, {"componentType", componentType}, {"count", count}, {"type", type}};
    a.update(extra);
    doc["accessors"].push_back(a);
    return int(doc["accessors"].size()) - 1;
  }
  int floats(const std::vector<float>& values, const std::string& type) {
    const size_t per = type == "VEC2" ? 2 : type == "VEC3" ? 3 : type == "VEC4" ? 4 : 1;
    return accessor(view(bytesOf(values)), kFloat, values.size() / per, type);
  }
  int indices(const std::vector<uint16_t>& values) {
    return accessor(view(bytesOf(values)), kUnsignedShort, values.size(), "SCALAR");
  }
  int add(const char* array, json value) {
    doc[array].push_back(std::move(value));
    return int(doc[array].size()) - 1;
  }

  // As a .gltf whose buffer is the file `uri`, as a .gltf with the buffer in a data URI, as a .glb.
  std::string gltf(const std::string& uri) const {
    json d = doc;
    d["buffers"] = json::array({{{"byteLength", bin.size()}, {"uri", uri}}});
    return d.dump(1);
  }
  std::string embedded() const { return gltf("data:application/octet-stream;base64," + base64(bin)); }
  std::string glb() const {
    json d = doc;
    d["buffers"] = json::array({{{"byteLength", bin.size()}}});
    return glbOf(d.dump(), bin);
  }
};

}  // namespace lensfarm::test
