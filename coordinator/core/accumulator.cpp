// Accumulator: one job's film, summed in unit order, and the stop at a target error or deadline
// (accumulator.h).
#include "coordinator/core/accumulator.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "common/farm/farm_types.h"
#include "common/film/work_unit.h"

namespace lensfarm {

Accumulator::Accumulator(const RenderSettings& settings, uint32_t unitSize, uint64_t unitsTotal)
    : samplesPerPixel_(settings.samplesPerPixel),
      unitSize_(unitSize),
      unitsTotal_(unitsTotal),
      targetError_(settings.targetError),
      sensor_(std::make_unique<Sensor>(settings.width, settings.height, AovLayout(settings.aovs).channels)),
      tracker_(std::make_unique<ConvergenceTracker>(settings.width, settings.height)),
      width_(settings.width),
      height_(settings.height),
      aovs_(settings.aovs) {}

Accumulator::Accumulator(const RenderSettings& settings, const JobLayout& layout)
    : layout_(layout),
      samplesPerPixel_(layout.samplesPerPixel),
      unitSize_(layout.passSamples),
      unitsTotal_(layout.unitCount()),
      targetError_(settings.targetError),
      rounds_(layout.roundStarts.size()),
      width_(settings.width),
      height_(settings.height),
      aovs_(settings.aovs) {
  if (layout.tiled()) {
    tiles_ = std::make_unique<TileFilm>(layout, aovs_);
  } else {
    sensor_ = std::make_unique<Sensor>(settings.width, settings.height, aovs_.channels);
    tracker_ = std::make_unique<ConvergenceTracker>(settings.width, settings.height);
  }
}

Accumulator::Accumulator(const RenderSettings& settings, const JobLayout& layout, Sensor sensor,
                         const std::string& filmState, uint64_t folded)
    : layout_(layout),
      samplesPerPixel_(layout.samplesPerPixel),
      unitSize_(layout.passSamples),
      unitsTotal_(layout.unitCount()),
      targetError_(settings.targetError),
      sensor_(std::make_unique<Sensor>(std::move(sensor))),
      nextToAdd_(folded),
      checkpointed_(folded),
      rounds_(layout.roundStarts.size()),
      width_(settings.width),
      height_(settings.height),
      aovs_(settings.aovs),
      lastPointAt_(folded) {
  if (sensor_->channels() != aovs_.channels)
    throw std::runtime_error("the checkpoint's sensor holds " + std::to_string(sensor_->channels()) +
                             " sums a cell, the job's AOVs " + std::to_string(aovs_.channels));
  size_t at = 0;
  tracker_ = std::make_unique<ConvergenceTracker>(ConvergenceTracker::deserializePrefix(filmState, at));
  while (at < filmState.size()) {  // the rounds allocated when the checkpoint was taken
    uint64_t size = 0;
    if (filmState.size() - at < sizeof size) throw std::runtime_error("film state: a round allocation is truncated");
    std::memcpy(&size, filmState.data() + at, sizeof size);
    at += sizeof size;
    if (size > filmState.size() - at) throw std::runtime_error("film state: a round allocation is truncated");
    auto round = std::make_shared<const RoundAllocation>(RoundAllocation::deserialize(filmState.substr(at, size)));
    at += size;
    const int r = layout_.roundOf(round->start);
    if (r < 0 || layout_.roundStarts[size_t(r)] != round->start ||
        round->units != layout_.roundEnd(size_t(r)) - round->start)
      throw std::runtime_error("film state: a round allocation that is not this job's");
    rounds_[size_t(r)] = std::move(round);
  }
  for (uint64_t u = 0; u < folded; ++u) sppAdded_ += unitAt(u, samplesPerPixel_, unitSize_).sampleCount;
  allocateIfRoundStarts();
}

std::shared_ptr<const SampleMap> Accumulator::samplesOf(uint64_t u, bool* ready) const {
  const int r = layout_.roundOf(u);
  if (ready) *ready = true;
  if (r < 0) return nullptr;
  std::lock_guard lock(mutex_);
  const auto& round = rounds_[size_t(r)];
  if (ready) *ready = round != nullptr;
  return round ? round->mapOf(u) : nullptr;
}

bool Accumulator::leasable(uint64_t u) const {
  const int r = layout_.roundOf(u);
  if (r < 0) return true;
  std::lock_guard lock(mutex_);
  return rounds_[size_t(r)] != nullptr;
}

void Accumulator::allocateIfRoundStarts() {
  const int r = layout_.roundOf(nextToAdd_);
  if (r < 0 || layout_.roundStarts[size_t(r)] != nextToAdd_ || rounds_[size_t(r)] || nextToAdd_ >= foldLimit_) return;
  rounds_[size_t(r)] =
      std::make_shared<const RoundAllocation>(allocateRound(*sensor_, *tracker_, layout_.roundRequest(size_t(r))));
}

std::optional<Accumulator::Progress> Accumulator::add(const UnitResult& result, UnitResult* owned,
                                                      uint64_t generation) {
  std::lock_guard lock(mutex_);
  if (tiles_) {
    // Tiles are independent: one accepted before a rewind is as good as after it, unless its
    // worker is the one the rewind was for (TileFilm refuses those).
    writeTile(result);
    return progress();
  }
  if (generation != generation_) return progress();  // accepted before a rewind: it is rendered again
  // Past a job's stop nothing more is folded (the stop is a prefix of units). The next unit in
  // order is summed from the caller's buffer; a later one waits in `arrived_`.
  const bool next = result.unitIndex == nextToAdd_;
  try {
    if (result.unitIndex < foldLimit_ && !next) arrived_.emplace(result.unitIndex, owned ? std::move(*owned) : result);
  } catch (const std::bad_alloc&) {
    return std::nullopt;
  }
  drainInOrder(next && result.unitIndex < foldLimit_ ? &result : nullptr);
  return progress();
}

void Accumulator::restoreFolded(const PathStats& stats) {
  std::lock_guard lock(mutex_);
  statsAdded_ += stats;
}

void Accumulator::writeTile(const UnitResult& result) {
  if (!tiles_->write(result.unitIndex, result.buffer, result.workerId)) return;
  statsAdded_ += result.stats;
  tileStats_[result.unitIndex] = result.stats;
  if (tiles_->unitsDone() == unitsTotal_ && stopReason_.empty()) stopReason_ = "all samples done";
}

void Accumulator::restoreWaiting(UnitResult result) {
  std::lock_guard lock(mutex_);
  if (tiles_) {
    writeTile(result);
    return;
  }
  const uint64_t unit = result.unitIndex;
  arrived_.emplace(unit, std::move(result));
}

void Accumulator::drain() {
  std::lock_guard lock(mutex_);
  if (!tiles_) drainInOrder(nullptr);
}

void Accumulator::limitTo(uint64_t units) {
  std::lock_guard lock(mutex_);
  foldLimit_ = units;
}

void Accumulator::drainInOrder(const UnitResult* next) {
  const double target = targetError_;
  bool folded = false;
  while (nextToAdd_ < foldLimit_) {
    // The next unit: the caller's (summed from its buffer, never copied) or one that waited.
    const UnitResult* r = nullptr;
    auto it = arrived_.end();
    if (next && next->unitIndex == nextToAdd_) {
      r = next;
      next = nullptr;
    } else if (it = arrived_.find(nextToAdd_); it != arrived_.end()) {
      r = &it->second;
    } else {
      break;
    }
    // Every cell of a unit holds the unit's samples, or its block's for an adaptive unit; the
    // counts are the coordinator's to know.
    const uint32_t samples = unitAt(nextToAdd_, samplesPerPixel_, unitSize_).sampleCount;
    if (const int round = layout_.roundOf(nextToAdd_); round >= 0) {
      const std::shared_ptr<const SampleMap> map = rounds_[size_t(round)]->mapOf(nextToAdd_);
      sensor_->add(r->buffer, *map);
      tracker_->add(nextToAdd_, r->buffer, *map);
    } else {
      sensor_->add(r->buffer, samples);
      tracker_->add(nextToAdd_, r->buffer, samples);
    }
    statsAdded_ += r->stats;
    sppAdded_ += samples;
    if (it != arrived_.end()) arrived_.erase(it);
    ++nextToAdd_;
    folded = true;
    if (pointSpacing_ > 0 && nextToAdd_ >= lastPointAt_ + pointSpacing_ && points_.size() < mostPoints_) {
      points_.push_back(RewindPoint{nextToAdd_, sppAdded_, statsAdded_, estimate_, *sensor_, *tracker_});
      lastPointAt_ = nextToAdd_;
    }
    // A target-error job checks after every unit: the first prefix that reaches the target is
    // the image, whichever units arrived early.
    if (target > 0.0) {
      estimate_ = tracker_->estimate(*sensor_);
      estimatedAt_ = Clock::now();
      if (estimate_.valid && estimate_.relativeRmse <= target) stopFolding("target error reached");
    }
    if (stopAtNextFold_ && stopReason_.empty()) stopFolding("deadline reached");
    allocateIfRoundStarts();
  }
  if (nextToAdd_ == unitsTotal_ && stopReason_.empty())
    stopReason_ = target > 0.0 ? "sample cap reached before the target error" : "all samples done";
  // Otherwise the estimate is for people watching: a few times a second is enough (it reads the
  // whole frame), and always at the end.
  const auto now = Clock::now();
  if (folded && target <= 0.0 && (now - estimatedAt_ > std::chrono::milliseconds(250) || !stopReason_.empty())) {
    estimate_ = tracker_->estimate(*sensor_);
    estimatedAt_ = now;
  }
}

void Accumulator::stopFolding(std::string reason) {
  foldLimit_ = nextToAdd_;
  stopReason_ = std::move(reason);
  arrived_.clear();
}

std::optional<Accumulator::Progress> Accumulator::stopAtDeadline() {
  std::lock_guard lock(mutex_);
  if (tiles_) return progress();  // never: a tiled job has no deadline (validateRenderSettings)
  if (nextToAdd_ == 0) {
    stopAtNextFold_ = true;  // no image yet: the first whole pass is the image
    return std::nullopt;
  }
  if (stopReason_.empty()) stopFolding("deadline reached");
  estimate_ = tracker_->estimate(*sensor_);
  return progress();
}

Accumulator::Progress Accumulator::estimateNow() {
  std::lock_guard lock(mutex_);
  if (tiles_) return progress();
  estimate_ = tracker_->estimate(*sensor_);
  return progress();
}

Accumulator::Progress Accumulator::progress() const {
  if (tiles_) {
    // Every tile holds every sample: the frame's samples per pixel in the share of its tiles in.
    const uint64_t done = tiles_->unitsDone();
    return Progress{
        done,        unitsTotal_ ? uint64_t(double(samplesPerPixel_) * double(done) / double(unitsTotal_)) : 0,
        statsAdded_, estimate_,
        stopReason_, foldLimit_};
  }
  return Progress{nextToAdd_, sppAdded_, statsAdded_, estimate_, stopReason_, foldLimit_};
}

std::optional<Accumulator::Snapshot> Accumulator::snapshotIfChanged() const {
  std::lock_guard lock(mutex_);
  if (tiles_ || nextToAdd_ == checkpointed_) return std::nullopt;
  return snapshotLocked();
}

Accumulator::Snapshot Accumulator::snapshotLocked() const {
  std::string state = tracker_->serialize();
  for (const auto& round : rounds_)
    if (round && round->start <= nextToAdd_) {  // (one allocated later is allocated again from the film)
      const std::string bytes = round->serialize();
      const uint64_t size = bytes.size();
      state.append(reinterpret_cast<const char*>(&size), sizeof size);
      state += bytes;
    }
  return Snapshot{sensor_->serialize(), std::move(state), nextToAdd_};
}

void Accumulator::keepRewindPoints(uint64_t spacing, size_t most) {
  std::lock_guard lock(mutex_);
  if (tiles_) return;  // a tile is undone alone (rewind)
  pointSpacing_ = most > 0 ? spacing : 0;
  mostPoints_ = most;
}

void Accumulator::trustBelow(uint64_t units) {
  std::lock_guard lock(mutex_);
  // Keep the latest point at or below `units` (a rewind may still go back to it) and those above.
  while (points_.size() >= 2 && points_[1].units <= units) points_.pop_front();
}

Accumulator::Rewound Accumulator::rewind(uint64_t unit, const std::function<bool(const UnitResult&)>& drop,
                                         const std::string& worker) {
  std::lock_guard lock(mutex_);
  ++generation_;
  if (tiles_) {
    // Tiles are independent: only the wrong worker's, from `unit` on, are undone (rendered again
    // and overwritten); every other tile stays. A frame stored already stays as it is.
    Rewound out;
    out.kept = tiles_->forgetWorker(unit, worker);
    for (auto it = tileStats_.lower_bound(unit); it != tileStats_.end();) {
      if (out.kept.count(it->first)) {
        ++it;
      } else {
        statsAdded_ -= it->second;
        it = tileStats_.erase(it);
      }
    }
    stopReason_.clear();
    out.units = unit;
    out.progress = progress();
    return out;
  }
  if (unit < nextToAdd_) {
    // The latest point at or before `unit`, else the empty film; points after it hold undone units.
    while (!points_.empty() && points_.back().units > unit) points_.pop_back();
    if (points_.empty()) {
      sensor_ = std::make_unique<Sensor>(width_, height_, aovs_.channels);
      tracker_ = std::make_unique<ConvergenceTracker>(width_, height_);
      nextToAdd_ = sppAdded_ = 0;
      statsAdded_ = PathStats{};
      estimate_ = ErrorEstimate{};
    } else {
      const RewindPoint& p = points_.back();
      *sensor_ = p.sensor;
      *tracker_ = p.tracker;
      nextToAdd_ = p.units;
      sppAdded_ = p.samplesPerPixel;
      statsAdded_ = p.stats;
      estimate_ = p.estimate;
    }
    lastPointAt_ = nextToAdd_;
    // Rounds allocated from a film now undone are allocated again when it gets there.
    for (size_t r = 0; r < rounds_.size(); ++r)
      if (layout_.roundStarts[r] > nextToAdd_) rounds_[r].reset();
    // The stop was decided on units now undone (a deadline ends a job before any rewind).
    foldLimit_ = std::numeric_limits<uint64_t>::max();
    stopReason_.clear();
  }
  allocateIfRoundStarts();
  Rewound out;
  for (auto it = arrived_.begin(); it != arrived_.end();) {
    const int round = layout_.roundOf(it->first);  // a unit of a round undone traced another allocation
    if (drop(it->second) || (round >= 0 && !rounds_[size_t(round)])) {
      it = arrived_.erase(it);
    } else {
      out.kept.insert(it->first);
      ++it;
    }
  }
  if (checkpointed_ > nextToAdd_) {
    out.checkpoint = snapshotLocked();
    checkpointed_ = nextToAdd_;
  }
  out.units = nextToAdd_;
  out.progress = progress();
  return out;
}

uint64_t Accumulator::generation() const {
  std::lock_guard lock(mutex_);
  return generation_;
}

void Accumulator::checkpointed(uint64_t folded) {
  std::lock_guard lock(mutex_);
  checkpointed_ = std::max(checkpointed_, folded);
}

Accumulator::Developed Accumulator::develop() const {
  std::lock_guard lock(mutex_);
  Developed out;
  if (tiles_) {
    // (Not value_or: its black image would be made, a frame's worth, even when the film has one.)
    std::optional<Image> held = tiles_->image(0);
    out.image =
        held ? std::move(*held) : Image{width_, height_, std::vector<float>(size_t(width_) * height_ * 3, 0.0f)};
    if (out.image.layers.empty() && aovs_.any()) out.image.layers = aovLayers(aovs_, width_, height_);
    const Progress p = progress();
    out.samplesPerPixel = p.samplesPerPixel;
    out.totalSamples = statsAdded_.paths;
    out.stats = statsAdded_;
    return out;
  }
  out.image = sensor_->developImage(aovs_);
  out.samplesPerPixel = sppAdded_;
  out.totalSamples = sensor_->totalSamples();
  out.stats = statsAdded_;
  return out;
}

std::string Accumulator::serializedSensor() const {
  std::lock_guard lock(mutex_);
  if (tiles_) throw FarmError(FarmError::Kind::kFailedPrecondition, "a tiled job holds no sensor, only its image");
  return sensor_->serialize();
}

std::vector<TileFilm::Completed> Accumulator::takeCompletedFrames() {
  std::lock_guard lock(mutex_);
  return tiles_ ? tiles_->takeCompleted() : std::vector<TileFilm::Completed>{};
}

void Accumulator::frameStored(uint64_t frameIndex) {
  std::lock_guard lock(mutex_);
  if (tiles_) tiles_->stored(frameIndex);
}

std::optional<Accumulator::Developed> Accumulator::developFrame(uint64_t frameIndex) const {
  if (!tiles_) {
    if (frameIndex != 0) return std::nullopt;
    return develop();
  }
  std::lock_guard lock(mutex_);
  std::optional<Image> image = tiles_->image(frameIndex);
  if (!image) return std::nullopt;
  Developed out;
  out.image = std::move(*image);
  const uint64_t perFrame = tiles_->layout().unitsPerFrame();
  out.samplesPerPixel = tiles_->tilesDone(frameIndex) == perFrame ? samplesPerPixel_ : 0;
  for (auto it = tileStats_.lower_bound(frameIndex * perFrame);
       it != tileStats_.end() && it->first < (frameIndex + 1) * perFrame; ++it)
    out.stats += it->second;
  out.totalSamples = out.stats.paths;
  return out;
}

void Accumulator::restoreCompleteFrame(uint64_t frameIndex) {
  std::lock_guard lock(mutex_);
  if (!tiles_) return;
  tiles_->restoreComplete(frameIndex);
  if (tiles_->unitsDone() == unitsTotal_ && stopReason_.empty()) stopReason_ = "all samples done";
}

std::vector<uint32_t> Accumulator::tilesDonePerFrame() const {
  std::lock_guard lock(mutex_);
  return tiles_ ? tiles_->tilesDonePerFrame() : std::vector<uint32_t>{};
}

}  // namespace lensfarm
