#pragma once
// Reassembles a unit's result from the pieces of an UploadResult stream, checking everything a
// worker (or an attacker) could get wrong: a missing or repeated header, a bad frame size,
// pieces out of order, overlapping, too long or misaligned, a truncated stream. Nothing it
// refuses ever reaches a job's sensor (Coordinator::acceptResult checks the rest).
#include "farm/farm_types.h"
#include "lensfarm/v1/worker_service.pb.h"

namespace lensfarm {

class UploadAssembler {
 public:
  // Throws FarmError(kInvalidArgument) naming what is wrong.
  void add(const v1::UploadResultRequest& piece);
  // The complete result; throws FarmError(kInvalidArgument) if the stream was truncated.
  UnitResult finish();

 private:
  UnitResult result_;
  bool haveHeader_ = false;
  uint64_t filled_ = 0;  // doubles received so far
};

}  // namespace lensfarm
