// Spherical triangles (math/spherical_triangle.h): the solid angle against closed forms, at any
// scale and distance from the origin; directions sampled uniformly over it (chi-square against
// the density 1 / Omega, and the exact share of each sub-triangle); every sample inside the
// triangle; irradiance estimated with it against Lambert's formula for a polygon.
#include "common/math/spherical_triangle.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include "tests/support/chi2.h"
#include "tests/support/uniform_rng.h"

namespace lensfarm {
namespace {

constexpr double kPi = std::numbers::pi;

// Where the ray from p along w meets the plane of (v0, v1, v2), its barycentrics (b1, b2), in double.
std::optional<std::array<double, 2>> barycentricsAlong(const DVec3& p, const DVec3& w, const DVec3& v0, const DVec3& v1,
                                                       const DVec3& v2) {
  const DVec3 e1 = v1 - v0, e2 = v2 - v0, n = glm::cross(e1, e2);
  const double denom = glm::dot(w, n);
  if (denom == 0.0) return std::nullopt;
  const double t = glm::dot(v0 - p, n) / denom;
  if (!(t > 0.0)) return std::nullopt;
  const DVec3 x = p + t * w - v0;
  const double nn = glm::dot(n, n);
  return std::array<double, 2>{glm::dot(glm::cross(x, e2), n) / nn, glm::dot(glm::cross(e1, x), n) / nn};
}

bool inside(const std::array<double, 2>& b, double slack) {
  return b[0] >= -slack && b[1] >= -slack && b[0] + b[1] <= 1.0 + slack;
}

TEST(SphericalTriangle, AnOctantIsAnEighthOfTheSphereAtEveryScaleAndPlace) {
  // The triangle on the three axes at distance s covers one octant: 4 pi / 8 = pi / 2. Far from
  // the origin the scale stays one a float can hold there (a float's step at 1e6 is 1/16).
  for (const double s : {1e-4, 1.0, 1e6})
    for (const double offset : {0.0, 1e6}) {
      if (offset > 0.0 && s < 1.0) continue;
      const Vec3 p = Vec3(float(offset));
      const auto t =
          SphericalTriangle::seen(p, p + Vec3(float(s), 0, 0), p + Vec3(0, float(s), 0), p + Vec3(0, 0, float(s)));
      ASSERT_TRUE(t) << "scale " << s << " offset " << offset;
      EXPECT_NEAR(t->solidAngle, kPi / 2.0, 1e-6) << "scale " << s << " offset " << offset;
    }
}

TEST(SphericalTriangle, SolidAngleMatchesTheClosedFormOfARectangleSeenFromAboveItsCorner) {
  // A w x h rectangle seen from height d above a corner: Omega = atan(w h / (d sqrt(d^2 + w^2 + h^2)))
  // (the solid angle of a rectangle, e.g. Van Oosterom & Strackee 1983); its two triangles sum to it.
  for (const double d : {1e-3, 0.1, 1.0, 30.0}) {
    const double w = 2.0, h = 1.0;
    const Vec3 p(0.0f, 0.0f, float(d));
    const auto t1 = SphericalTriangle::seen(p, Vec3(0, 0, 0), Vec3(float(w), 0, 0), Vec3(float(w), float(h), 0));
    const auto t2 = SphericalTriangle::seen(p, Vec3(0, 0, 0), Vec3(float(w), float(h), 0), Vec3(0, float(h), 0));
    ASSERT_TRUE(t1 && t2);
    const double expected =
        std::atan(w * h / (double(float(d)) * std::sqrt(double(float(d)) * float(d) + w * w + h * h)));
    EXPECT_NEAR(t1->solidAngle + t2->solidAngle, expected, 1e-6 * expected) << "d " << d;
  }
}

TEST(SphericalTriangle, ADegenerateViewHasNone) {
  const Vec3 v0(0, 0, 0), v1(1, 0, 0), v2(0, 1, 0);
  EXPECT_FALSE(SphericalTriangle::seen(Vec3(0.3f, 0.3f, 0.0f), v0, v1, v2)) << "a point in the plane";
  EXPECT_FALSE(SphericalTriangle::seen(Vec3(5, 5, 0), v0, v1, v2)) << "in the plane, outside";
  EXPECT_FALSE(SphericalTriangle::seen(v1, v0, v1, v2)) << "on a vertex";
  EXPECT_FALSE(SphericalTriangle::seen(Vec3(0, 0, 1), v0, v1, Vec3(2, 0, 0))) << "collinear vertices";
}

// The views the sampler must serve: near and far, grazing, nearly a hemisphere, thin.
struct View {
  const char* name;
  Vec3 p, v0, v1, v2;
};
const View kViews[] = {
    {"near", Vec3(0.2f, 0.3f, 0.5f), Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)},
    {"far", Vec3(0.2f, 0.3f, 20.0f), Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)},
    {"grazing", Vec3(3.0f, -2.0f, 0.05f), Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)},
    {"almost a hemisphere", Vec3(0.3f, 0.3f, 1e-3f), Vec3(-50, -50, 0), Vec3(100, 0, 0), Vec3(0, 100, 0)},
    {"thin", Vec3(0.5f, 0.0f, 0.2f), Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5f, 0.01f, 0)},
    {"obtuse, at 1e6", Vec3(1e6f + 0.5f, 1e6f, 1e6f + 0.25f), Vec3(1e6f, 1e6f, 1e6f), Vec3(1e6f + 4, 1e6f, 1e6f),
     Vec3(1e6f + 2, 1e6f + 0.5f, 1e6f)},
};

// The solid angle of triangle (a, b, c) seen from p, in double (Van Oosterom & Strackee 1983).
double solidAngleOf(const DVec3& p, const DVec3& a, const DVec3& b, const DVec3& c) {
  const DVec3 x = glm::normalize(a - p), y = glm::normalize(b - p), z = glm::normalize(c - p);
  return 2.0 *
         std::atan2(std::abs(glm::dot(x, glm::cross(y, z))), 1.0 + glm::dot(x, y) + glm::dot(y, z) + glm::dot(z, x));
}

TEST(SphericalTriangle, SamplesAreDistributedAsOneOverTheSolidAngle) {
  // Chi-square on the triangle itself, where the density has no edges to integrate across: the
  // square [0,1)^2 maps onto the triangle by b1 = 1 - sqrt(u1), b2 = u2 sqrt(u1), whose lines of
  // constant u1 are parallel to the edge v0-v2 and of constant u2 pass through v1, so each cell of
  // a grid in u is a quadrilateral with straight sides. Its expected share of the samples is its
  // solid angle over the triangle's (two triangles, in double), independent of the sampler.
  constexpr int kCells = 24, kSamples = 400000;
  for (const View& v : kViews) {
    const auto t = SphericalTriangle::seen(v.p, v.v0, v.v1, v.v2);
    ASSERT_TRUE(t) << v.name;
    const DVec3 p(v.p), v0(v.v0), v1(v.v1), v2(v.v2);
    const auto at = [&](double u1, double u2) {
      const double r = std::sqrt(u1);
      return (1.0 - (1.0 - r) - u2 * r) * v0 + (1.0 - r) * v1 + u2 * r * v2;
    };
    std::vector<double> expected(kCells * kCells);
    for (int i = 0; i < kCells; ++i)
      for (int j = 0; j < kCells; ++j) {
        const double a1 = double(i) / kCells, b1 = double(i + 1) / kCells;
        const double a2 = double(j) / kCells, b2 = double(j + 1) / kCells;
        const DVec3 q00 = at(a1, a2), q10 = at(b1, a2), q11 = at(b1, b2), q01 = at(a1, b2);
        const double omega = solidAngleOf(p, q00, q10, q11) + solidAngleOf(p, q00, q11, q01);  // one is empty at v1
        expected[size_t(i * kCells + j)] = kSamples * omega / t->solidAngle;
      }
    std::vector<double> observed(expected.size(), 0.0);
    test::UniformRng rng(11);
    for (int n = 0; n < kSamples; ++n) {
      const auto bary = barycentricsAlong(p, t->sample(rng.next2()), v0, v1, v2);
      ASSERT_TRUE(bary && inside(*bary, 1e-6)) << v.name;
      const double r = std::clamp(1.0 - (*bary)[0], 0.0, 1.0);
      const double u1 = r * r, u2 = r > 0.0 ? std::clamp((*bary)[1] / r, 0.0, 1.0) : 0.0;
      const int i = std::min(int(u1 * kCells), kCells - 1), j = std::min(int(u2 * kCells), kCells - 1);
      observed[size_t(i * kCells + j)] += 1.0;
    }
    // Cells expecting fewer than 5 samples pooled into one, as the chi-square approximation needs.
    double chi2 = 0.0, pooledExpected = 0.0, pooledObserved = 0.0, total = 0.0;
    int cells = 0;
    for (size_t k = 0; k < expected.size(); ++k) {
      total += expected[k];
      if (expected[k] < 5.0) {
        pooledExpected += expected[k], pooledObserved += observed[k];
        continue;
      }
      chi2 += (observed[k] - expected[k]) * (observed[k] - expected[k]) / expected[k];
      ++cells;
    }
    if (pooledExpected > 0.0) {
      chi2 += (pooledObserved - pooledExpected) * (pooledObserved - pooledExpected) / pooledExpected;
      ++cells;
    }
    EXPECT_NEAR(total, kSamples, 1e-6 * kSamples) << v.name << ": the cells' solid angles sum to the triangle's";
    const double pValue = test::chi2PValue(chi2, cells - 1);
    EXPECT_TRUE(test::passes(pValue, 0.01, int(std::size(kViews))))
        << v.name << ": chi2 " << chi2 << " over " << cells << " cells, p " << pValue;
  }
}

TEST(SphericalTriangle, EachSubTriangleGetsItsShareOfTheSolidAngle) {
  // The four triangles between the edges' midpoints, each expected in proportion to its own
  // solid angle (computed by seen(), independently of the sampling), and every sample inside.
  for (const View& v : kViews) {
    const auto t = SphericalTriangle::seen(v.p, v.v0, v.v1, v.v2);
    ASSERT_TRUE(t) << v.name;
    const DVec3 p(v.p), a(v.v0), b(v.v1), c(v.v2);
    const DVec3 ab = 0.5 * (a + b), bc = 0.5 * (b + c), ca = 0.5 * (c + a);
    const std::array<std::array<DVec3, 3>, 4> parts{{{a, ab, ca}, {ab, b, bc}, {ca, bc, c}, {ab, bc, ca}}};
    std::array<double, 4> expected{};
    for (int i = 0; i < 4; ++i) {
      const auto s = SphericalTriangle::seen(v.p, Vec3(parts[i][0]), Vec3(parts[i][1]), Vec3(parts[i][2]));
      expected[i] = s ? s->solidAngle / t->solidAngle : 0.0;
    }
    test::UniformRng rng(7);
    constexpr int kSamples = 200000;
    std::array<double, 4> observed{};
    int outside = 0;
    for (int n = 0; n < kSamples; ++n) {
      const DVec3 w = t->sample(rng.next2());
      ASSERT_NEAR(glm::length(w), 1.0, 1e-12) << v.name;
      const auto bary = barycentricsAlong(p, w, a, b, c);
      if (!bary || !inside(*bary, 1e-6)) {
        ++outside;
        continue;
      }
      const double b1 = (*bary)[0], b2 = (*bary)[1], b0 = 1.0 - b1 - b2;
      // Sub-triangle: a corner's where its barycentric is above 1/2, else the middle one.
      observed[b0 > 0.5 ? 0 : b1 > 0.5 ? 1 : b2 > 0.5 ? 2 : 3] += 1.0;
    }
    EXPECT_EQ(outside, 0) << v.name;
    for (int i = 0; i < 4; ++i) {
      const double sigma = std::sqrt(kSamples * expected[i] * (1.0 - expected[i]));
      EXPECT_NEAR(observed[i], kSamples * expected[i], 5.0 * sigma + 1.0) << v.name << " part " << i;
    }
  }
}

TEST(SphericalTriangle, IrradianceFromUniformSamplesMatchesLambertsPolygonFormula) {
  // E / L = sum over edges of (angle subtended by the edge) (n . unit(v_i x v_{i+1})) / (2 pi) times
  // pi: the cosine-weighted solid angle (Lambert 1760; Arvo 1995, "Applications of irradiance
  // tensors"). Each estimate Omega cos(theta) is bounded by Omega: the point of sampling by
  // solid angle near a light.
  for (const View& v : kViews) {
    const auto t = SphericalTriangle::seen(v.p, v.v0, v.v1, v.v2);
    ASSERT_TRUE(t) << v.name;
    const DVec3 n(0.0, 0.0, v.p.z > v.v0.z ? -1.0 : 1.0);  // the receiver faces the triangle's plane
    const std::array<DVec3, 3> d{t->a, t->b, t->c};
    double lambert = 0.0;
    for (int i = 0; i < 3; ++i) {
      const DVec3 x = glm::cross(d[i], d[(i + 1) % 3]);
      const double angle = std::atan2(glm::length(x), glm::dot(d[i], d[(i + 1) % 3]));
      lambert += angle * glm::dot(n, x / glm::length(x));
    }
    lambert = std::abs(lambert) / 2.0;  // the projected solid angle, integral of cos over the triangle
    test::UniformRng rng(11);
    constexpr int kSamples = 100000;
    double sum = 0.0, largest = 0.0;
    for (int k = 0; k < kSamples; ++k) {
      const double estimate = t->solidAngle * std::max(0.0, glm::dot(n, t->sample(rng.next2())));
      sum += estimate;
      largest = std::max(largest, estimate);
    }
    EXPECT_NEAR(sum / kSamples, lambert, 0.01 * lambert + 1e-12) << v.name;
    EXPECT_LE(largest, t->solidAngle) << v.name;
  }
}

}  // namespace
}  // namespace lensfarm
