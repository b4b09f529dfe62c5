#pragma once
// The checks a worker's upload meets, written once for every path a result takes: the gRPC
// header before its sums arrive (Coordinator::admitUpload), the whole result
// (Coordinator::accept, results.cpp) and an audit's result (Coordinator::acceptAudit,
// auditing.cpp). Each is called with the coordinator's mutex held; `JobT` is its private Job.
#include <cstdint>
#include <string>

#include "common/farm/farm_types.h"
#include "coordinator/core/lease_table.h"

namespace lensfarm {

// The job has unit `unit`.
template <class JobT>
void checkUnitExists(const JobT& job, uint64_t unit) {
  if (unit >= job.progress.units.total())
    throw FarmError(FarmError::Kind::kInvalidArgument,
                    "job " + job.definition.id + " has no unit " + std::to_string(unit));
}

// `leaseId` is `workerId`'s lease of that unit, still current.
inline void checkLeaseHeld(const LeaseTable& leases, uint64_t leaseId, const std::string& workerId,
                           const std::string& jobId, uint64_t unit) {
  if (!leases.covers(leaseId, workerId, jobId, unit))
    throw FarmError(FarmError::Kind::kFailedPrecondition, "lease " + std::to_string(leaseId) + " for unit " +
                                                              std::to_string(unit) + " of " + jobId +
                                                              " is not held by " + workerId);
}

// The buffer has the unit's region: the whole frame, or its tile.
template <class JobT>
void checkRegion(const JobT& job, uint64_t unit, int width, int height) {
  const PixelRegion region = job.definition.layout.regionOf(unit);
  if (width != region.width || height != region.height)
    throw FarmError(FarmError::Kind::kInvalidArgument,
                    "result for unit " + std::to_string(unit) + " of " + job.definition.id + " is " +
                        std::to_string(width) + "x" + std::to_string(height) + "; the unit covers " +
                        std::to_string(region.width) + "x" + std::to_string(region.height) + " cells at (" +
                        std::to_string(region.x) + ", " + std::to_string(region.y) + ")");
}

// The buffer holds the region's sums: its cells times the job's channels.
template <class JobT>
void checkSumCount(const JobT& job, uint64_t unit, size_t sums) {
  if (sums != job.definition.layout.sumsOf(unit))
    throw FarmError(FarmError::Kind::kInvalidArgument,
                    "result for unit " + std::to_string(unit) + " of " + job.definition.id + " carries " +
                        std::to_string(sums) + " sums; its region holds " +
                        std::to_string(job.definition.layout.sumsOf(unit)) + " (" +
                        std::to_string(job.definition.layout.channels) + " a cell: RGB and the job's AOVs)");
}

}  // namespace lensfarm
