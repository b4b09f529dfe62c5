// TileFilm: a tiled job's float images, written tile by tile (tile_film.h).
#include "coordinator/core/tile_film.h"

#include <algorithm>
#include <utility>

namespace lensfarm {

TileFilm::TileFilm(JobLayout layout, AovLayout aovs)
    : layout_(std::move(layout)), aovs_(aovs), tilesDone_(layout_.frameCount(), 0) {}

TileFilm::Frame& TileFilm::frame(uint64_t frameIndex) {
  auto it = held_.find(frameIndex);
  if (it != held_.end()) return it->second;
  Frame f;
  f.image = Image{layout_.width, layout_.height, std::vector<float>(size_t(layout_.width) * layout_.height * 3, 0.0f)};
  if (aovs_.any()) f.image.layers = aovLayers(aovs_, layout_.width, layout_.height);
  f.workerOf.resize(layout_.unitsPerFrame());
  return held_.emplace(frameIndex, std::move(f)).first->second;
}

bool TileFilm::has(uint64_t u) const {
  const uint64_t f = layout_.frameIndexOf(u);
  if (completeFrames_.count(f)) return true;
  auto it = held_.find(f);
  return it != held_.end() && !it->second.workerOf[u % layout_.unitsPerFrame()].empty();
}

bool TileFilm::write(uint64_t u, const SensorBuffer& buffer, const std::string& worker) {
  if (has(u) || distrusted_.count(worker)) return false;
  const uint64_t f = layout_.frameIndexOf(u);
  Frame& fr = frame(f);
  const PixelRegion r = layout_.regionOf(u);
  const int w = layout_.width, h = layout_.height;
  // Sensor::mean and developImage, cell by cell: mean = value * (1 / n); image pixel (x, y) is
  // cell (W-1-x, H-1-y) (2013 report §4.7: the lens flips both axes).
  const double inv = 1.0 / double(layout_.samplesPerPixel);
  const size_t stride = size_t(aovs_.channels);
  for (int j = 0; j < r.height; ++j) {
    const int cy = r.y + j;
    for (int i = 0; i < r.width; ++i) {
      const int cx = r.x + i;
      const size_t src = stride * (size_t(j) * size_t(r.width) + size_t(i));
      const size_t pixel = size_t(h - 1 - cy) * size_t(w) + size_t(w - 1 - cx);
      for (int c = 0; c < 3; ++c) fr.image.rgb[3 * pixel + c] = float(buffer.sums[src + c] * inv);
      if (aovs_.any()) developAovPixel(aovs_, &buffer.sums[src], layout_.samplesPerPixel, pixel, fr.image.layers);
    }
  }
  fr.workerOf[u % layout_.unitsPerFrame()] = worker.empty() ? std::string("?") : worker;
  ++unitsDone_;
  if (++tilesDone_[f] == layout_.unitsPerFrame()) justCompleted_.push_back(f);
  return true;
}

std::vector<TileFilm::Completed> TileFilm::takeCompleted() {
  std::vector<Completed> out;
  for (uint64_t f : justCompleted_) {
    auto it = held_.find(f);
    if (it == held_.end()) continue;
    if (layout_.frames) {
      auto image = std::make_shared<const Image>(std::move(it->second.image));
      storing_[f] = image;
      out.push_back(Completed{f, std::move(image)});
      held_.erase(it);
      completeFrames_.insert(f);
    } else {
      out.push_back(Completed{f, nullptr});  // a still's image stays in the film: no copy
    }
  }
  justCompleted_.clear();
  return out;
}

std::optional<Image> TileFilm::image(uint64_t frameIndex) const {
  if (auto it = held_.find(frameIndex); it != held_.end()) return it->second.image;
  if (auto it = storing_.find(frameIndex); it != storing_.end()) return *it->second;
  return std::nullopt;
}

void TileFilm::stored(uint64_t frameIndex) { storing_.erase(frameIndex); }

void TileFilm::restoreComplete(uint64_t frameIndex) {
  if (frameIndex >= tilesDone_.size()) return;
  unitsDone_ += layout_.unitsPerFrame() - tilesDone_[frameIndex];
  tilesDone_[frameIndex] = uint32_t(layout_.unitsPerFrame());
  held_.erase(frameIndex);
  completeFrames_.insert(frameIndex);
}

std::set<uint64_t> TileFilm::forgetWorker(uint64_t from, const std::string& worker) {
  distrusted_.insert(worker);
  std::set<uint64_t> kept;
  const uint64_t perFrame = layout_.unitsPerFrame();
  for (uint64_t f : completeFrames_)
    for (uint64_t t = 0; t < perFrame; ++t)
      if (f * perFrame + t >= from) kept.insert(f * perFrame + t);
  for (auto& [f, fr] : held_) {
    for (uint64_t t = 0; t < perFrame; ++t) {
      const uint64_t u = f * perFrame + t;
      if (u < from || fr.workerOf[t].empty()) continue;
      if (fr.workerOf[t] == worker) {
        fr.workerOf[t].clear();
        --tilesDone_[f];
        --unitsDone_;
      } else {
        kept.insert(u);
      }
    }
  }
  return kept;
}

}  // namespace lensfarm
