#include "proto/convert.h"

#include <nlohmann/json.hpp>

#include <stdexcept>

#include "common/util/error.h"

namespace lensfarm::proto {

// The overrides travel field by field through overrideTable(): each row's name is its field in
// lensfarm.v1.RenderOverrides (a test holds the two lists equal), its value JSON of the field's type.
namespace {

using google::protobuf::FieldDescriptor;

const FieldDescriptor& overrideField(const std::string& name) {
  const FieldDescriptor* f = v1::RenderOverrides::descriptor()->FindFieldByName(name);
  if (!f) throw std::logic_error("lensfarm.v1.RenderOverrides has no field " + name);
  return *f;
}

}  // namespace

v1::RenderOverrides toProto(const RenderOverrides& o) {
  v1::RenderOverrides p;
  const auto* reflection = p.GetReflection();
  for (const OverrideRow& row : overrideTable()) {
    const std::optional<nlohmann::json> v = row.get(o);
    if (!v) continue;
    const FieldDescriptor& f = overrideField(row.name);
    switch (f.cpp_type()) {
      case FieldDescriptor::CPPTYPE_UINT64: reflection->SetUInt64(&p, &f, v->get<uint64_t>()); break;
      case FieldDescriptor::CPPTYPE_UINT32: reflection->SetUInt32(&p, &f, uint32_t(v->get<int64_t>())); break;
      case FieldDescriptor::CPPTYPE_INT32: reflection->SetInt32(&p, &f, v->get<int32_t>()); break;
      case FieldDescriptor::CPPTYPE_DOUBLE: reflection->SetDouble(&p, &f, v->get<double>()); break;
      case FieldDescriptor::CPPTYPE_BOOL: reflection->SetBool(&p, &f, v->get<bool>()); break;
      case FieldDescriptor::CPPTYPE_STRING: reflection->SetString(&p, &f, v->get<std::string>()); break;
      default: throw std::logic_error("RenderOverrides." + row.name + ": a field type the table does not carry");
    }
  }
  return p;
}

RenderOverrides fromProto(const v1::RenderOverrides& p) {
  RenderOverrides o;
  const auto* reflection = p.GetReflection();
  for (const OverrideRow& row : overrideTable()) {
    const FieldDescriptor& f = overrideField(row.name);
    if (!reflection->HasField(p, &f)) continue;
    nlohmann::json v;
    switch (f.cpp_type()) {
      case FieldDescriptor::CPPTYPE_UINT64: v = reflection->GetUInt64(p, &f); break;
      case FieldDescriptor::CPPTYPE_UINT32: v = reflection->GetUInt32(p, &f); break;
      case FieldDescriptor::CPPTYPE_INT32: v = reflection->GetInt32(p, &f); break;
      case FieldDescriptor::CPPTYPE_DOUBLE: v = reflection->GetDouble(p, &f); break;
      case FieldDescriptor::CPPTYPE_BOOL: v = reflection->GetBool(p, &f); break;
      case FieldDescriptor::CPPTYPE_STRING: v = reflection->GetString(p, &f); break;
      default: throw std::logic_error("RenderOverrides." + row.name + ": a field type the table does not carry");
    }
    try {
      row.set(o, v);
    } catch (const InputError& e) {
      throw FarmError(FarmError::Kind::kInvalidArgument, e.what());
    }
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

namespace {
struct ConditionPair {
  Dependency::Condition plain;
  v1::DependencyCondition wire;
};
constexpr ConditionPair kConditionPairs[] = {
    {Dependency::Condition::kDone, v1::DEPENDENCY_CONDITION_DONE},
    {Dependency::Condition::kFailed, v1::DEPENDENCY_CONDITION_FAILED},
    {Dependency::Condition::kEnded, v1::DEPENDENCY_CONDITION_ENDED},
    {Dependency::Condition::kErrorAtMost, v1::DEPENDENCY_CONDITION_ERROR_AT_MOST},
    {Dependency::Condition::kApproved, v1::DEPENDENCY_CONDITION_APPROVED}};
}  // namespace

v1::JobPolicy toProto(const JobPolicy& policy) {
  v1::JobPolicy p;
  for (const Dependency& d : policy.after) {
    v1::Dependency* out = p.add_after();
    out->set_job_id(d.jobId);
    for (const ConditionPair& c : kConditionPairs)
      if (c.plain == d.condition) out->set_condition(c.wire);
    out->set_max_error(d.maxError);
  }
  p.set_on_dependency_failure(policy.onDependencyFailure == OnDependencyFailure::kWait ? v1::DEPENDENCY_FAILURE_WAIT
                                                                                       : v1::DEPENDENCY_FAILURE_FAIL);
  for (const std::string& t : policy.requireTags) p.add_require_tags(t);
  for (const std::string& t : policy.preferTags) p.add_prefer_tags(t);
  for (const std::string& t : policy.auditRequireTags) p.add_audit_require_tags(t);
  if (policy.maxWorkers) p.set_max_workers(*policy.maxWorkers);
  p.set_share_weight(policy.shareWeight);
  if (policy.maxUnitFailures) p.set_max_unit_failures(*policy.maxUnitFailures);
  if (policy.maxWorkerFailures) p.set_max_worker_failures(*policy.maxWorkerFailures);
  if (policy.unitTimeLimitSeconds) p.set_unit_time_limit_seconds(*policy.unitTimeLimitSeconds);
  p.set_on_failure(policy.onFailure == OnFailure::kPause ? v1::ON_FAILURE_PAUSE : v1::ON_FAILURE_FAIL);
  return p;
}

JobPolicy fromProto(const v1::JobPolicy& p) {
  JobPolicy policy;
  for (int i = 0; i < p.after_size(); ++i) {
    const v1::Dependency& in = p.after(i);
    Dependency d;
    d.jobId = in.job_id();
    d.maxError = in.max_error();
    bool known = in.condition() == v1::DEPENDENCY_CONDITION_UNSPECIFIED;
    for (const ConditionPair& c : kConditionPairs)
      if (c.wire == in.condition()) d.condition = c.plain, known = true;
    if (!known)
      throw FarmError(FarmError::Kind::kInvalidArgument, "after[" + std::to_string(i) + "].condition: unknown value " +
                                                             std::to_string(int(in.condition())));
    policy.after.push_back(d);
  }
  if (p.on_dependency_failure() != v1::DEPENDENCY_FAILURE_UNSPECIFIED &&
      p.on_dependency_failure() != v1::DEPENDENCY_FAILURE_FAIL &&
      p.on_dependency_failure() != v1::DEPENDENCY_FAILURE_WAIT)
    throw FarmError(FarmError::Kind::kInvalidArgument,
                    "on_dependency_failure: unknown value " + std::to_string(int(p.on_dependency_failure())));
  policy.onDependencyFailure = p.on_dependency_failure() == v1::DEPENDENCY_FAILURE_WAIT ? OnDependencyFailure::kWait
                                                                                        : OnDependencyFailure::kFail;
  policy.requireTags.assign(p.require_tags().begin(), p.require_tags().end());
  policy.preferTags.assign(p.prefer_tags().begin(), p.prefer_tags().end());
  policy.auditRequireTags.assign(p.audit_require_tags().begin(), p.audit_require_tags().end());
  if (p.has_max_workers()) policy.maxWorkers = p.max_workers();
  policy.shareWeight = p.share_weight() == 0.0 ? 1.0 : p.share_weight();
  if (p.has_max_unit_failures()) policy.maxUnitFailures = p.max_unit_failures();
  if (p.has_max_worker_failures()) policy.maxWorkerFailures = p.max_worker_failures();
  if (p.has_unit_time_limit_seconds()) policy.unitTimeLimitSeconds = p.unit_time_limit_seconds();
  if (p.on_failure() != v1::ON_FAILURE_UNSPECIFIED && p.on_failure() != v1::ON_FAILURE_FAIL &&
      p.on_failure() != v1::ON_FAILURE_PAUSE)
    throw FarmError(FarmError::Kind::kInvalidArgument,
                    "on_failure: unknown value " + std::to_string(int(p.on_failure())));
  policy.onFailure = p.on_failure() == v1::ON_FAILURE_PAUSE ? OnFailure::kPause : OnFailure::kFail;
  return policy;
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
  p.set_kernel(g.kernel);
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
  g.unit.region = PixelRegion{
      int(std::min<uint32_t>(p.region_x(), 1u << 30)), int(std::min<uint32_t>(p.region_y(), 1u << 30)),
      int(std::min<uint32_t>(p.region_width(), 1u << 30)), int(std::min<uint32_t>(p.region_height(), 1u << 30))};
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
  g.kernel = p.kernel();
  // A value this worker does not know: raw, which every coordinator accepts.
  g.uploadEncoding =
      p.sums_encoding() == v1::SUMS_ENCODING_SHUFFLE_ZSTD ? SumsEncoding::kShuffleZstd : SumsEncoding::kRaw;
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

v1::FarmEvent toProto(const FarmEvent& e) {
  v1::FarmEvent out;
  out.set_sequence(e.sequence);
  out.set_unix_seconds(e.unixSeconds);
  out.set_type(e.type);
  out.set_job_id(e.jobId);
  out.set_worker_id(e.workerId);
  out.set_owner(e.owner);
  out.set_text(e.text);
  return out;
}

}  // namespace lensfarm::proto
