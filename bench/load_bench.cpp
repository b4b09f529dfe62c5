// Loading big scenes (docs/performance.md, "Loading big scenes"): how long a generated mesh of N
// triangles takes to load and to make ready for rendering, and how much memory that needs at its
// peak.
//
// For each size the mesh (a heightfield grid over the unit square: smooth bumps, vertex normals
// and texture coordinates, 2 triangles per grid cell, N / 2 vertices or so) is written into a
// temporary directory as a binary glTF (.glb) and as an OBJ with v/vt/vn, each with a scene file
// that names it as its one shape, with a camera and a white environment. Each case then runs in
// a fresh child process (this program re-executed with --child), so that peaks do not mix, which
// measures:
//   load      wall time of loadScene (scene/scene_loader.h): reading, importing, render space;
//   build     wall time of constructing the RenderScene (render/render_scene.h): the effects
//             analysis, the Embree BVH and the light sampler;
//   peak      the process's peak resident memory (VmHWM, /proc/self/status), after loading and
//             after the build, and that peak over N: bytes per triangle, everything included
//             (the program itself, Embree, TBB).
// It prints medians over --repeat runs, with the CPU time beside each wall time (on a shared
// machine the CPU time is the steadier measure). --phases adds, per case, the build split into its
// parts (constructed one after the other as RenderScene does) from one more child each. --mirror
// makes the mesh a mirror: the effects analysis then searches it for closed shells. --digest (with
// --child) prints a SHA-256 of what was loaded, to check that a change keeps every bit. --uses N
// places the glb's mesh with N nodes (instanced; with --copies, copied per use): the table's
// triangles are those held in memory, bytes/triangle are per triangle drawn.
//
//   build/bench/lensfarm-load-bench [--triangles 1000000 --triangles 10000000] [--repeat 3]
//                                   [--formats glb,obj] [--dir /tmp/x] [--keep] [--phases] [--mirror]
//                                   [--uses 1000 [--copies]]
#include <sys/resource.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "common/farm/memory_estimate.h"
#include "common/render/render_scene.h"
#include "common/scene/scene_loader.h"
#include "common/util/hash.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using json = nlohmann::json;

double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// CPU time (user + system) of every thread of this process so far, in seconds.
double cpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  const auto seconds = [](const timeval& t) { return double(t.tv_sec) + 1e-6 * double(t.tv_usec); };
  return seconds(u.ru_utime) + seconds(u.ru_stime);
}

// A field of /proc/self/status in bytes (VmHWM: the peak resident set so far; VmRSS: the resident
// set now), or 0 if it cannot be read.
uint64_t statusBytes(const std::string& field) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind(field, 0) == 0) return uint64_t(std::stoull(line.substr(field.size()))) * 1024;
  return 0;
}
uint64_t peakResidentBytes() { return statusBytes("VmHWM:"); }

// ---------------------------------------------------------------------------------------------
// The mesh: an nx x nz grid of cells over [0, 1]^2 in the xz plane, y = h(x, z) a few gentle
// bumps, counter-clockwise seen from above (+y).
struct Grid {
  uint32_t nx = 0, nz = 0;
  uint64_t triangles() const { return 2 * uint64_t(nx) * nz; }
  uint64_t vertices() const { return uint64_t(nx + 1) * (nz + 1); }
};

// Cells as close to square as gives exactly `triangles` (rounded down to even), for sizes like
// 10^6 and 10^7.
Grid gridOf(uint64_t triangles) {
  const uint64_t cells = std::max<uint64_t>(1, triangles / 2);
  uint64_t nx = uint64_t(std::sqrt(double(cells)));
  while (nx > 1 && cells % nx != 0) --nx;
  return Grid{uint32_t(std::max<uint64_t>(nx, 1)), uint32_t(cells / std::max<uint64_t>(nx, 1))};
}

constexpr double kBump = 0.03, kWavesX = 5.0, kWavesZ = 4.0;

struct Vertex {
  float p[3], n[3], uv[2];
};

Vertex vertexAt(const Grid& g, uint32_t i, uint32_t j) {
  const double x = double(i) / g.nx, z = double(j) / g.nz;
  const double ax = 2.0 * std::numbers::pi * kWavesX, az = 2.0 * std::numbers::pi * kWavesZ;
  const double y = kBump * std::sin(ax * x) * std::cos(az * z);
  const double dydx = kBump * ax * std::cos(ax * x) * std::cos(az * z);
  const double dydz = -kBump * az * std::sin(ax * x) * std::sin(az * z);
  const double len = std::sqrt(dydx * dydx + 1.0 + dydz * dydz);
  return Vertex{{float(x), float(y), float(z)},
                {float(-dydx / len), float(1.0 / len), float(-dydz / len)},
                {float(x), float(1.0 - z)}};
}

// Vertex (i, j) is number j * (nx + 1) + i. Cell (i, j): two triangles, each counter-clockwise
// seen from +y (the xz plane with x right and z towards the viewer).
template <typename Emit>
void forEachTriangle(const Grid& g, Emit emit) {
  const uint32_t row = g.nx + 1;
  for (uint32_t j = 0; j < g.nz; ++j)
    for (uint32_t i = 0; i < g.nx; ++i) {
      const uint32_t a = j * row + i, b = a + 1, c = a + row, d = c + 1;
      emit(a, c, b);
      emit(b, c, d);
    }
}

// A buffered writer for large files.
class Writer {
 public:
  explicit Writer(const fs::path& path) : file_(std::fopen(path.c_str(), "wb")) {
    if (!file_) throw std::runtime_error("cannot write " + path.string());
    buffer_.reserve(kChunk + 256);
  }
  ~Writer() { close(); }
  void close() {
    if (!file_) return;
    flush();
    std::fclose(file_);
    file_ = nullptr;
  }
  void bytes(const void* data, size_t size) {
    buffer_.append(static_cast<const char*>(data), size);
    if (buffer_.size() >= kChunk) flush();
  }
  void text(std::string_view s) { bytes(s.data(), s.size()); }
  template <typename T>
  void number(T value) {
    char tmp[32];
    const auto result = std::to_chars(tmp, tmp + sizeof tmp, value);  // shortest form that reads back exactly
    bytes(tmp, size_t(result.ptr - tmp));
  }
  void u32le(uint32_t v) {
    const unsigned char b[4] = {uint8_t(v), uint8_t(v >> 8), uint8_t(v >> 16), uint8_t(v >> 24)};
    bytes(b, 4);
  }

 private:
  static constexpr size_t kChunk = size_t(1) << 22;
  void flush() {
    if (!buffer_.empty() && std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size())
      throw std::runtime_error("write failed (disk full?)");
    buffer_.clear();
  }
  std::FILE* file_;
  std::string buffer_;
};

// A binary glTF (glTF 2.0 §4.4): the 12-byte header, the JSON chunk padded with spaces, the BIN
// chunk (positions, normals, texture coordinates, 32-bit indices; each a multiple of 4 bytes).
// `uses` nodes place the mesh side by side (more than one: the scene loader instances it).
void writeGlb(const Grid& g, const fs::path& path, int uses) {
  const uint64_t vertices = g.vertices(), triangles = g.triangles();
  const uint64_t positionBytes = 12 * vertices, normalBytes = 12 * vertices, uvBytes = 8 * vertices;
  const uint64_t indexBytes = 12 * triangles;
  const uint64_t binBytes = positionBytes + normalBytes + uvBytes + indexBytes;
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  for (uint32_t j = 0; j <= g.nz; ++j)
    for (uint32_t i = 0; i <= g.nx; ++i) {
      const Vertex v = vertexAt(g, i, j);
      for (int c = 0; c < 3; ++c) lo[c] = std::min(lo[c], v.p[c]), hi[c] = std::max(hi[c], v.p[c]);
    }
  const auto view = [](uint64_t offset, uint64_t length, int target) {
    return json{{"buffer", 0}, {"byteOffset", offset}, {"byteLength", length}, {"target", target}};
  };
  json nodes = json::array(), roots = json::array();
  const int side = int(std::ceil(std::sqrt(double(uses))));
  for (int k = 0; k < uses; ++k) {
    nodes.push_back({{"mesh", 0}, {"name", "grid"}, {"translation", {1.1 * (k % side), 0.0, 1.1 * (k / side)}}});
    roots.push_back(k);
  }
  json doc = {
      {"asset", {{"version", "2.0"}, {"generator", "lensfarm-load-bench"}}},
      {"scene", 0},
      {"scenes", {{{"nodes", roots}}}},
      {"nodes", nodes},
      {"meshes",
       {{{"name", "grid"},
         {"primitives",
          {{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}, {"TEXCOORD_0", 2}}}, {"indices", 3}, {"material", 0}}}}}}},
      {"materials",
       {{{"name", "grey"},
         {"pbrMetallicRoughness",
          {{"baseColorFactor", {0.7, 0.7, 0.7, 1.0}}, {"metallicFactor", 0.0}, {"roughnessFactor", 1.0}}}}}},
      {"buffers", {{{"byteLength", binBytes}}}},
      {"bufferViews",
       {view(0, positionBytes, 34962), view(positionBytes, normalBytes, 34962),
        view(positionBytes + normalBytes, uvBytes, 34962),
        view(positionBytes + normalBytes + uvBytes, indexBytes, 34963)}},
      {"accessors",
       {{{"bufferView", 0},
         {"componentType", 5126},
         {"count", vertices},
         {"type", "VEC3"},
         {"min", {lo[0], lo[1], lo[2]}},
         {"max", {hi[0], hi[1], hi[2]}}},
        {{"bufferView", 1}, {"componentType", 5126}, {"count", vertices}, {"type", "VEC3"}},
        {{"bufferView", 2}, {"componentType", 5126}, {"count", vertices}, {"type", "VEC2"}},
        {{"bufferView", 3}, {"componentType", 5125}, {"count", 3 * triangles}, {"type", "SCALAR"}}}}};
  std::string text = doc.dump();
  while (text.size() % 4 != 0) text += ' ';
  const uint64_t total = 12 + 8 + text.size() + 8 + binBytes;
  if (total > UINT32_MAX) throw std::runtime_error("the .glb would exceed 4 GiB");
  Writer out(path);
  out.text("glTF");
  out.u32le(2);
  out.u32le(uint32_t(total));
  out.u32le(uint32_t(text.size()));
  out.u32le(0x4E4F534A);  // JSON
  out.text(text);
  out.u32le(uint32_t(binBytes));
  out.u32le(0x004E4942);  // BIN
  for (int part = 0; part < 3; ++part)
    for (uint32_t j = 0; j <= g.nz; ++j)
      for (uint32_t i = 0; i <= g.nx; ++i) {
        const Vertex v = vertexAt(g, i, j);
        out.bytes(part == 0 ? v.p : part == 1 ? v.n : v.uv, part == 2 ? 8 : 12);
      }
  forEachTriangle(g, [&](uint32_t a, uint32_t b, uint32_t c) {
    const uint32_t idx[3] = {a, b, c};
    out.bytes(idx, sizeof idx);
  });
}

// The same mesh as OBJ: v, vt and vn in the same order (the float values written exactly), faces
// v/vt/vn with one number for all three.
void writeObj(const Grid& g, const fs::path& path) {
  Writer out(path);
  out.text("# lensfarm-load-bench: a heightfield grid\no grid\n");
  const char* prefixes[3] = {"v ", "vt ", "vn "};
  for (int part = 0; part < 3; ++part)
    for (uint32_t j = 0; j <= g.nz; ++j)
      for (uint32_t i = 0; i <= g.nx; ++i) {
        const Vertex v = vertexAt(g, i, j);
        const float* values = part == 0 ? v.p : part == 1 ? v.uv : v.n;
        out.text(prefixes[part]);
        for (int c = 0; c < (part == 1 ? 2 : 3); ++c) {
          if (c) out.text(" ");
          out.number(values[c]);
        }
        out.text("\n");
      }
  forEachTriangle(g, [&](uint32_t a, uint32_t b, uint32_t c) {
    out.text("f");
    for (uint32_t v : {a, b, c}) {
      out.text(" ");
      for (int k = 0; k < 3; ++k) {
        if (k) out.text("/");
        out.number(v + 1);
      }
    }
    out.text("\n");
  });
}

// A scene with the model as its one shape, seen from above and the front, lit by a white sky.
// `mirror`: the shape is a mirror, which has the effects analysis look for closed meshes.
// `copies`: a mesh several nodes use is copied per use rather than instanced.
void writeScene(const fs::path& path, const std::string& format, const std::string& model, bool mirror, bool copies) {
  json shape = {{"type", format == "obj" ? "obj" : "gltf"}, {"file", model}};
  if (copies) shape["instancing"] = false;
  if (format == "obj" || mirror) shape["material"] = mirror ? "mirror" : "white";
  const json scene = {
      {"format", kSceneFormat},
      {"render", {{"resolution", {64, 64}}, {"samples_per_pixel", 1}}},
      {"materials",
       {{"white", {{"type", "lambertian"}, {"albedo", {0.8, 0.8, 0.8}}}},
        {"mirror", {{"type", "mirror"}, {"reflectance", 0.9}}}}},
      {"camera",
       {{"type", "pinhole"}, {"position", {0.5, 1.2, 2.0}}, {"look_at", {0.5, 0.0, 0.5}}, {"angle_of_view", 50}}},
      {"shapes", {shape}},
      {"environment", {{"radiance", {1.0, 1.0, 1.0}}}}};
  std::ofstream(path) << scene.dump(2) << "\n";
}

// ---------------------------------------------------------------------------------------------
// A child: one case, measured from a fresh process.
struct Result {
  double load = 0, build = 0, loadCpu = 0, buildCpu = 0;
  uint64_t peakLoad = 0, peak = 0, triangles = 0;
  double effects = 0, caster = 0, lights = 0;  // --phases only
  uint64_t sceneRss = 0, casterRss = 0;        // --phases only: resident after loading; added by the caster
};

// SHA-256 of every array of the loaded scene's meshes and of the caster's triangle table: equal
// digests before and after a change to the loading path say it loads the very same bits.
std::string sceneDigest(const Scene& scene) {
  Sha256 hash;
  const auto add = [&](const auto& v) {
    hash.update(std::string_view(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(v[0])));
  };
  for (const TriangleMesh& m : scene.meshes) {
    add(m.positions), add(m.indices), add(m.materialIds), add(m.normals), add(m.uv[0]), add(m.uv[1]), add(m.tangents);
    hash.update(m.name);
  }
  const RayCaster caster(scene);
  add(caster.triangles());
  return hash.hexDigest();
}

int runChild(const fs::path& scenePath, bool phases, bool digest) {
  if (digest) {
    std::printf("%s\n", sceneDigest(loadScene(scenePath)).c_str());
    return 0;
  }
  Result r;
  const auto start = Clock::now();
  const double cpuStart = cpuSeconds();
  const Scene scene = loadScene(scenePath);
  r.load = secondsSince(start);
  r.loadCpu = cpuSeconds() - cpuStart;
  const double buildCpuStart = cpuSeconds();
  r.peakLoad = peakResidentBytes();
  r.triangles = storedTriangles(scene);
  if (!phases) {
    const auto buildStart = Clock::now();
    const RenderScene render(scene);
    r.build = secondsSince(buildStart);
    r.buildCpu = cpuSeconds() - buildCpuStart;
    r.peak = peakResidentBytes();
  } else {
    // RenderScene's parts, one after the other as its constructor makes them.
    auto t = Clock::now();
    const ThinLensCamera camera = scene.camera();
    const EffectSet effects = analyzeEffects(scene, camera);
    r.effects = secondsSince(t);
    r.sceneRss = statusBytes("VmRSS:");
    t = Clock::now();
    const RayCaster caster(scene);
    r.caster = secondsSince(t);
    r.casterRss = statusBytes("VmRSS:") - r.sceneRss;
    t = Clock::now();
    const LightSampler lights(scene, caster, effects.lightUseful, scene.render.integrator == IntegratorKind::kNaive);
    r.lights = secondsSince(t);
    r.build = r.effects + r.caster + r.lights;
    r.buildCpu = cpuSeconds() - buildCpuStart;
    r.peak = peakResidentBytes();
  }
  std::printf("RESULT %.6f %.6f %llu %llu %llu %.6f %.6f %.6f %.6f %.6f %llu %llu\n", r.load, r.build,
              (unsigned long long)r.peakLoad, (unsigned long long)r.peak, (unsigned long long)r.triangles, r.effects,
              r.caster, r.lights, r.loadCpu, r.buildCpu, (unsigned long long)r.sceneRss,
              (unsigned long long)r.casterRss);
  return 0;
}

std::string selfPath() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw std::runtime_error("cannot find this program's path (/proc/self/exe)");
  return self.string();
}

std::string quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

Result runCase(const std::string& self, const fs::path& scenePath, bool phases) {
  const std::string command = quoted(self) + " --child " + quoted(scenePath.string()) + (phases ? " --phases" : "");
  std::FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) throw std::runtime_error("cannot run " + command);
  Result r;
  bool found = false;
  char line[512];
  while (std::fgets(line, sizeof line, pipe)) {
    unsigned long long peakLoad = 0, peak = 0, triangles = 0, sceneRss = 0, casterRss = 0;
    if (std::sscanf(line, "RESULT %lf %lf %llu %llu %llu %lf %lf %lf %lf %lf %llu %llu", &r.load, &r.build, &peakLoad,
                    &peak, &triangles, &r.effects, &r.caster, &r.lights, &r.loadCpu, &r.buildCpu, &sceneRss,
                    &casterRss) == 12) {
      r.peakLoad = peakLoad, r.peak = peak, r.triangles = triangles, r.sceneRss = sceneRss, r.casterRss = casterRss;
      found = true;
    } else {
      std::fputs(line, stderr);  // the child's own messages
    }
  }
  const int status = pclose(pipe);
  if (!found || status != 0) throw std::runtime_error("the child for " + scenePath.string() + " failed");
  return r;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string megabytes(double bytes) {
  char s[32];
  std::snprintf(s, sizeof s, "%.0f MB", bytes / 1e6);
  return s;
}

}  // namespace
}  // namespace lensfarm

int main(int argc, char** argv) {
  using namespace lensfarm;
  CLI::App app{"lensfarm load benchmark: load time, BVH build time and peak memory of a generated mesh"};
  std::vector<uint64_t> sizes;
  std::vector<std::string> formats{"glb", "obj"};
  int repeat = 3;
  std::string dir, child;
  bool keep = false, phases = false, mirror = false, copies = false;
  int uses = 1;
  app.add_option("--triangles", sizes, "Mesh sizes in triangles (default: 1000000 and 10000000)");
  app.add_option("--formats", formats, "glb, obj or both")->delimiter(',')->check(CLI::IsMember({"glb", "obj"}));
  app.add_option("--repeat", repeat, "Runs per case; medians are reported")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  app.add_option("--dir", dir, "Where to write the meshes (default: a new temporary directory)");
  app.add_flag("--keep", keep, "Keep the generated files");
  app.add_flag("--phases", phases, "Also time the build's parts (effects analysis, Embree, light sampler)");
  app.add_flag("--mirror", mirror, "Make the mesh a mirror (the effects analysis then looks for closed meshes)");
  app.add_option("--uses", uses, "Nodes placing the mesh (glb only; more than one: instanced)")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  app.add_flag("--copies", copies, "With --uses: copy the mesh for each use instead of instancing it");
  app.add_option("--child", child, "(internal) measure loading this scene file in this process");
  bool digest = false;
  app.add_flag("--digest", digest, "With --child: print a SHA-256 of the loaded meshes and triangle table instead");
  CLI11_PARSE(app, argc, argv);
  try {
    if (!child.empty()) return runChild(child, phases, digest);
    if (sizes.empty()) sizes = {1000000, 10000000};
    const fs::path root =
        dir.empty() ? fs::temp_directory_path() / ("lensfarm-load-bench-" + std::to_string(getpid())) : fs::path(dir);
    fs::create_directories(root);
    const std::string self = selfPath();
    std::printf(
        "| triangles | format | file | load (s) | load CPU (s) | build (s) | build CPU (s) | peak after load | peak | "
        "bytes/triangle |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
    std::vector<std::string> phaseLines;
    for (const uint64_t n : sizes) {
      const Grid grid = gridOf(n);
      for (const std::string& format : formats) {
        if (uses > 1 && format != "glb") {
          std::fprintf(stderr, "--uses: %s has no instancing; skipped\n", format.c_str());
          continue;
        }
        const std::string usesTag = uses > 1 ? "-u" + std::to_string(uses) : "";
        const fs::path model = root / ("mesh-" + std::to_string(grid.triangles()) + usesTag + "." + format);
        const fs::path scenePath = root / ("scene-" + std::to_string(grid.triangles()) + usesTag + "-" + format +
                                           (mirror ? "-mirror" : "") + (copies ? "-copies" : "") + ".json");
        if (!fs::exists(model)) {
          const auto t = Clock::now();
          format == "glb" ? writeGlb(grid, model, uses) : writeObj(grid, model);
          std::fprintf(stderr, "wrote %s (%s) in %.1f s\n", model.c_str(),
                       megabytes(double(fs::file_size(model))).c_str(), secondsSince(t));
        }
        writeScene(scenePath, format, model.filename().string(), mirror, copies);
        const std::string label =
            uses == 1 ? format : format + ", " + std::to_string(uses) + (copies ? " copies" : " instances");
        std::vector<double> load, build, loadCpu, buildCpu, peakLoad, peak;
        uint64_t triangles = 0;
        for (int k = 0; k < repeat; ++k) {
          const Result r = runCase(self, scenePath, false);
          load.push_back(r.load), build.push_back(r.build);
          loadCpu.push_back(r.loadCpu), buildCpu.push_back(r.buildCpu);
          peakLoad.push_back(double(r.peakLoad)), peak.push_back(double(r.peak));
          triangles = r.triangles;
        }
        std::printf("| %llu | %s | %s | %.2f | %.2f | %.2f | %.2f | %s | %s | %.0f |\n", (unsigned long long)triangles,
                    label.c_str(), megabytes(double(fs::file_size(model))).c_str(), median(load), median(loadCpu),
                    median(build), median(buildCpu), megabytes(median(peakLoad)).c_str(),
                    megabytes(median(peak)).c_str(), median(peak) / double(grid.triangles() * uint64_t(uses)));
        std::fflush(stdout);
        if (phases) {
          std::vector<double> effects, caster, lights, sceneRss, casterRss;
          for (int k = 0; k < repeat; ++k) {
            const Result r = runCase(self, scenePath, true);
            effects.push_back(r.effects), caster.push_back(r.caster), lights.push_back(r.lights);
            sceneRss.push_back(double(r.sceneRss)), casterRss.push_back(double(r.casterRss));
          }
          char line[256];
          std::snprintf(line, sizeof line, "| %llu | %s | %.3f | %.3f | %.3f | %s | %s |",
                        (unsigned long long)triangles, label.c_str(), median(effects), median(caster), median(lights),
                        megabytes(median(sceneRss)).c_str(), megabytes(median(casterRss)).c_str());
          phaseLines.push_back(line);
        }
        if (!keep) fs::remove(model);
      }
    }
    if (phases) {
      std::printf(
          "\nThe build's parts (s, medians), the memory resident once loaded and what the caster adds (Embree's "
          "BVH and buffers, the triangle table):\n\n| triangles | format | effects analysis | RayCaster (Embree) | "
          "light sampler | resident after loading | added by the caster |\n|---|---|---|---|---|---|---|\n");
      for (const std::string& line : phaseLines) std::printf("%s\n", line.c_str());
    }
    if (!keep && dir.empty()) fs::remove_all(root);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lensfarm-load-bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
