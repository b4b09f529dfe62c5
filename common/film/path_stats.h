#pragma once
// The counters of the paths behind a sensor buffer's samples (film/sensor.h): what a renderer
// reports with each unit and the farm sums and checks (farm/farm_types.h, UnitResult).
#include <cstdint>

namespace lensfarm {

struct PathStats {
  uint64_t paths = 0;
  uint64_t rays = 0;       // every ray cast: camera, scattered and shadow rays
  uint64_t lightHits = 0;  // paths whose camera or scattered ray reached an emitting surface
  uint64_t dropped = 0;    // samples whose radiance was NaN or infinite (counted, not added)
  // Paths still going when they reached pathSegmentLimit(B) segments (light trapped by total
  // internal reflection in faceted glass, facing mirrors): their further light is not counted.
  uint64_t truncated = 0;

  PathStats& operator+=(const PathStats& o) {
    paths += o.paths;
    rays += o.rays;
    lightHits += o.lightHits;
    dropped += o.dropped;
    truncated += o.truncated;
    return *this;
  }
  PathStats& operator-=(const PathStats& o) {  // undoing counts added before
    paths -= o.paths;
    rays -= o.rays;
    lightHits -= o.lightHits;
    dropped -= o.dropped;
    truncated -= o.truncated;
    return *this;
  }
};

}  // namespace lensfarm
