#include "upload_assembler.h"

#include <cstring>

#include "convert.h"

namespace lensfarm {

namespace {
constexpr uint64_t kMaxCells = uint64_t(1) << 28;  // 16384 x 16384, the scene format's limit

[[noreturn]] void refuse(const std::string& what) { throw FarmError(FarmError::Kind::kInvalidArgument, "UploadResult: " + what); }
}  // namespace

void UploadAssembler::add(const v1::UploadResultRequest& piece) {
  if (piece.has_header()) {
    if (haveHeader_) refuse("a second header");
    const v1::ResultHeader& h = piece.header();
    const uint64_t cells = uint64_t(h.width()) * h.height();
    if (h.width() == 0 || h.height() == 0 || h.width() > 16384 || h.height() > 16384 || cells > kMaxCells)
      refuse("bad frame size " + std::to_string(h.width()) + "x" + std::to_string(h.height()));
    result_.workerId = h.worker_id();
    result_.leaseId = h.lease_id();
    result_.jobId = h.job_id();
    result_.unitIndex = h.unit_index();
    result_.buffer = SensorBuffer(int(h.width()), int(h.height()));
    result_.stats = proto::fromProto(h.stats());
    result_.renderSeconds = h.stats().render_seconds();
    haveHeader_ = true;
  } else if (!haveHeader_) {
    refuse("the first piece must carry the header");
  }
  const std::string& bytes = piece.sums();
  if (bytes.size() % sizeof(double) != 0) refuse("a piece that is not whole doubles");
  const uint64_t count = bytes.size() / sizeof(double);
  if (piece.offset() != filled_) refuse("pieces out of order");
  if (count > result_.buffer.sums.size() - filled_) refuse("more sums than the frame holds");
  std::memcpy(result_.buffer.sums.data() + filled_, bytes.data(), bytes.size());
  filled_ += count;
}

UnitResult UploadAssembler::finish() {
  if (!haveHeader_) refuse("an empty stream");
  if (filled_ != result_.buffer.sums.size())
    refuse("truncated: " + std::to_string(filled_) + " of " + std::to_string(result_.buffer.sums.size()) + " sums");
  return std::move(result_);
}

}  // namespace lensfarm
