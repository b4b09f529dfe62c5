// The lens library (scenes/lenses/*.dat, scenes/README.md "Lenses"): every prescription there
// parses, states its focal length and source in its header, and has the focal length and
// f-number it states. The expected values come from the file's own numbers, multiplied out here
// as 2x2 ray-transfer matrices (Hecht, Optics, 5th ed., §6.2) independently of LensSystem. A new
// lens dropped into the folder is checked without touching this file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "common/camera/lens_system.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

std::vector<fs::path> lensFiles() {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(test::scenesDir() / "lenses"))
    if (e.is_regular_file() && e.path().extension() == ".dat") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

// The machine-readable header lines (scenes/README.md "Lenses"):
//   # focal length: 50 mm      exactly once
//   # f-number: 2              at most once; free text may follow the number
//   # source: ...              at least once
struct Header {
  int focalLengthLines = 0, fNumberLines = 0, sourceLines = 0;
  double focalLength = 0.0;
  std::optional<double> fNumber;
};

Header readHeader(const std::string& text) {
  static const std::regex focal(R"(^#\s*focal length:\s*([0-9]+(\.[0-9]+)?)\s*mm\s*$)");
  static const std::regex fNumber(R"(^#\s*f-number:\s*([0-9]+(\.[0-9]+)?)(\s.*)?$)");
  static const std::regex source(R"(^#\s*source:\s*\S.*$)");
  Header h;
  std::istringstream lines(text);
  std::string line;
  std::smatch m;
  while (std::getline(lines, line)) {
    if (std::regex_match(line, m, focal)) {
      ++h.focalLengthLines;
      h.focalLength = std::stod(m[1].str());
    } else if (std::regex_match(line, m, fNumber)) {
      ++h.fNumberLines;
      h.fNumber = std::stod(m[1].str());
    } else if (std::regex_match(line, source)) {
      ++h.sourceLines;
    }
  }
  return h;
}

// The file's surface rows as written ("radius thickness index aperture [abbe]"), read here
// without LensSystem.
struct Row {
  double radius, thickness, index, aperture;
};

std::vector<Row> readRows(const std::string& text) {
  std::vector<Row> rows;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    line = line.substr(0, line.find('#'));
    std::istringstream in(line);
    Row r{};
    if (in >> r.radius >> r.thickness >> r.index >> r.aperture) rows.push_back(r);
  }
  return rows;
}

// 2x2 matrices on (height y, reduced angle n u).
struct Mat2 {
  double a, b, c, d;
};
Mat2 operator*(const Mat2& l, const Mat2& r) {
  return {l.a * r.a + l.b * r.c, l.a * r.b + l.b * r.d, l.c * r.a + l.d * r.c, l.c * r.b + l.d * r.d};
}

// The system matrix from the front vertex to the last vertex: refraction [[1, 0], [-P, 1]] with
// P = (n' - n) / R at each surface, transfer [[1, t / n'], [0, 1]] between surfaces. pbrt writes
// index 0 for the air after the stop.
Mat2 systemMatrix(const std::vector<Row>& rows) {
  Mat2 m{1.0, 0.0, 0.0, 1.0};
  double n = 1.0;
  for (size_t k = 0; k < rows.size(); ++k) {
    const double n2 = rows[k].index == 0.0 ? 1.0 : rows[k].index;
    const double power = rows[k].radius == 0.0 ? 0.0 : (n2 - n) / rows[k].radius;
    m = Mat2{1.0, 0.0, -power, 1.0} * m;
    if (k + 1 < rows.size()) m = Mat2{1.0, rows[k].thickness / n2, 0.0, 1.0} * m;
    n = n2;
  }
  return m;
}

TEST(LensLibrary, ShipsLenses) {
  const std::vector<fs::path> files = lensFiles();
  EXPECT_GE(files.size(), 4u) << "a double-Gauss, a wide-angle, a telephoto and a fisheye";
}

TEST(LensLibrary, EveryLensStatesItsFocalLengthAndSourceInItsHeaderAndName) {
  static const std::regex name(R"(^[a-z0-9-]+\.([0-9]+(\.[0-9]+)?)mm\.dat$)");
  for (const fs::path& file : lensFiles()) {
    SCOPED_TRACE(file.filename().string());
    const Header h = readHeader(test::readFile(file));
    EXPECT_EQ(h.focalLengthLines, 1) << "one \"# focal length: F mm\" line";
    EXPECT_LE(h.fNumberLines, 1) << "at most one \"# f-number: N\" line";
    EXPECT_GE(h.sourceLines, 1) << "a \"# source: ...\" line";
    EXPECT_GT(h.focalLength, 0.0);
    if (h.fNumber) {
      EXPECT_GT(*h.fNumber, 0.0);
    }
    std::smatch m;
    const std::string filename = file.filename().string();
    ASSERT_TRUE(std::regex_match(filename, m, name)) << "named <kind>.<focal length>mm.dat";
    EXPECT_DOUBLE_EQ(std::stod(m[1].str()), h.focalLength) << "the name's focal length is the header's";
  }
}

TEST(LensLibrary, EveryLensHasTheFocalLengthAndFNumberItStates) {
  for (const fs::path& file : lensFiles()) {
    SCOPED_TRACE(file.filename().string());
    const std::string text = test::readFile(file);
    const LensSystem lens = LensSystem::parsePbrt(text, file.filename().string());
    const Header h = readHeader(text);
    const LensSystem::Paraxial p = lens.paraxial();
    EXPECT_NEAR(p.efl, h.focalLength, 0.005 * h.focalLength) << "paraxial EFL within 0.5 % of the stated focal length";
    if (h.fNumber) {
      EXPECT_NEAR(p.fNumber, *h.fNumber, 0.05 * *h.fNumber) << "f-number within 5 % of the stated one";
    }
  }
}

TEST(LensLibrary, EveryLensMatchesAnIndependentRayTransferMatrix) {
  for (const fs::path& file : lensFiles()) {
    SCOPED_TRACE(file.filename().string());
    const std::string text = test::readFile(file);
    const std::vector<Row> rows = readRows(text);
    const LensSystem lens = LensSystem::parsePbrt(text, file.filename().string());
    ASSERT_EQ(rows.size(), lens.surfaces().size());
    const Mat2 m = systemMatrix(rows);
    EXPECT_NEAR(m.a * m.d - m.b * m.c, 1.0, 1e-12) << "reduced-angle matrices have determinant 1";
    const double efl = -1.0 / m.c, bfl = -m.a / m.c;
    const LensSystem::Paraxial p = lens.paraxial();
    EXPECT_NEAR(p.efl, efl, 1e-9 * std::abs(efl));
    EXPECT_NEAR(p.bfl, bfl, 1e-9 * std::abs(efl));
  }
}

TEST(LensLibrary, EveryLensPassesRaysNearTheAxisToItsFocus) {
  for (const fs::path& file : lensFiles()) {
    SCOPED_TRACE(file.filename().string());
    const LensSystem lens = LensSystem::parsePbrt(test::readFile(file), file.filename().string());
    const LensSystem::Paraxial p = lens.paraxial();
    // A ray parallel to the axis 1 um off it, from 10 mm in front of the front vertex: it passes
    // every clear aperture and crosses the axis at the paraxial rear focus.
    const std::optional<LensRay> out = lens.traceFromObjectSide({DVec3(0.0, 1e-3, -10.0), DVec3(0.0, 0.0, 1.0)});
    ASSERT_TRUE(out) << "vignetted on the axis";
    ASSERT_LT(out->direction.y, 0.0) << "a positive lens bends it toward the axis";
    const double crossing = out->origin.z - out->origin.y / out->direction.y * out->direction.z;
    EXPECT_NEAR(crossing - lens.totalTrack(), p.bfl, 1e-4 * p.efl);
    // The axial beam fills the entrance pupil: rays across 90 % of its radius pass too (no lens
    // rim cuts the axial beam inside the pupil).
    for (double fraction : {0.5, 0.9}) {
      const double height = fraction * p.entrancePupilDiameter / 2.0;
      EXPECT_TRUE(lens.traceFromObjectSide({DVec3(0.0, height, -10.0), DVec3(0.0, 0.0, 1.0)}))
          << "vignetted at " << fraction << " of the entrance pupil's radius";
    }
  }
}

}  // namespace
}  // namespace lensfarm
