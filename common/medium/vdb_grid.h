#pragma once
// OpenVDB grids (Museth 2013, "VDB: High-resolution sparse volumes with dynamic topology"; the
// format smoke and clouds come in from Houdini, Blender and EmberGen) read into the dense form
// GridMedium traces (medium/grid_medium.h): the active voxels' bounding box, densities at voxel
// centres, x fastest, inactive voxels at the grid's background value.
//
// World space: a VDB's index-to-world transform places voxel (i, j, k)'s centre at
// transform(i, j, k); the box is the bounding box of the active voxels grown by half a voxel, in
// the scene's world coordinates. Only axis-aligned transforms (scale and translation, the ones
// exporters write) are read; a rotated or perspective (frustum) grid is refused.
//
// OpenVDB is loaded only when a scene names a .vdb: the reader is the module liblensfarm_openvdb.so
// (medium/openvdb/openvdb_module.cpp), found next to the binaries as `cmake --install` lays them
// out (<prefix>/<libdir>/lensfarm/) or in the build tree. Linked into every process, OpenVDB's
// symbol bindings cost each start 60 ms (docs/performance.md).
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "common/math/vec.h"

namespace lensfarm {

struct DenseGrid {
  DVec3 lo{0.0}, hi{0.0};  // world space
  glm::ivec3 resolution{0};
  std::vector<float> density;
};

// The most voxels a grid may hold once dense (2^27 = 134M voxels, 512 MiB of floats in every
// process that renders it).
inline constexpr size_t kMaxGridVoxels = size_t(1) << 27;

// Reads the float grid `gridName` of the .vdb file whose bytes are `content`. Errors are one
// InputError(file, field + ": ...") naming the file as `shown`: not an OpenVDB file, no grid of
// that name (the names it has are listed), a grid that is not of floats, no active voxels, a
// transform that is not axis-aligned, more than kMaxGridVoxels voxels.
//
// A missing module is the same InputError, saying where it was looked for.
DenseGrid readVdbGrid(const std::string& content, const std::string& gridName, const std::string& shown,
                      const std::string& file, const std::string& field);

// The module's entry point: fills `out`, or returns false with `error` saying why (the text after
// "field: " in readVdbGrid's error).
using VdbReadFunction = bool (*)(const std::string& content, const std::string& gridName, const std::string& shown,
                                 DenseGrid& out, std::string& error);
inline constexpr const char* kVdbReadSymbol = "lensfarm_read_vdb_grid";

}  // namespace lensfarm
