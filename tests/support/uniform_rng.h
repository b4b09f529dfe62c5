#pragma once
// Uniform floats in [0, 1) with 24 random bits from a fixed seed, for tests that draw their own
// sample values (std::uniform_real_distribution<float> may return 1 in libstdc++).
#include <cstdint>
#include <random>

#include "common/math/vec.h"

namespace lensfarm::test {

struct UniformRng {
  explicit UniformRng(uint32_t seed) : engine(seed) {}
  float next() { return float(engine() >> 8) * 0x1.0p-24f; }
  Vec2 next2() {
    const float a = next();  // in this order: a constructor's arguments are evaluated in any order
    return Vec2(a, next());
  }
  std::mt19937 engine;
};

}  // namespace lensfarm::test
