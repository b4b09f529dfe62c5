#include "common/scene/effects.h"
#include "common/camera/real_lens_camera.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "common/film/diffraction_psf.h"
#include "common/material/dielectric.h"
#include "common/material/mirror.h"
#include "common/math/triangle.h"
#include "common/medium/medium.h"
#include "common/scene/scene_diffraction.h"
#include "common/scene/scene_loader.h"

namespace lensfarm {

namespace {
// Below this blur (in sensor cells) a thin lens and a pinhole make the same picture.
constexpr double kNegligibleBlurCells = 0.5;
// A closed component: connected triangles of one mesh in which every edge is shared by exactly
// two triangles (a watertight, manifold shell).
struct Shell {
  const TriangleMesh* mesh;
  std::vector<uint32_t> triangles;
};

// In linear time and with flat arrays (a 10^7-triangle mesh takes well under a second): the
// components by union-find over vertex indices; each undirected edge bucketed by its smaller
// vertex (a counting sort), its uses counted within the bucket. Shells in mesh order, each
// mesh's by ascending root, their triangles in mesh order.
std::vector<Shell> closedShells(const Scene& scene) {
  std::vector<Shell> shells;
  for (const auto& mesh : scene.meshes) {
    // A mesh any of whose materials lets paths through (glass, an interface, subsurface) is no
    // wall: camera paths enter it.
    if (std::any_of(mesh.materialIds.begin(), mesh.materialIds.end(),
                    [&](uint32_t id) { return scene.materials[id].traits().transmits; }))
      continue;
    const size_t vertices = mesh.positions.size(), triangles = mesh.triangleCount();
    const uint32_t* idx = mesh.indices.data();
    // Union-find over vertex indices.
    std::vector<uint32_t> parent(vertices);
    for (uint32_t i = 0; i < parent.size(); ++i) parent[i] = i;
    const auto find = [&](uint32_t x) {
      while (parent[x] != x) x = parent[x] = parent[parent[x]];
      return x;
    };
    for (size_t t = 0; t < triangles; ++t)
      for (int k = 1; k < 3; ++k) parent[find(idx[3 * t + k])] = find(idx[3 * t]);
    // Edges (a, b), a <= b, grouped by a: start[a] .. start[a + 1] index the b's in `other`.
    std::vector<uint32_t> start(vertices + 1, 0);
    const auto edge = [&](size_t t, int k) {
      const uint32_t a = idx[3 * t + k], b = idx[3 * t + (k + 1) % 3];
      return std::pair<uint32_t, uint32_t>(std::min(a, b), std::max(a, b));
    };
    for (size_t t = 0; t < triangles; ++t)
      for (int k = 0; k < 3; ++k) ++start[edge(t, k).first + 1];
    for (size_t v = 0; v < vertices; ++v) start[v + 1] += start[v];
    std::vector<uint32_t> other(3 * triangles), fill(start.begin(), start.end() - 1);
    for (size_t t = 0; t < triangles; ++t)
      for (int k = 0; k < 3; ++k) {
        const auto [a, b] = edge(t, k);
        other[fill[a]++] = b;
      }
    std::vector<uint32_t>().swap(fill);
    // A component is open if one of its edges is used other than twice.
    std::vector<uint8_t> open(vertices, 0);
    for (size_t a = 0; a < vertices; ++a) {
      const auto first = other.begin() + start[a], last = other.begin() + start[a + 1];
      if (first == last) continue;
      std::sort(first, last);
      for (auto run = first; run != last;) {
        const auto end = std::find_if(run, last, [&](uint32_t b) { return b != *run; });
        if (end - run != 2) open[find(uint32_t(a))] = 1;
        run = end;
      }
    }
    std::vector<uint32_t>().swap(other);
    std::vector<uint32_t>().swap(start);
    // The triangles of each closed component, components by ascending root.
    std::vector<uint32_t> shellOf(vertices, UINT32_MAX);
    std::vector<uint32_t> roots;
    for (size_t t = 0; t < triangles; ++t) {
      const uint32_t root = find(idx[3 * t]);
      if (open[root] || shellOf[root] != UINT32_MAX) continue;
      shellOf[root] = 0;
      roots.push_back(root);
    }
    std::sort(roots.begin(), roots.end());
    const size_t first = shells.size();
    for (size_t k = 0; k < roots.size(); ++k) {
      shellOf[roots[k]] = uint32_t(first + k);
      shells.push_back(Shell{&mesh, {}});
    }
    for (size_t t = 0; t < triangles; ++t) {
      const uint32_t root = find(idx[3 * t]);
      if (!open[root]) shells[shellOf[root]].triangles.push_back(uint32_t(t));
    }
  }
  return shells;
}

// Point-in-shell by ray parity, in double, along a direction no scene axis shares.
bool inside(const Shell& shell, const DVec3& p) {
  const DVec3 d = glm::normalize(DVec3(0.5773, 0.5774, 0.5771));
  int crossings = 0;
  for (size_t t : shell.triangles) {
    const DVec3 v0(shell.mesh->positions[shell.mesh->indices[3 * t]]);
    const DVec3 e1 = DVec3(shell.mesh->positions[shell.mesh->indices[3 * t + 1]]) - v0;
    const DVec3 e2 = DVec3(shell.mesh->positions[shell.mesh->indices[3 * t + 2]]) - v0;
    const DVec3 h = glm::cross(d, e2);
    const double det = glm::dot(e1, h);
    if (std::abs(det) < 1e-300) continue;
    const DVec3 q = p - v0;
    const double u = glm::dot(q, h) / det;
    if (u < 0 || u > 1) continue;
    const DVec3 r = glm::cross(q, e1);
    const double v = glm::dot(d, r) / det;
    if (v < 0 || u + v > 1) continue;
    if (glm::dot(e2, r) / det > 0) ++crossings;
  }
  return crossings % 2 == 1;
}

// True if every triangle of material `id` lies inside a closed shell that the camera is outside
// of: camera paths can never enter a watertight shell, so nothing there can reach the image.
bool sealedAway(const Scene& scene, const std::vector<Shell>& shells, uint32_t id, const Vec3& camera) {
  // (Instances are not searched: a material an instance uses counts as reachable.)
  for (const TriangleMesh& mesh : scene.prototypes)
    if (std::count(mesh.materialIds.begin(), mesh.materialIds.end(), id)) return false;
  std::vector<bool> holdsCamera(shells.size());
  for (size_t k = 0; k < shells.size(); ++k) holdsCamera[k] = inside(shells[k], DVec3(camera));
  bool any = false;
  for (const auto& mesh : scene.meshes)
    for (size_t t = 0; t < mesh.triangleCount(); ++t) {
      if (mesh.materialIds[t] != id) continue;
      any = true;
      bool sealed = false;
      for (const Shell& shell : shells) {
        if (shell.mesh == &mesh || holdsCamera[size_t(&shell - shells.data())]) continue;
        bool all = true;
        for (int k = 0; k < 3 && all; ++k) all = inside(shell, DVec3(mesh.positions[mesh.indices[3 * t + k]]));
        if (all) {
          sealed = true;
          break;
        }
      }
      if (!sealed) return false;
    }
  return any;
}

// Signed volume of a closed shell (six times it): negative where its triangles face inwards.
double signedVolume(const Shell& shell) {
  double v = 0.0;
  for (size_t t : shell.triangles) {
    const auto& p = shell.mesh->positions;
    const uint32_t* i = &shell.mesh->indices[3 * t];
    v += glm::dot(DVec3(p[i[0]]), glm::cross(DVec3(p[i[1]]), DVec3(p[i[2]])));
  }
  return v;
}

// Emitters that can emit nothing into the scene: for each material, why (empty: it can).
struct UselessLights {
  std::vector<std::string> reason;
};

// A one-sided emitting triangle emits into the half-space in front of it; it lights nothing if no
// surface vertex and not the camera lies there. A triangle of a closed mesh wound inwards emits
// only into that mesh's inside, so its own vertices (in front of it) do not count: it lights
// something only if the camera or another surface's vertex is inside. A material is useless if
// every one of its triangles is.
UselessLights findUselessLights(const Scene& scene, const std::vector<Shell>& shells, const Vec3& camera) {
  UselessLights out;
  out.reason.assign(scene.materials.size(), "");
  if (std::none_of(scene.materials.begin(), scene.materials.end(), [](const Material& m) { return m.isEmissive(); }))
    return out;  // no emitter: nothing to decide
  // Inward shells and, for each, whether something lies inside: per mesh and triangle, -1 for a
  // triangle of no inward emitting shell, else 1 if something lies inside its shell, 0 if not.
  // Each instance's box as placed stands for its surface, conservatively.
  const std::vector<std::pair<DVec3, DVec3>> boxes = instanceBoxes(scene);
  std::vector<std::vector<int8_t>> inwardTriangle(scene.meshes.size());
  for (const Shell& shell : shells) {
    bool emits = false;
    for (size_t t : shell.triangles) emits |= scene.materials[shell.mesh->materialIds[t]].isEmissive();
    if (!emits || !(signedVolume(shell) < 0.0)) continue;
    std::vector<bool> own(shell.mesh->positions.size(), false);
    DVec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    for (size_t t : shell.triangles)
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = shell.mesh->indices[3 * t + k];
        own[v] = true;
        lo = glm::min(lo, DVec3(shell.mesh->positions[v]));
        hi = glm::max(hi, DVec3(shell.mesh->positions[v]));
      }
    const auto within = [&](const Vec3& p) {
      const DVec3 d(p);
      return glm::all(glm::greaterThan(d, lo)) && glm::all(glm::lessThan(d, hi)) && inside(shell, d);
    };
    bool occupied = within(camera);
    for (const auto& mesh : scene.meshes)
      for (uint32_t v = 0; v < mesh.positions.size() && !occupied; ++v)
        if (&mesh != shell.mesh || !own[v]) occupied = within(mesh.positions[v]);
    // An instance counts as inside if its box meets the shell's (conservatively: the light is kept).
    for (const auto& [a, b] : boxes)
      occupied |= glm::all(glm::lessThanEqual(a, hi)) && glm::all(glm::lessThanEqual(lo, b));
    std::vector<int8_t>& inMesh = inwardTriangle[size_t(shell.mesh - scene.meshes.data())];
    if (inMesh.empty()) inMesh.assign(shell.mesh->triangleCount(), -1);
    for (size_t t : shell.triangles) inMesh[t] = occupied ? 1 : 0;
  }
  std::vector<int> useful(scene.materials.size(), 0), inward(scene.materials.size(), 0);
  // Whether the camera or any vertex of the scene lies in front of the plane through a with normal n.
  const auto anyInFront = [&](const Vec3& a, const DVec3& n) {
    if (glm::dot(DVec3(camera) - DVec3(a), n) > 0.0) return true;
    for (const auto& mesh : scene.meshes)
      for (const Vec3& p : mesh.positions)
        if (glm::dot(DVec3(p) - DVec3(a), n) > 0.0) return true;
    // An instance's box has a corner in front if any point of the instance is.
    for (const auto& [lo, hi] : boxes)
      for (int c = 0; c < 8; ++c)
        if (glm::dot(boxCorner(lo, hi, c) - DVec3(a), n) > 0.0) return true;
    return false;
  };
  for (const auto& mesh : scene.meshes) {
    const std::vector<int8_t>& inMesh = inwardTriangle[size_t(&mesh - scene.meshes.data())];
    for (size_t t = 0; t < mesh.triangleCount(); ++t) {
      const uint32_t id = mesh.materialIds[t];
      const Material& m = scene.materials[id];
      if (!m.isEmissive() || useful[id]) continue;
      if (m.twoSidedEmission) {
        useful[id] = 1;
        continue;
      }
      if (!inMesh.empty() && inMesh[t] >= 0) {
        useful[id] = inMesh[t];
        inward[id] = 1;
        continue;
      }
      const Vec3& a = mesh.positions[mesh.indices[3 * t]];
      const DVec3 n =
          triangleCross(a, mesh.positions[mesh.indices[3 * t + 1]], mesh.positions[mesh.indices[3 * t + 2]]);
      if (anyInFront(a, n)) useful[id] = 1;
    }
  }
  for (size_t m = 0; m < scene.materials.size(); ++m)
    if (scene.materials[m].isEmissive() && !useful[m])
      out.reason[m] = inward[m] ? "faces only into the closed mesh it lies on, where neither the camera nor any other "
                                  "surface is"
                                : "faces away from every surface and the camera";
  return out;
}

// How a warning names an emitter: `light "lamp"` for a `lights` quad (its material is named after
// the entry), else `emissive material "glow" (shape "ball")`.
std::string emitterName(const Scene& scene, uint32_t id) {
  std::vector<std::string> shapes;
  for (const auto& mesh : scene.meshes)
    for (uint32_t m : mesh.materialIds)
      if (m == id) {
        shapes.push_back(mesh.name);
        break;
      }
  const std::string& name = scene.materials[id].name;
  if (name.rfind("lights[", 0) == 0 && shapes.size() == 1) return "light \"" + shapes[0] + "\"";
  std::string out = "emissive material \"" + name + "\"";
  for (size_t k = 0; k < shapes.size(); ++k) out += (k ? ", \"" : " (shape \"") + shapes[k] + "\"";
  return shapes.empty() ? out : out + ")";
}

}  // namespace

double maxBlurInCells(const Scene& scene, const ThinLensCamera& camera) {
  if (camera.isPinhole()) return 0.0;
  const ThinLensParams& p = camera.params();
  const double f = p.focalLength, s2 = camera.imageDistance(), r = camera.lensRadius() * camera.aperture().extent();
  const double cell = std::min(p.sensorWidth / camera.width(), p.sensorHeight / camera.height());
  // Depth range of the scene along the optical axis (bounding box corners).
  Vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (const auto& mesh : scene.meshes)
    for (const Vec3& v : mesh.positions) {
      lo = glm::min(lo, v);
      hi = glm::max(hi, v);
    }
  for (const auto& [a, b] : instanceBoxes(scene)) lo = glm::min(lo, Vec3(a)), hi = glm::max(hi, Vec3(b));
  double nearest = std::numeric_limits<double>::max(), farthest = 0.0;
  for (int c = 0; c < 8; ++c) {
    const Vec3 corner = boxCorner(lo, hi, c);
    const double d = glm::dot(corner - p.position, camera.forward());
    nearest = std::min(nearest, d);
    farthest = std::max(farthest, d);
  }
  // A point at distance D focuses at S2' = f D / (D - f); on the sensor at S2 its blur circle has
  // diameter 2R |S2' - S2| / S2'. Points at or inside f (or behind the lens) blur without bound.
  const auto blur = [&](double d) {
    if (d <= f * (1 + 1e-9)) return std::numeric_limits<double>::infinity();
    const double s2p = f * d / (d - f);
    return 2.0 * r * std::abs(s2p - s2) / s2p / cell;
  };
  if (farthest <= 0.0) return 0.0;  // nothing in front of the lens
  return std::max(blur(std::max(nearest, f * 1.000001)), blur(farthest));
}

EffectSet EffectSet::all(const Scene& scene) {
  EffectSet e;
  e.lightUseful.assign(scene.materials.size(), true);
  e.media = scene.medium != nullptr;
  for (const Material& m : scene.materials) {
    e.media |= m.interior != nullptr || m.exterior != nullptr || m.passesThrough();
    e.thinWalls |= m.isThinWall();
  }
  return e;
}

namespace {

// What the steps below share: the scene, its camera, and what the first step finds out about
// its materials (which ones a camera path can meet, the closed shells, sealed mirrors, whether a
// diffuse surface is met).
struct Analysis {
  const Scene& scene;
  const ThinLensCamera& camera;
  const RealLensCamera* real;
  std::vector<bool> used;     // by material: on a mesh or prototype, and not sealed away
  std::vector<Shell> shells;  // closed meshes (only where mirrors or emitters make them matter)
  int sealedMirrors = 0;
  bool diffuse = false;  // a Lambertian surface reflects
};

std::string listed(const std::set<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

// The materials a camera path can meet, and the closed shells that seal some of them away.
void findReachableMaterials(Analysis& a) {
  const Scene& scene = a.scene;
  std::vector<bool>& used = a.used;
  used.assign(scene.materials.size(), false);
  for (const auto& mesh : scene.meshes)
    for (uint32_t id : mesh.materialIds) used[id] = true;
  for (const auto& mesh : scene.prototypes)  // (each drawn by at least one instance)
    for (uint32_t id : mesh.materialIds) used[id] = true;
  // A mirror sealed inside a closed shell the camera is outside of can never be reached. The
  // shells matter only to mirrors and emitters: a scene with neither is not searched for them.
  bool shellsMatter = false;
  for (size_t m = 0; m < scene.materials.size(); ++m)
    shellsMatter |= (used[m] && scene.materials[m].isSpecular()) || scene.materials[m].isEmissive();
  if (shellsMatter) a.shells = closedShells(scene);
  for (size_t m = 0; m < scene.materials.size(); ++m)
    if (used[m] && scene.materials[m].isSpecular() && !a.shells.empty() &&
        sealedAway(scene, a.shells, uint32_t(m), a.camera.params().position)) {
      used[m] = false;
      ++a.sealedMirrors;
    }
}

// A real lens, a pinhole or a thin lens with its blur over the scene's depth.
void decideCamera(Analysis& a, EffectSet& e) {
  const Scene& scene = a.scene;
  const ThinLensCamera& camera = a.camera;
  const RealLensCamera* real = a.real;
  std::ostringstream why;
  // A real lens: every camera ray through its surfaces (camera/real_lens_camera.h); depth of
  // field, aberrations, vignetting and distortion are the lens's own.
  if (scene.realLens) {
    const LensSystem& lens = *scene.realLens->lens;
    e.depthOfField = true;
    why << scene.realLens->name << ": " << lens.surfaces().size() << " surfaces, f/" << std::setprecision(3)
        << lens.paraxial().fNumber << ", every camera ray traced through them";
    if (real) why << "; " << std::setprecision(2) << 100.0 * real->passingFraction(16, 4) << " % of them get through";
    e.decisions.push_back({"real lens", true, why.str()});
    why.str("");
    // Spectral camera samples (camera/spectral_response.h; the renderer asks the lens the same).
    if (lens.disperses())
      e.decisions.push_back({"spectral", true,
                             scene.realLens->name + " disperses (Abbe numbers): each camera sample "
                                                    "traced at its own wavelength, 400-700 nm in three bands"});
    else
      e.decisions.push_back(
          {"spectral", false, scene.realLens->name + " has no Abbe numbers: RGB, traced at the d line"});
  } else if (camera.isPinhole()) {
    e.depthOfField = false;
    e.decisions.push_back({"depth of field", false, "aperture closed (N = infinity)"});
  } else {
    const double blur = maxBlurInCells(scene, camera);
    e.depthOfField = blur >= kNegligibleBlurCells;
    if (e.depthOfField) {
      why << "blur up to " << blur << " sensor cells over the scene's depth";
    } else {
      // The scene asks for a lens, but at this resolution its blur stays below half a cell (a
      // preview size, or an aperture nearly closed): the picture is the pinhole's, and it says so.
      const int w = camera.width(), h = camera.height();
      why << "the scene's f/" << camera.params().fNumber << " lens is traced as a pinhole at " << w << "x" << h
          << " px: its blur is at most " << std::setprecision(2) << blur
          << " sensor cells over the scene's depth, below half a cell";
      // The blur in cells grows with the resolution (cells shrink): where it reaches half a cell.
      const double scale = blur > 0.0 ? kNegligibleBlurCells / blur : std::numeric_limits<double>::infinity();
      const double needW = std::ceil(w * scale), needH = std::ceil(h * scale);
      if (needW <= kMaxResolution && needH <= kMaxResolution)
        why << "; from " << int64_t(needW) << "x" << int64_t(needH) << " px on it is simulated";
      else
        why << " at every resolution up to " << kMaxResolution
            << "; open the aperture (a smaller f_number) for depth of field";
    }
    e.decisions.push_back({"depth of field", e.depthOfField, why.str(), !e.depthOfField});
  }
}

void decideDiffraction(Analysis& a, EffectSet& e) {
  const Scene& scene = a.scene;
  // Diffraction by the aperture (film/diffraction_psf.h): a post-process of the developed image.
  if (!scene.diffraction) {
    e.decisions.push_back({"diffraction", false, "not asked"});
  } else {
    const DiffractionOptics optics = diffractionOpticsOf(scene);
    const double airy = airyRadiusMm(550.0, optics.workingFNumber);
    const double pixels = airy / std::max(optics.pixelWidthMm, optics.pixelHeightMm);
    std::ostringstream text;
    text << std::setprecision(3) << "f/" << optics.workingFNumber << " working aperture, "
         << (scene.realLens  ? "round exit pupil"
             : optics.blades ? std::to_string(optics.blades) + " blades"
                             : "round aperture")
         << ", Airy radius " << airy * 1000.0 << " µm = " << pixels << " px at 550 nm";
    e.decisions.push_back({"diffraction", true, text.str()});
    if (pixels < 1.0) {
      text.str("");
      text << "diffraction: the Airy radius is " << std::setprecision(2) << pixels
           << " px, below a pixel: the image changes little; a larger f_number or more pixels show the pattern";
      e.sceneWarnings.push_back(text.str());
    }
  }
}

// Mirrors, glossy models, shading normals and textures.
void decideMaterials(Analysis& a, EffectSet& e) {
  const Scene& scene = a.scene;
  const std::vector<bool>& used = a.used;
  // The models the camera's paths can meet, by the effect each stands for (BsdfTraits::effect).
  std::set<std::string> deltaEffects, glossyEffects;
  for (size_t m = 0; m < scene.materials.size(); ++m) {
    const BsdfTraits& t = scene.materials[m].traits();
    if (!used[m] || !t.reflects) continue;
    if (t.lambertian)
      a.diffuse = true;
    else
      (t.delta ? deltaEffects : glossyEffects).insert(t.effect);
  }
  // Surfaces that vary across a triangle: smooth shading and textures (render/shading_point.h).
  size_t smoothMeshes = 0, texturedMaterials = 0;
  for (const auto& mesh : scene.meshes) smoothMeshes += mesh.normals.empty() ? 0 : 1;
  for (const auto& mesh : scene.prototypes) smoothMeshes += mesh.normals.empty() ? 0 : 1;
  for (size_t m = 0; m < scene.materials.size(); ++m) texturedMaterials += used[m] && scene.materials[m].varies();
  e.specular = !deltaEffects.empty();
  e.generalMaterials = e.specular || !glossyEffects.empty() || smoothMeshes > 0 || texturedMaterials > 0;
  e.decisions.push_back({"specular reflection", e.specular,
                         e.specular        ? listed(deltaEffects) + " in the scene"
                         : a.sealedMirrors ? "every mirror is sealed inside a closed mesh the camera is outside of"
                                           : "no mirror in the scene"});
  if (!glossyEffects.empty())
    e.decisions.push_back({"glossy materials", true, listed(glossyEffects) + " in the scene"});
  if (smoothMeshes > 0 || texturedMaterials > 0)
    e.decisions.push_back({"shading normals and textures", true,
                           std::to_string(smoothMeshes) + " mesh(es) with vertex normals, " +
                               std::to_string(texturedMaterials) + " textured material(s)"});
}

void decideMedia(Analysis& a, EffectSet& e) {
  const Scene& scene = a.scene;
  const std::vector<bool>& used = a.used;
  // Participating media (docs/media.md): the volume path tracer runs only where a path can be in
  // one; every other scene keeps the surface tracers, which have no medium code at all.
  {
    std::vector<std::string> where;
    if (scene.medium) where.push_back("\"" + scene.medium->name() + "\" fills the scene");
    for (size_t m = 0; m < scene.materials.size(); ++m)
      if (used[m] && scene.materials[m].interior)
        where.push_back("\"" + scene.materials[m].interior->name() + "\" inside \"" + scene.materials[m].name + "\"");
      else if (used[m] && scene.materials[m].exterior)
        where.push_back("\"" + scene.materials[m].exterior->name() + "\" around \"" + scene.materials[m].name + "\"");
    e.media = !where.empty();
    std::string reason;
    for (size_t k = 0; k < where.size() && k < 4; ++k) reason += (k ? "; " : "") + where[k];
    if (where.size() > 4) reason += "; ...";
    e.decisions.push_back({"participating media", e.media, e.media ? reason : "no medium in the scene"});
  }
}

void decideThinWalls(Analysis& a, EffectSet& e) {
  const Scene& scene = a.scene;
  const std::vector<bool>& used = a.used;
  // Thin walls: only a scene with one pays for shadow rays that cross surfaces.
  {
    std::set<std::string> walls;
    for (size_t m = 0; m < scene.materials.size(); ++m)
      if (used[m] && scene.materials[m].isThinWall()) walls.insert("\"" + scene.materials[m].name + "\"");
    e.thinWalls = !walls.empty();
    if (e.thinWalls)
      e.decisions.push_back(
          {"thin walls", true, listed(walls) + " let light straight through: shadow rays cross them with their tint"});
  }
}

// Which lights can light something, the lights that are not triangles, next-event estimation and
// what the camera sees.
void decideLights(Analysis& a, EffectSet& e) {
  const Scene& scene = a.scene;
  const std::vector<bool>& used = a.used;
  // Lights that can light something: an emitter is useful if the front of some triangle of its
  // material faces a surface or the camera (scene/effects.h).
  const UselessLights useless = findUselessLights(scene, a.shells, a.camera.params().position);
  int usefulLights = 0, uselessLights = 0;
  for (size_t m = 0; m < scene.materials.size(); ++m) {
    if (!used[m] || !scene.materials[m].isEmissive()) continue;
    if (useless.reason[m].empty()) {
      ++usefulLights;
      continue;
    }
    e.lightUseful[m] = false;
    ++uselessLights;
    e.sceneWarnings.push_back(emitterName(scene, uint32_t(m)) + " " + useless.reason[m] +
                              ": it emits nothing into the scene (flip its winding or set two_sided)");
  }
  if (uselessLights > 0)
    e.decisions.push_back(
        {"lights facing away", false,
         std::to_string(uselessLights) + " light(s) face away from every surface and the camera: not sampled"});
  // The lights that are not triangles (light/light_source.h), by type.
  int deltaLights = 0;
  bool seenLight = false;
  std::map<std::string, std::vector<const LightSource*>> byType;
  for (const auto& light : scene.lights) {
    byType[light->type()].push_back(light.get());
    deltaLights += light->isDelta() ? 1 : 0;
    seenLight |= light->isReachedByEscapedRays();
  }
  for (const auto& [type, lights] : byType) {
    std::ostringstream reason;
    if (type == "environment") {
      reason << lights[0]->describe();
    } else {
      reason << lights.size() << ": ";
      for (size_t k = 0; k < lights.size() && k < 3; ++k)
        reason << (k ? "; " : "") << "\"" << lights[k]->name() << "\" (" << lights[k]->describe() << ")";
      if (lights.size() > 3) reason << "; ...";
    }
    e.decisions.push_back({type == "environment" ? type : type + " lights", true, reason.str()});
  }
  usefulLights += int(scene.lights.size());
  if (scene.render.integrator == IntegratorKind::kNaive) {
    // Nothing but a light sample reaches a delta light: the naive estimator samples those alone.
    e.lightSampling = deltaLights > 0;
    e.decisions.push_back({"next-event estimation", e.lightSampling,
                           e.lightSampling ? "the naive estimator samples only its " + std::to_string(deltaLights) +
                                                 " delta light(s) (point, spot, sun without diameter), which no ray "
                                                 "can hit"
                                           : "the naive estimator was asked for"});
  } else if (usefulLights == 0) {
    e.lightSampling = false;
    e.decisions.push_back({"next-event estimation", false, "no light can light anything"});
  } else {
    e.decisions.push_back({"next-event estimation", true, std::to_string(usefulLights) + " light(s) to sample"});
  }
  bool seenEmitter = false;
  for (const auto& mesh : scene.meshes)
    for (uint32_t id : mesh.materialIds) seenEmitter |= mesh.visibleToCamera && scene.materials[id].isEmissive();
  e.decisions.push_back({"lights seen by the camera", seenEmitter || seenLight,
                         seenEmitter ? "an emitter is visible to camera rays"
                         : seenLight ? "camera rays that leave the scene see the light beyond it"
                                     : "every light is hidden from the camera"});
  if (!a.diffuse && !e.generalMaterials)
    e.decisions.push_back({"indirect light", false, "no surface reflects: only emitters are seen"});
}

// Equiangular sampling in media (render/volume_integrator.cpp): listed only for scenes with media.
void decideEquiangular(Analysis& a, EffectSet& e) {
  if (!e.media) return;
  const Scene& scene = a.scene;
  // The media it can serve: homogeneous and scattering, where shadow rays can leave (the scene's
  // medium, one inside an interface, one around a surface): RenderScene picks the same.
  std::set<std::string> media;
  const auto consider = [&](const Medium* m) {
    if (m && m->homogeneous() && m->scatters()) media.insert("\"" + m->name() + "\"");
  };
  consider(scene.medium.get());
  for (size_t m = 0; m < scene.materials.size(); ++m) {
    if (!a.used[m]) continue;
    const Material& mat = scene.materials[m];
    if (mat.passesThrough()) consider(mat.interior.get());
    consider(mat.exterior.get());
  }
  bool positioned = false;
  for (size_t m = 0; m < scene.materials.size(); ++m) {
    const Material& mat = scene.materials[m];
    positioned |= a.used[m] && mat.isEmissive() && e.lightUseful[m];
  }
  for (const auto& light : scene.lights) positioned |= light->position().has_value();
  std::string why;
  if (scene.render.mediumLightSampling == MediumLightSampling::kDistance)
    why = "render.medium_light_sampling is \"distance\"";
  else if (scene.render.integrator == IntegratorKind::kNaive || !e.lightSampling)
    why = "no light sampling";
  else if (media.empty())
    why = "no homogeneous scattering medium that shadow rays can leave (a grid is distance-sampled alone)";
  else if (!positioned)
    why = "no light at points (an emitting surface, a point or a spot light)";
  else if (e.lightTree && scene.render.mediumLightSampling == MediumLightSampling::kAuto)
    // Its light point is chosen by power, with no shading point to choose by: among the many
    // lights a tree serves, mostly lights that light nothing near the segment (docs/media.md).
    why =
        "a light tree chooses among the lights, and equiangular sampling's choice by power does not pay beside "
        "it (render.medium_light_sampling \"equiangular\" forces it)";
  e.equiangular = why.empty();
  if (e.equiangular)
    why = "in " + listed(media) +
          ", towards a point on a light, combined with free-flight sampling by MIS (Kulla & Fajardo 2012)";
  e.decisions.push_back({"equiangular sampling", e.equiangular, why});
}

void decideLightTree(Analysis& a, EffectSet& e) {
  const Scene& scene = a.scene;
  // The lights a tree would hold: the emitting triangles sampled and the lights at points.
  const bool deltaOnly = scene.render.integrator == IntegratorKind::kNaive;
  uint64_t triangles = 0, points = 0;
  for (const TriangleMesh& mesh : scene.meshes)
    for (uint32_t id : mesh.materialIds)
      triangles += !deltaOnly && a.used[id] && scene.materials[id].isEmissive() && e.lightUseful[id] ? 1 : 0;
  for (const auto& light : scene.lights) points += light->bounds() ? 1 : 0;
  const uint64_t lights = triangles + points;
  const LightTreeMode mode = scene.render.lightTree;
  std::ostringstream why;
  if (!e.lightSampling)
    why << "no light sampling";
  else if (mode == LightTreeMode::kOff)
    why << "render.light_tree is off";
  else if (lights == 0)
    why << "no light in the scene (only lights beyond it)";
  else if (mode == LightTreeMode::kAuto && lights <= kLightTreeAutoLights)
    why << lights << " light(s) in the scene, chosen by power (the tree from " << kLightTreeAutoLights + 1 << " on)";
  e.lightTree = why.str().empty();
  if (e.lightTree)
    why << "over " << triangles << " emitting triangle(s) and " << points
        << " point or spot light(s): each light sample chooses by the lights' bounds as seen from its point "
           "(Conty Estevez & Kulla 2018)";
  if (e.lightTree || mode != LightTreeMode::kAuto || lights > 8)
    e.decisions.push_back({"light tree", e.lightTree, why.str()});
}

void decideLightTracing(Analysis& a, EffectSet& e) {
  const Scene& scene = a.scene;
  const std::vector<bool>& used = a.used;
  // Light tracing (render/light_tracer.h): particles from the lights, connected to the thin lens at
  // every diffuse vertex, for the paths light -> mirror or glass -> ... -> diffuse -> camera.
  bool emittingTriangles = false, tracedDelta = false, tracedMirror = false, tracedDiffuse = false;
  for (size_t m = 0; m < scene.materials.size(); ++m) {
    if (!used[m]) continue;
    const Material& mat = scene.materials[m];
    emittingTriangles |= mat.isEmissive() && e.lightUseful[m];
    if (!mat.reflects() || !lightTraceable(mat)) continue;
    (mat.isSpecular() ? tracedDelta : tracedDiffuse) = true;
    tracedMirror |= mat.isSpecular() && !mat.traits().transmits;
  }
  // The lights whose caustics camera paths sample badly or not at all: a delta light (point, spot,
  // a sun without diameter) is reached by no ray, so light -> delta surface -> diffuse is black
  // without light paths; the environment and a sun with a diameter only by a scattered ray that
  // happens to leave the scene through the glass towards their bright part.
  std::set<std::string> deltaLights, farLights;
  for (const auto& light : scene.lights)
    (light->isDelta() ? deltaLights : farLights).insert(std::string(light->type()) + " \"" + light->name() + "\"");
  e.mirrorCaustics = emittingTriangles && tracedMirror && tracedDiffuse;
  const bool lightCaustics = tracedDelta && tracedDiffuse && !(deltaLights.empty() && farLights.empty());
  const RenderSettings& rs = scene.render;
  std::string ltWhy;
  if (rs.lightTracing == LightTracingMode::kOff)
    ltWhy = "render.light_tracing is off";
  else if (!(lightCaustics || (rs.lightTracing == LightTracingMode::kOn && emittingTriangles)))
    ltWhy = e.mirrorCaustics ? "" : "no mirror or smooth glass through which a diffuse surface sees a light";
  else if (e.media)
    ltWhy = "participating media: light paths are not traced through media (the volume path tracer samples the image)";
  else if (e.thinWalls)
    ltWhy = "thin walls: light paths are not connected through them (the volume path tracer samples the image)";
  else if (scene.realLens)
    ltWhy =
        "a real lens cannot be connected to: a path from a surface point to the sensor through its "
        "surfaces has no closed form (the path tracer alone samples the image)";
  else if (rs.integrator == IntegratorKind::kNaive)
    ltWhy = "the naive estimator was asked for";
  else if (rs.tileSize > 0)
    ltWhy = "tiled units render a region only; light paths splat over the whole frame";
  else if (rs.adaptive.enabled)
    ltWhy = "adaptive sampling gives blocks their own sample counts; light paths splat over the whole frame";
  // Emitting triangles emit particles only when asked: measured on cornell-seed (docs/performance.md,
  // "Light tracing for the 2013 report's caustic"), with binary weights their light paths cost more
  // time than the variance they remove.
  e.lightTracingTriangles = ltWhy.empty() && emittingTriangles && rs.lightTracing == LightTracingMode::kOn;
  if (ltWhy.empty() && !lightCaustics && !e.lightTracingTriangles)
    ltWhy =
        "mirror caustics of emitting surfaces, but light tracing with binary weights does not pay at equal time "
        "there (docs/performance.md); render.light_tracing \"on\" forces it";
  e.lightTracing = ltWhy.empty();
  if (e.lightTracing) {
    std::ostringstream why;
    why << rs.lightTracingRatio << " light path(s) per camera path from ";
    std::set<std::string> from = deltaLights;
    from.insert(farLights.begin(), farLights.end());
    if (e.lightTracingTriangles) from.insert("the emitting surfaces");
    why << listed(from) << ", aimed at the mirrors and glass they light, connected to the camera";
    if (!deltaLights.empty()) why << " (a delta light's caustics: no camera path reaches them)";
    ltWhy = why.str();
  }
  // A delta light's caustic through glass or a mirror is black without light paths: where they
  // cannot run, the picture differs from the scene's, which the render says as a warning.
  const bool deltaCausticLost =
      !e.lightTracing && lightCaustics && !deltaLights.empty() && rs.lightTracing != LightTracingMode::kOff;
  if (deltaCausticLost)
    ltWhy += "; the caustics of " + listed(deltaLights) + " through mirrors and glass are black without light paths";
  if (e.lightTracing || rs.lightTracing != LightTracingMode::kAuto || e.mirrorCaustics || lightCaustics)
    e.decisions.push_back({"light tracing", e.lightTracing, ltWhy, deltaCausticLost});
}

}  // namespace

int guidingTrainingStride(int width, int height) {
  const double pixels = double(width) * double(height);
  return std::max(1, int(std::ceil(std::sqrt(pixels / double(kGuidingTrainingPixels)))));
}

uint64_t guidingTrainingPaths(int width, int height) {
  const int stride = guidingTrainingStride(width, height);
  const uint64_t grid = uint64_t((width + stride - 1) / stride) * uint64_t((height + stride - 1) / stride);
  return grid * ((uint64_t(1) << kGuidingTrainingPasses) - 1);
}

namespace {

void decidePathGuiding(Analysis& a, EffectSet& e) {
  // Path guiding (render/path_guiding.h) serves the paths next-event estimation cannot sample: a
  // diffuse surface lit through a mirror or smooth glass. Elsewhere its training and its lookups
  // would cost time for nothing.
  const PathGuidingMode mode = a.scene.render.pathGuiding;
  std::string why;
  if (mode == PathGuidingMode::kOff)
    why = "render.path_guiding is off";
  else if (!a.diffuse)
    why = "no diffuse surface to guide";
  else if (e.media || e.thinWalls)
    why = "the volume path tracer is not guided";
  else if (mode == PathGuidingMode::kAuto && !e.specular)
    why = "no mirror or smooth glass through which a diffuse surface sees a light";
  else if (mode == PathGuidingMode::kAuto && e.lightTracing)
    why = "light paths carry the caustics";
  else if (mode == PathGuidingMode::kAuto && !e.mirrorCaustics)
    why =
        "measured not to pay at equal time through glass and metal (docs/performance.md, \"Path guiding\"); "
        "render.path_guiding \"on\" forces it";
  else if (mode == PathGuidingMode::kAuto)
    why =
        "a mirror shows an emitting surface: guided, cornell-seed reaches an equal relMSE 1.2x to 1.5x sooner but "
        "an equal relative RMSE, which target-error jobs stop on, 1.4x later (docs/performance.md, \"Path "
        "guiding\"); render.path_guiding \"on\" forces it";
  e.pathGuiding = why.empty();
  if (e.pathGuiding)
    why = std::string(e.mirrorCaustics ? "a diffuse surface sees an emitting surface through a mirror; " : "") +
          "training passes learn where the light on the diffuse surfaces comes from, and half of their directions "
          "are drawn from it";
  if (e.pathGuiding || mode != PathGuidingMode::kAuto || e.specular)
    e.decisions.push_back({"path guiding", e.pathGuiding, why});
}

// The decisions, in the order `lensfarm render` lists them; each step is one effect.
using EffectStep = void (*)(Analysis&, EffectSet&);
constexpr EffectStep kEffectSteps[] = {decideCamera,       decideDiffraction, decideMaterials, decideMedia,
                                       decideThinWalls,    decideLights,      decideLightTree, decideEquiangular,
                                       decideLightTracing, decidePathGuiding};

}  // namespace

EffectSet analyzeEffects(const Scene& scene, const Camera& camera) {
  EffectSet e = EffectSet::all(scene);
  Analysis a{scene, camera.paraxial(), dynamic_cast<const RealLensCamera*>(&camera), {}, {}};
  findReachableMaterials(a);
  for (const EffectStep step : kEffectSteps) step(a, e);
  return e;
}

bool lightTraceable(const Material& m) {
  if (m.textures()) return false;
  if (!m.reflects() || m.isLambertian()) return true;
  if (const auto* glass = dynamic_cast<const DielectricBsdf*>(m.bsdf()))
    return glass->smooth() && !m.traits().thinWall && !m.interior;
  return dynamic_cast<const MirrorBsdf*>(m.bsdf()) || dynamic_cast<const RippledMirrorBsdf*>(m.bsdf());
}

std::vector<std::string> EffectSet::warnings() const {
  std::vector<std::string> out = sceneWarnings;
  for (const auto& d : decisions)
    if (d.changesScene) out.push_back(d.effect + " is not simulated: " + d.reason);
  return out;
}

std::string EffectSet::summary() const {
  std::string out;
  for (const auto& d : decisions)
    out += (out.empty() ? "" : "; ") + d.effect + ": " + (d.simulated ? "on" : "off") + " (" + d.reason + ")";
  return out;
}

}  // namespace lensfarm
