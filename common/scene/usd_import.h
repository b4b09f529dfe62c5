#pragma once
// USD scenes (.usda text, and .usdz packages of it) read into an ImportedModel
// (scene/imported_model.h) from the composed stage (scene/usd_stage.h), following the schemas of
// Pixar's USD (openusd.org, "Schemas": UsdGeom, UsdShade's UsdPreviewSurface, UsdLux):
//   * Mesh: points, faceVertexCounts and faceVertexIndices (polygons fanned into triangles),
//     orientation, normals and primvars:normals, primvars:st (vertex or faceVarying, indexed or
//     not), material:binding on the mesh or an ancestor, and GeomSubsets of familyName
//     materialBind; primvars:displayColor where no material is bound;
//   * Xformable: xformOpOrder of translate, scale, rotateX/Y/Z, rotateXYZ and its orders, orient,
//     transform, with !invert! and !resetXformStack!; the stage's upAxis Z turned to Y up;
//   * instanceable prims that reference a prototype: one mesh, drawn as instances;
//   * Material -> UsdPreviewSurface (diffuseColor, emissiveColor, metallic, roughness, opacity,
//     opacityThreshold, ior, normal) with UsdUVTexture files (wrap modes, colour spaces) read
//     through the model's reader, as the `principled` material of glTF's model;
//   * Camera: focalLength and apertures (in tenths of a scene unit), fStop and focusDistance as a
//     thin lens whose view at the focal plane is the camera's; fStop 0 a pinhole;
//   * RectLight and DiskLight as quad lights, SphereLight as a point (or, with a cone, a spot)
//     light, DistantLight as a directional light with its angle; intensity x 2^exposure x colour,
//     `normalize` dividing by the area.
// What is mapped approximately or not rendered (subdivision, other gprims, variants, DomeLight,
// ...) becomes a note naming the prim. Errors name the file and the prim path:
//   "scene.usda: </World/Box>: faceVertexIndices[7] = 12 is not a point (8 points)".
#include <string>

#include "common/scene/imported_model.h"

namespace lensfarm {

// `bytes` is the .usda (or .usdz) file's content, `shown` its path for messages; the files it refers
// to are read through `read`, relative to it.
ImportedModel importUsd(std::string bytes, const std::string& shown, const ModelFileReader& read);

}  // namespace lensfarm
