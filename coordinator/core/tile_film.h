#pragma once
// A tiled job's film (farm/job_layout.h, docs/farm.md "Tiles and passes"). A tile unit arrives
// final — its sums are the cells' compensated sums over every sample — so its cells' means go
// straight into a float image of its frame, in whatever order tiles arrive: the coordinator holds
// one float image per frame being rendered (12 bytes a cell) and no sums, no tracker and no
// waiting results. A frame whose every tile is in is complete: an animation's is stored
// (frame_store.h) and freed; a still's stays held, its tiles' unit files being its durable state.
//
// Invariants:
//  - A cell's value is float(value * (1 / spp)), with the lens flip undone: the bits
//    Sensor::developImage gives for the same passes (film/sensor.h), so a tiled job and the same
//    job in passes make the same image.
//  - Writing a tile twice writes the same bits (a restart replays the ledger): it counts once.
// Not thread-safe: the Accumulator's lock guards it.
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "common/farm/job_layout.h"
#include "common/film/image.h"
#include "common/film/path_stats.h"
#include "common/film/sensor.h"

namespace lensfarm {

class TileFilm {
 public:
  // `aovs`: the AOV layers developed beside the beauty (film/aov_layout.h; layout.channels sums a cell).
  explicit TileFilm(JobLayout layout, AovLayout aovs = AovLayout());

  const JobLayout& layout() const { return layout_; }
  // Writes unit `u`'s sums (its region's cells; the caller checked the size) into its frame,
  // rendered by `worker`. Returns false, changing nothing, if the tile is in already.
  bool write(uint64_t u, const SensorBuffer& buffer, const std::string& worker);
  bool has(uint64_t u) const;
  uint64_t unitsDone() const { return unitsDone_; }
  uint64_t tilesDone(uint64_t frameIndex) const { return frameIndex < tilesDone_.size() ? tilesDone_[frameIndex] : 0; }
  bool frameComplete(uint64_t frameIndex) const { return tilesDone(frameIndex) == layout_.unitsPerFrame(); }

  // Frames completed since the last call, with their images, in completion order. A still's
  // image stays held (image() serves it) and is not handed over (null); an animation's is handed
  // over and freed.
  // Until stored() is called for it, a handed-over frame is still served by image(): the file
  // is written outside any lock, and the job may be done before the write ends.
  struct Completed {
    uint64_t frameIndex = 0;
    std::shared_ptr<const Image> image;
  };
  std::vector<Completed> takeCompleted();
  void stored(uint64_t frameIndex);  // its file is durable: the film lets the image go

  // The frame's image as held now (black where no tile is in yet); nullopt when it is not held
  // (an animation's frame before its first tile or after it completed).
  std::optional<Image> image(uint64_t frameIndex) const;

  // Restoring: an animation frame stored before the restart: every tile counts as in.
  void restoreComplete(uint64_t frameIndex);
  const std::vector<uint32_t>& tilesDonePerFrame() const { return tilesDone_; }

  // The audit found `worker` wrong (docs/farm.md "Audit"): its tiles from unit `from` on, in
  // frames still held, no longer count (they are rendered again and overwritten), and no later
  // tile of it is written. Returns the units from `from` on that still count.
  std::set<uint64_t> forgetWorker(uint64_t from, const std::string& worker);

 private:
  struct Frame {
    Image image;
    std::vector<std::string> workerOf;  // per tile; empty: not in
  };
  Frame& frame(uint64_t frameIndex);

  JobLayout layout_;
  AovLayout aovs_;
  std::map<uint64_t, Frame> held_;                            // frames with tiles in, not yet handed over
  std::vector<uint32_t> tilesDone_;                           // per frame
  std::set<uint64_t> completeFrames_;                         // handed over (or restored): every tile counts
  std::vector<uint64_t> justCompleted_;                       // for takeCompleted
  std::set<std::string> distrusted_;                          // workers forgotten by the audit
  std::map<uint64_t, std::shared_ptr<const Image>> storing_;  // handed over, not yet stored
  uint64_t unitsDone_ = 0;
};

}  // namespace lensfarm
