#pragma once
// The render settings of a w x h frame, shared by memory_estimate_test and memory_estimate_cli_test.
#include <cstdint>

#include "common/scene/scene.h"

namespace lensfarm::test {

inline RenderSettings settingsOf(int w, int h, uint64_t spp = 1) {
  RenderSettings s;
  s.width = w;
  s.height = h;
  s.samplesPerPixel = spp;
  return s;
}

}  // namespace lensfarm::test
