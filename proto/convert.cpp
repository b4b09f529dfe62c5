#include "convert.h"

namespace lensfarm::proto {

v1::RenderOverrides toProto(const RenderOverrides& o) {
  v1::RenderOverrides p;
  if (o.samplesPerPixel) p.set_samples_per_pixel(*o.samplesPerPixel);
  if (o.width) p.set_width(uint32_t(*o.width));
  if (o.height) p.set_height(uint32_t(*o.height));
  if (o.maxBounces) p.set_max_bounces(uint32_t(*o.maxBounces));
  if (o.seed) p.set_seed(*o.seed);
  if (o.integrator) p.set_integrator(integratorName(*o.integrator));
  if (o.ev) p.set_ev(*o.ev);
  if (o.sampler) p.set_sampler(samplerName(*o.sampler));
  if (o.russianRoulette) p.set_russian_roulette(*o.russianRoulette);
  if (o.targetError) p.set_target_error(*o.targetError);
  if (o.timeLimitSeconds) p.set_time_limit_seconds(*o.timeLimitSeconds);
  if (o.tileSize) p.set_tile_size(*o.tileSize);
  if (o.aovs) p.set_aovs(aovListText(*o.aovs));
  if (o.adaptive) p.set_adaptive(*o.adaptive);
  return p;
}

RenderOverrides fromProto(const v1::RenderOverrides& p) {
  RenderOverrides o;
  if (p.has_samples_per_pixel()) o.samplesPerPixel = p.samples_per_pixel();
  if (p.has_width()) o.width = int(std::min<uint32_t>(p.width(), 1u << 30));
  if (p.has_height()) o.height = int(std::min<uint32_t>(p.height(), 1u << 30));
  if (p.has_max_bounces()) o.maxBounces = int(std::min<uint32_t>(p.max_bounces(), 1u << 30));
  if (p.has_seed()) o.seed = p.seed();
  if (p.has_integrator()) {
    IntegratorKind kind;
    if (!parseIntegratorName(p.integrator(), kind))
      throw FarmError(FarmError::Kind::kInvalidArgument, "overrides.integrator: unknown integrator \"" +
                                                             p.integrator() + "\" (expected nee_mis, nee or naive)");
    o.integrator = kind;
  }
  if (p.has_sampler()) {
    SamplerKind kind;
    if (!parseSamplerName(p.sampler(), kind))
      throw FarmError(FarmError::Kind::kInvalidArgument, "overrides.sampler: unknown sampler \"" + p.sampler() +
                                                             "\" (expected sobol, stratified or independent)");
    o.sampler = kind;
  }
  if (p.has_russian_roulette()) o.russianRoulette = p.russian_roulette();
  if (p.has_target_error()) o.targetError = p.target_error();
  if (p.has_time_limit_seconds()) o.timeLimitSeconds = p.time_limit_seconds();
  if (p.has_ev()) o.ev = p.ev();
  if (p.has_tile_size()) o.tileSize = p.tile_size();
  if (p.has_adaptive()) o.adaptive = p.adaptive();
  if (p.has_aovs()) {
    std::string bad;
    if (!parseAovList(p.aovs(), o.aovs.emplace(), &bad))
      throw FarmError(FarmError::Kind::kInvalidArgument,
                      "overrides.aovs: unknown AOV \"" + bad + "\" (expected " + aovNames() + ")");
  }
  return o;
}

v1::JobSpec toProto(const JobSpec& spec) {
  v1::JobSpec p;
  p.set_scene_name(spec.sceneName);
  p.set_scene_json(spec.sceneJson);
  for (const auto& [path, sha] : spec.assets) {
    auto* a = p.add_assets();
    a->set_path(path);
    a->set_sha256(sha);
  }
  *p.mutable_overrides() = toProto(spec.overrides);
  if (spec.frames) {
    p.mutable_frames()->set_first(spec.frames->first);
    p.mutable_frames()->set_last(spec.frames->last);
    p.mutable_frames()->set_step(spec.frames->step);
  }
  return p;
}

JobSpec fromProto(const v1::JobSpec& p) {
  JobSpec spec;
  spec.sceneName = p.scene_name();
  spec.sceneJson = p.scene_json();
  for (const auto& a : p.assets()) spec.assets[a.path()] = a.sha256();
  spec.overrides = fromProto(p.overrides());
  if (p.has_frames()) spec.frames = FrameRange{p.frames().first(), p.frames().last(), p.frames().step()};
  return spec;
}

v1::Lease toProto(const LeaseGrant& g) {
  v1::Lease p;
  p.set_lease_id(g.leaseId);
  p.set_job_id(g.jobId);
  p.set_unit_index(g.unit.index);
  p.set_first_sample(g.unit.firstSample);
  p.set_sample_count(g.unit.sampleCount);
  p.set_scene_hash(g.sceneHash);
  p.set_deadline_seconds(g.deadlineSeconds);
  p.set_frame(g.unit.frame);
  if (!g.unit.region.empty()) {
    p.set_region_x(uint32_t(g.unit.region.x));
    p.set_region_y(uint32_t(g.unit.region.y));
    p.set_region_width(uint32_t(g.unit.region.width));
    p.set_region_height(uint32_t(g.unit.region.height));
  }
  p.set_pass_samples(g.unit.passSamples);
  p.set_sums_encoding(v1::SumsEncoding(g.uploadEncoding));
  if (const SampleMap* map = g.unit.samples.get()) {
    v1::Lease::AdaptiveSamples& a = *p.mutable_adaptive();
    a.set_block_edge(uint32_t(map->blockEdge));
    a.set_pass_samples(map->passSamples);
    a.set_half(map->half);
    a.set_blocks_x(uint32_t(map->blocksX));
    a.set_blocks_y(uint32_t(map->blocksY));
    a.mutable_block_first()->Add(map->first.begin(), map->first.end());
    a.mutable_block_count()->Add(map->count.begin(), map->count.end());
  }
  return p;
}

LeaseGrant fromProto(const v1::Lease& p) {
  LeaseGrant g;
  g.leaseId = p.lease_id();
  g.jobId = p.job_id();
  g.unit = WorkUnit{p.unit_index(), p.first_sample(), p.sample_count()};
  g.unit.frame = p.frame();
  g.unit.region = PixelRegion{int(std::min<uint32_t>(p.region_x(), 1u << 30)), int(std::min<uint32_t>(p.region_y(), 1u << 30)),
                              int(std::min<uint32_t>(p.region_width(), 1u << 30)),
                              int(std::min<uint32_t>(p.region_height(), 1u << 30))};
  g.unit.passSamples = p.pass_samples();
  if (p.has_adaptive()) {
    // Checked against the frame where it is rendered (renderUnit: SampleMap::whyNotFor).
    const v1::Lease::AdaptiveSamples& a = p.adaptive();
    auto map = std::make_shared<SampleMap>();
    map->blockEdge = int(std::min<uint32_t>(a.block_edge(), 1u << 30));
    map->passSamples = a.pass_samples();
    map->half = a.half();
    map->first.assign(a.block_first().begin(), a.block_first().end());
    map->count.assign(a.block_count().begin(), a.block_count().end());
    map->blocksX = int(std::min<uint32_t>(a.blocks_x(), 1u << 30));
    map->blocksY = int(std::min<uint32_t>(a.blocks_y(), 1u << 30));
    g.unit.samples = std::move(map);
  }
  g.sceneHash = p.scene_hash();
  g.deadlineSeconds = p.deadline_seconds();
  // A value this worker does not know: raw, which every coordinator accepts.
  g.uploadEncoding = p.sums_encoding() == v1::SUMS_ENCODING_SHUFFLE_ZSTD ? SumsEncoding::kShuffleZstd : SumsEncoding::kRaw;
  return g;
}

v1::UnitStats toProto(const PathStats& s, double renderSeconds) {
  v1::UnitStats p;
  p.set_paths(s.paths);
  p.set_rays(s.rays);
  p.set_light_hits(s.lightHits);
  p.set_dropped(s.dropped);
  p.set_render_seconds(renderSeconds);
  return p;
}

PathStats fromProto(const v1::UnitStats& p) {
  PathStats s;
  s.paths = p.paths();
  s.rays = p.rays();
  s.lightHits = p.light_hits();
  s.dropped = p.dropped();
  return s;
}

}  // namespace lensfarm::proto
