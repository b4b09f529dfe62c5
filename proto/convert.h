#pragma once
// Translations between the farm's plain C++ types (common/farm/farm_types.h) and the lensfarm.v1
// messages. Both services and every client use these, so a field is mapped in one place.
#include "common/farm/farm_event.h"
#include "common/farm/farm_types.h"
#include "common/farm/job_policy.h"
#include "lensfarm/v1/client_service.pb.h"
#include "lensfarm/v1/common.pb.h"
#include "lensfarm/v1/worker_service.pb.h"

namespace lensfarm::proto {

v1::RenderOverrides toProto(const RenderOverrides& o);
RenderOverrides fromProto(const v1::RenderOverrides& o);

v1::JobSpec toProto(const JobSpec& spec);
JobSpec fromProto(const v1::JobSpec& spec);

// Unspecified enums read as their defaults (done, fail), a share weight of 0 as 1; fromProto
// does not check the policy (Coordinator::submit does, naming the field).
v1::JobPolicy toProto(const JobPolicy& policy);
v1::FarmEvent toProto(const FarmEvent& event);
JobPolicy fromProto(const v1::JobPolicy& policy);

v1::Lease toProto(const LeaseGrant& grant);
LeaseGrant fromProto(const v1::Lease& lease);

v1::UnitStats toProto(const PathStats& stats, double renderSeconds);
PathStats fromProto(const v1::UnitStats& stats);

// Largest piece of a file or buffer per message: far below gRPC's 4 MiB default.
inline constexpr size_t kChunkBytes = size_t(1) << 20;

}  // namespace lensfarm::proto
