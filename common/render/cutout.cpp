#include "common/render/cutout.h"

namespace lensfarm {

bool meshCutsOut(const Scene& scene, const TriangleMesh& mesh) {
  for (const uint32_t m : mesh.materialIds) {
    const MaterialTextures* textures = scene.materials[m].textures();
    if (textures && textures->cutsOut()) return true;
  }
  return false;
}

bool cutsAway(const Scene& scene, const TriangleMesh& mesh, unsigned triangle, float b1, float b2) {
  const Material& material = scene.materials[mesh.materialIds[triangle]];
  const MaterialTextures* textures = material.textures();
  if (!textures || !textures->cutsOut()) return false;
  Vec2 uv[2] = {Vec2(0.0f), Vec2(0.0f)};
  for (int set = 0; set < 2; ++set)
    if (!mesh.uv[set].empty()) uv[set] = mesh.interpolate(mesh.uv[set], triangle, b1, b2);
  const float cutoff = textures->alphaMode == AlphaMode::kBlend ? 0.5f : textures->alphaCutoff;
  return material.alphaAt(uv) < cutoff;
}

}  // namespace lensfarm
