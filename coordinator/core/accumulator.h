#pragma once
// One job's film on the coordinator: its sensor and convergence tracker, the results that wait
// for an earlier unit, and where the job stops. No network code, and nothing of leases, workers
// or durable state: Coordinator hands it each accepted unit once (results.cpp) and publishes its
// Progress; a checkpoint saves what it serializes (persistence.cpp).
//
// Invariants:
//  - Units are summed in index order (a later unit waits in memory for the earlier ones), so the
//    image never depends on which worker finished first.
//  - Stopping rules (docs/accuracy.md) are decided here so that the kept units are a prefix chosen
//    in unit order: the same units whatever order results arrive in, and after a restart. A
//    target-error job stops at the first prefix that reaches its target; at a deadline the units
//    summed when it passed are kept (at least one).
//  - A rewind (the audit found a wrong worker, docs/farm.md "Audit") restores the film exactly as
//    it was after some prefix of units (a rewind point, a bitwise copy, or the empty film), so
//    summing the units after it again gives the bits a run without the wrong worker gives.
//  - A tiled job (farm/job_layout.h) holds a TileFilm instead of a sensor: each tile is final when
//    it arrives and is written at once, whatever its order; it stops when every tile is in (no
//    target error or deadline: those need passes), keeps no rewind points and no checkpoint (the
//    ledger and the stored frames are its durable state).
//  - Every member takes the accumulator's own lock, which is never held while taking another
//    (Coordinator::mutex_ may be held while taking it, never the reverse).
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>

#include "common/farm/farm_types.h"
#include "common/farm/job_layout.h"
#include "common/film/adaptive_allocation.h"
#include "common/film/convergence.h"
#include "common/film/image.h"
#include "common/film/sensor.h"
#include "common/scene/scene.h"
#include "coordinator/core/tile_film.h"

namespace lensfarm {

class Accumulator {
 public:
  // What has been summed, as of one moment.
  struct Progress {
    uint64_t units = 0;            // units [0, units) are in the sensor
    uint64_t samplesPerPixel = 0;  // their samples per pixel
    PathStats stats;
    ErrorEstimate estimate;                                     // the latest estimate
    std::string stopReason;                                     // empty until the job reached its stop
    uint64_t foldLimit = std::numeric_limits<uint64_t>::max();  // units from here on are never summed
  };

  // A new job's: an empty sensor and tracker of the frame (std::bad_alloc if they do not fit).
  Accumulator(const RenderSettings& settings, uint32_t unitSize, uint64_t unitsTotal);
  // A new job's film for its layout: a TileFilm when it is tiled, else as above.
  Accumulator(const RenderSettings& settings, const JobLayout& layout);
  // A job resumed from a checkpoint whose sensor and film state (Snapshot::tracker) hold units
  // [0, folded); std::runtime_error if they are not this job's.
  Accumulator(const RenderSettings& settings, const JobLayout& layout, Sensor sensor, const std::string& filmState,
              uint64_t folded);
  Accumulator(const Accumulator&) = delete;
  Accumulator& operator=(const Accumulator&) = delete;

  // Adds an accepted unit (each unit once). The next unit in order is summed straight from
  // `result`'s buffer; a later one is kept until the earlier ones arrive (moved from `owned` if
  // given, else copied); nothing past the stop is kept. nullopt: out of memory keeping it.
  // A result accepted before a rewind (`generation` below generation()) is ignored.
  std::optional<Progress> add(const UnitResult& result, UnitResult* owned, uint64_t generation = 0);

  // The sensor and the rest of the film as a checkpoint saves them: `tracker` holds the
  // convergence tracker's bytes, then an adaptive job's round allocations (each a 64-bit size and
  // RoundAllocation's bytes).
  struct Snapshot {
    std::string sensor, tracker;
    uint64_t folded = 0;  // the units they hold
  };

  // ---- adaptive sampling (farm/job_layout.h) ----
  // What unit `u` traces: null for a unit of one sample range (a uniform pass, any job without
  // rounds); its map once its round is allocated (every unit before the round summed).
  // `ready` says whether the unit can be leased now.
  std::shared_ptr<const SampleMap> samplesOf(uint64_t u, bool* ready = nullptr) const;
  bool leasable(uint64_t u) const;  // samplesOf's `ready`, without making the map

  // ---- rewinding (docs/farm.md "Audit") ----
  // Keeps a copy of the sensor and tracker every `spacing` units summed, at most `most` at once
  // (a new one waits for trustBelow to free a place); 0: none. Each costs one sensor and tracker.
  // Calling it again with the same values changes nothing.
  void keepRewindPoints(uint64_t spacing, size_t most);
  // Units [0, units) will never be undone: of the rewind points at or below `units` only the
  // latest is kept.
  void trustBelow(uint64_t units);
  struct Rewound {
    uint64_t units = 0;       // the film holds units [0, units)
    std::set<uint64_t> kept;  // results still waiting to be summed (all above `units`)
    Progress progress;
    std::optional<Snapshot> checkpoint;  // when the last checkpoint held more: save this
  };
  // Undoes the units from the latest rewind point at or before `unit` on (the empty film if there
  // is none; nothing if `unit` is not summed yet) and the job's stop with them, and drops the
  // waiting results `drop` names. Results accepted before now are ignored (generation()).
  // A tiled job undoes only the tiles `worker` rendered from `unit` on (TileFilm::forgetWorker).
  Rewound rewind(uint64_t unit, const std::function<bool(const UnitResult&)>& drop, const std::string& worker = "");
  uint64_t generation() const;

  // Restoring from the ledger: a unit the checkpoint holds adds only its stats; a later one
  // waits like an early result until drain() sums it in order.
  void restoreFolded(const PathStats& stats);
  void restoreWaiting(UnitResult result);
  void drain();
  // Units from `units` on are never summed (a stop that was reached before a restart).
  void limitTo(uint64_t units);

  // The deadline passed: the units summed so far are the image (their progress, estimated now), or,
  // before the first was summed, the first one will be (nullopt).
  std::optional<Progress> stopAtDeadline();
  // Estimates the error now, and the progress with that estimate.
  Progress estimateNow();

  // The sensor and tracker as a checkpoint saves them, if units were summed since the last one.
  std::optional<Snapshot> snapshotIfChanged() const;
  void checkpointed(uint64_t folded);  // a snapshot of `folded` units is durable

  // The image as it is now (std::bad_alloc if it does not fit), with what it holds.
  struct Developed {
    Image image;
    uint64_t samplesPerPixel = 0;
    uint64_t totalSamples = 0;
    PathStats stats;
  };
  Developed develop() const;
  std::string serializedSensor() const;  // Sensor::serialize; FarmError kFailedPrecondition for a tiled job

  // ---- tiled jobs (tile_film.h) ----
  bool tiled() const { return tiles_ != nullptr; }
  // Frames completed since the last call (TileFilm::takeCompleted); none for a job in passes.
  std::vector<TileFilm::Completed> takeCompletedFrames();
  void frameStored(uint64_t frameIndex);  // TileFilm::stored
  // Frame `frameIndex`'s image as held now; nullopt when the film does not hold it (TileFilm::image).
  std::optional<Developed> developFrame(uint64_t frameIndex) const;
  // An animation frame stored before a restart: all its tiles count as in.
  void restoreCompleteFrame(uint64_t frameIndex);
  // Each frame's tiles in, under one lock (a status of many frames).
  std::vector<uint32_t> tilesDonePerFrame() const;

 private:
  using Clock = std::chrono::steady_clock;
  // Sums the units that are next in order (`next`, if given, is one not kept in arrived_).
  void drainInOrder(const UnitResult* next);  // requires mutex_
  void stopFolding(std::string reason);       // requires mutex_
  void writeTile(const UnitResult& result);   // requires mutex_; a tiled job's
  Progress progress() const;                  // requires mutex_
  Snapshot snapshotLocked() const;            // requires mutex_

  // An adaptive job's round starting at nextToAdd_, if it has none yet (film/adaptive_allocation.h).
  void allocateIfRoundStarts();  // requires mutex_
  // The job's layout, fixed at submission.
  const JobLayout layout_;
  const uint64_t samplesPerPixel_;
  const uint32_t unitSize_;
  const uint64_t unitsTotal_;
  const double targetError_;  // 0: none

  mutable std::mutex mutex_;  // guards everything below
  std::unique_ptr<Sensor> sensor_;
  std::map<uint64_t, UnitResult> arrived_;  // results waiting for an earlier unit
  uint64_t nextToAdd_ = 0;
  uint64_t sppAdded_ = 0;
  PathStats statsAdded_;
  uint64_t checkpointed_ = 0;  // units in the last saved sensor
  std::unique_ptr<ConvergenceTracker> tracker_;
  std::vector<std::shared_ptr<const RoundAllocation>> rounds_;  // per round of layout_; null until allocated
  ErrorEstimate estimate_;
  Clock::time_point estimatedAt_;
  uint64_t foldLimit_ = std::numeric_limits<uint64_t>::max();  // units from here on are never folded
  bool stopAtNextFold_ = false;                                // the deadline passed before the first unit was folded
  std::string stopReason_;
  // Rewinding: copies of the film after `units` units, oldest first.
  struct RewindPoint {
    uint64_t units = 0, samplesPerPixel = 0;
    PathStats stats;
    ErrorEstimate estimate;
    Sensor sensor;
    ConvergenceTracker tracker;
  };
  const int width_, height_;
  const AovLayout aovs_;  // the AOVs' sums in a cell (film/aov_layout.h)
  std::deque<RewindPoint> points_;
  std::unique_ptr<TileFilm> tiles_;          // a tiled job's film (then no sensor_ or tracker_)
  std::map<uint64_t, PathStats> tileStats_;  // a tiled job: per unit written, to undo with it
  uint64_t pointSpacing_ = 0, lastPointAt_ = 0;
  size_t mostPoints_ = 0;
  uint64_t generation_ = 0;
};

}  // namespace lensfarm
