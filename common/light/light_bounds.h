#pragma once
// What a light tree (render/light_tree.h) knows of a light or of a cluster of lights: where they
// are, how much they emit, and in which directions (Conty Estevez & Kulla 2018, "Importance
// Sampling of Many Lights with Adaptive Tree Splitting"; pbrt-v4's LightBounds, §12.6.3).
//
// The directions are a cone of normals: every emitter's normal lies within theta_o of the axis w,
// and each emits within theta_e of its normal (pi/2 for a surface, which emits over its
// hemisphere; a point light's normals cover the sphere, theta_o = pi). A two-sided cluster emits
// from both faces (the cone and its mirror image).
//
// importance(p) estimates the light the cluster sends to point p, up to a constant shared by all
// clusters: its intensity over the squared distance, times the cosine of the smallest angle between
// any normal of the cone and any direction from the cluster's box to p; zero where no emitter can
// face p at all. It is only a guide to choosing: the tree samples by it and divides by the
// probability it gave, so a poor estimate costs noise, never bias. Units: intensity in luminance
// (a triangle's A L along its normal, a point's or spot's I: light/light_source.h), distances in
// render space; a squared distance is floored at the
// square of half the box's diagonal, so that a point inside or near a cluster does not make it
// infinitely important (scale-free: the same choice at any scale).
#include <cstdint>

#include "common/math/vec.h"

namespace lensfarm {

// A cone of directions: every direction within theta of the unit axis w, by cos(theta); an empty
// cone has cosTheta = +inf (no direction), the whole sphere -1.
struct DirectionCone {
  Vec3 w{0.0f, 0.0f, 1.0f};
  float cosTheta = std::numeric_limits<float>::infinity();

  bool empty() const { return cosTheta == std::numeric_limits<float>::infinity(); }
  static DirectionCone sphere() { return DirectionCone{Vec3(0.0f, 0.0f, 1.0f), -1.0f}; }
  // The smallest cone (of this construction) holding both.
  static DirectionCone merge(const DirectionCone& a, const DirectionCone& b);
};

struct LightBounds {
  Vec3 lo{std::numeric_limits<float>::max()}, hi{-std::numeric_limits<float>::max()};  // the box
  // The largest radiant intensity each emitter sends (luminance), summed over a cluster. (Not its
  // power: a surface's peak intensity is its power over pi, a point's over 4 pi, and importance
  // compares what reaches a point.)
  float intensity = 0.0f;
  DirectionCone normals;
  float cosThetaE = 0.0f;  // cos(theta_e): emission beyond the normal (0: a hemisphere)
  bool twoSided = false;

  Vec3 centroid() const { return 0.5f * (lo + hi); }
  // The bounds of a cluster of both.
  static LightBounds merge(const LightBounds& a, const LightBounds& b);
};

// LightBounds as importance() reads them, with what it needs computed once (the light tree holds
// its nodes in this form: a light sample evaluates two per level).
struct LightCluster {
  Vec3 centre;  // of the box's bounding sphere
  float radius;
  Vec3 w;  // the normals' cone: axis, cos and sin of theta_o
  float cosO;
  float sinO, cosE, intensity;
  uint32_t twoSided;

  LightCluster() = default;
  explicit LightCluster(const LightBounds& b);
  // See above; >= 0, finite for finite inputs.
  float importance(const Vec3& p) const;
};

}  // namespace lensfarm
