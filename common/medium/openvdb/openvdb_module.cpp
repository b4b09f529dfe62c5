// The OpenVDB reader, a module of its own (liblensfarm_openvdb.so) that the renderer loads on the
// first .vdb a scene names (medium/vdb_grid.cpp): OpenVDB's 57,000 symbol bindings cost every
// process 60 ms at start, and a scene without a VDB pays nothing for it.
#include <openvdb/openvdb.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
#include <sstream>

#include "common/medium/vdb_grid.h"

namespace lensfarm {

namespace {

// io::File reads from a path: the asset's bytes (already hashed and shipped with the scene) go
// to a private temporary file, removed whatever happens.
class TemporaryCopy {
 public:
  explicit TemporaryCopy(const std::string& content) {
    static std::atomic<uint64_t> counter{0};
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() /
            ("lensfarm-vdb-" + std::to_string(rd()) + "-" + std::to_string(counter++) + ".vdb");
    std::ofstream out(path_, std::ios::binary | std::ios::trunc);
    out.write(content.data(), std::streamsize(content.size()));
    if (!out) throw std::runtime_error("cannot write a temporary copy in " + path_.parent_path().string());
  }
  ~TemporaryCopy() {
    std::error_code ignored;
    std::filesystem::remove(path_, ignored);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// Why a grid cannot be read (VdbReadFunction's error).
struct VdbError {
  std::string what;
};

DenseGrid readGrid(const std::string& content, const std::string& gridName, const std::string& shown) {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
  const auto fail = [&](const std::string& what) { throw VdbError{what}; };

  openvdb::GridBase::Ptr base;
  std::string names;
  try {
    const TemporaryCopy copy(content);
    openvdb::io::File vdb(copy.path().string());
    vdb.open(false);  // read everything now: the copy is removed on return
    for (auto it = vdb.beginName(); it != vdb.endName(); ++it)
      names += (names.empty() ? "\"" : ", \"") + it.gridName() + "\"";
    if (vdb.hasGrid(gridName)) base = vdb.readGrid(gridName);
    vdb.close();
  } catch (const std::exception& e) {
    fail("cannot read \"" + shown + "\" as an OpenVDB file (" + e.what() + ")");
  }
  if (!base)
    fail("\"" + shown + "\" has no grid \"" + gridName + "\" (it has " + (names.empty() ? "none" : names) + ")");
  const openvdb::FloatGrid::Ptr grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
  if (!grid)
    fail("grid \"" + gridName + "\" of \"" + shown + "\" holds " + base->valueType() + ", not float densities");

  const openvdb::math::Transform& xf = grid->transform();
  if (!xf.isLinear() || !xf.baseMap()->getAffineMap()->isScaleTranslate())  // scale and translation only
    fail("grid \"" + gridName + "\" of \"" + shown + "\" has a " + xf.mapType() +
         " transform; only axis-aligned grids (scale and translation) are read");
  const openvdb::CoordBBox box = grid->evalActiveVoxelBoundingBox();
  if (box.empty()) fail("grid \"" + gridName + "\" of \"" + shown + "\" has no active voxels");
  const openvdb::Coord dim = box.dim();
  const size_t voxels = size_t(dim.x()) * size_t(dim.y()) * size_t(dim.z());
  if (voxels > kMaxGridVoxels)
    fail("grid \"" + gridName + "\" of \"" + shown + "\" spans " + std::to_string(dim.x()) + " x " +
         std::to_string(dim.y()) + " x " + std::to_string(dim.z()) + " voxels, more than " +
         std::to_string(kMaxGridVoxels) + " once dense");

  DenseGrid out;
  out.resolution = glm::ivec3(dim.x(), dim.y(), dim.z());
  const openvdb::Vec3d a = xf.indexToWorld(box.min().asVec3d() - openvdb::Vec3d(0.5));
  const openvdb::Vec3d b = xf.indexToWorld(box.max().asVec3d() + openvdb::Vec3d(0.5));
  out.lo = DVec3(std::min(a.x(), b.x()), std::min(a.y(), b.y()), std::min(a.z(), b.z()));
  out.hi = DVec3(std::max(a.x(), b.x()), std::max(a.y(), b.y()), std::max(a.z(), b.z()));
  // A negative scale mirrors an axis: the dense array then runs from hi to lo along it.
  const openvdb::Vec3d step = xf.indexToWorld(openvdb::Vec3d(1.0)) - xf.indexToWorld(openvdb::Vec3d(0.0));
  out.density.assign(voxels, 0.0f);
  const openvdb::FloatGrid::ConstAccessor access = grid->getConstAccessor();
  for (int z = 0; z < dim.z(); ++z)
    for (int y = 0; y < dim.y(); ++y)
      for (int x = 0; x < dim.x(); ++x) {
        const int i = step.x() < 0 ? dim.x() - 1 - x : x, j = step.y() < 0 ? dim.y() - 1 - y : y,
                  k = step.z() < 0 ? dim.z() - 1 - z : z;
        out.density[(size_t(z) * size_t(dim.y()) + size_t(y)) * size_t(dim.x()) + size_t(x)] =
            access.getValue(box.min() + openvdb::Coord(i, j, k));
      }
  return out;
}

}  // namespace
}  // namespace lensfarm

// The module's one entry point (kVdbReadSymbol, a VdbReadFunction).
extern "C" bool lensfarm_read_vdb_grid(const std::string& content, const std::string& gridName,
                                       const std::string& shown, lensfarm::DenseGrid& out, std::string& error) {
  try {
    out = lensfarm::readGrid(content, gridName, shown);
    return true;
  } catch (const lensfarm::VdbError& e) {
    error = e.what;
  } catch (const std::exception& e) {
    error = "cannot read \"" + shown + "\" (" + e.what() + ")";
  }
  return false;
}
