#include "coordinator/rpc/upload_assembler.h"

#include <cstring>

#include "coordinator/store/asset_store.h"
#include "proto/convert.h"

namespace lensfarm {

namespace {
constexpr uint64_t kMaxCells = uint64_t(1) << 28;  // 16384 x 16384, the scene format's limit

[[noreturn]] void refuse(const std::string& what) {
  throw FarmError(FarmError::Kind::kInvalidArgument, "UploadResult: " + what);
}
[[noreturn]] void refuseAsset(const std::string& what) {
  throw FarmError(FarmError::Kind::kInvalidArgument, "UploadAsset: " + what);
}
}  // namespace

const UploadHeader& UploadAssembler::begin(const v1::UploadResultRequest& first) {
  if (haveHeader_) refuse("a second header");
  if (!first.has_header()) refuse("the first piece must carry the header");
  const v1::ResultHeader& h = first.header();
  header_.workerId = h.worker_id();
  header_.session = h.session();
  header_.jobId = h.job_id();
  header_.leaseId = h.lease_id();
  header_.unitIndex = h.unit_index();
  header_.width = h.width();
  header_.height = h.height();
  header_.channels = h.channels() == 0 ? 3 : h.channels();
  header_.encoding = int(h.encoding());
  result_.stats = proto::fromProto(h.stats());
  result_.renderSeconds = h.stats().render_seconds();
  result_.kernel = h.kernel();
  haveHeader_ = true;
  return header_;
}

void UploadAssembler::add(const v1::UploadResultRequest& piece) {
  if (!haveHeader_) {
    begin(piece);
  } else if (piece.has_header() && pieces_ > 0) {
    refuse("a second header");
  }
  if (pieces_++ == 0) allocate();
  const std::string& bytes = piece.sums();
  wireBytes_ += bytes.size();
  if (piece.offset() != filled_) refuse("pieces out of order");
  const uint64_t room = result_.buffer.sums.size() - filled_;
  if (encoding_ == SumsEncoding::kShuffleZstd) {
    if (bytes.empty()) return;  // carries no block
    filled_ += decodeSumsBlock(bytes, result_.buffer.sums.data() + filled_, room,
                               "UploadResult: the block at offset " + std::to_string(filled_));
    return;
  }
  if (bytes.size() % sizeof(double) != 0) refuse("a piece that is not whole doubles");
  const uint64_t count = bytes.size() / sizeof(double);
  if (count > room) refuse("more sums than the frame holds");
  std::memcpy(result_.buffer.sums.data() + filled_, bytes.data(), bytes.size());
  filled_ += count;
}

void UploadAssembler::allocate() {
  const UploadHeader& h = header_;
  const uint64_t cells = uint64_t(h.width) * h.height;
  if (h.width == 0 || h.height == 0 || h.width > 16384 || h.height > 16384 || cells > kMaxCells)
    refuse("bad frame size " + std::to_string(h.width) + "x" + std::to_string(h.height));
  if (h.channels < 3 || h.channels > kMaxChannels)
    refuse("bad channel count " + std::to_string(h.channels) + " (3 to " + std::to_string(kMaxChannels) +
           " sums a cell, or 0 for 3)");
  if (h.encoding != v1::SUMS_ENCODING_RAW && h.encoding != v1::SUMS_ENCODING_SHUFFLE_ZSTD)
    refuse("unknown sums encoding " + std::to_string(h.encoding) +
           " (expected 0, SUMS_ENCODING_RAW, or 1, SUMS_ENCODING_SHUFFLE_ZSTD)");
  encoding_ = SumsEncoding(h.encoding);
  result_.workerId = h.workerId;
  result_.leaseId = h.leaseId;
  result_.jobId = h.jobId;
  result_.unitIndex = h.unitIndex;
  result_.buffer = SensorBuffer(int(h.width), int(h.height), int(h.channels));
}

UnitResult UploadAssembler::finish() {
  if (!haveHeader_) refuse("an empty stream");
  if (filled_ != result_.buffer.sums.size())
    refuse("truncated: " + std::to_string(filled_) + " of " + std::to_string(result_.buffer.sums.size()) + " sums");
  return std::move(result_);
}

static_assert(AssetUploadAssembler::kMaxChunkBytes == proto::kChunkBytes, "clients send chunks of at most this");

void AssetUploadAssembler::add(const v1::UploadAssetRequest& message) {
  const std::string chunk = "chunk[" + std::to_string(chunks_) + "]";
  const uint64_t size = message.chunk().data().size();
  if (chunks_ == 0) {
    if (message.sha256().empty()) refuseAsset("the first message must name the sha256");
    AssetStore::checkSha256(message.sha256(), "UploadAsset: sha256");
    declared_ = message.chunk().total_size();
    if (declared_ > kMaxAssetBytes)
      refuseAsset("total_size " + std::to_string(declared_) + " bytes: an asset is at most 2 GiB (" +
                  std::to_string(kMaxAssetBytes) + " bytes)");
    sha256_ = message.sha256();
  } else if (message.chunk().total_size() != 0 && message.chunk().total_size() != declared_) {
    refuseAsset(chunk + " declares total_size " + std::to_string(message.chunk().total_size()) + ", the first " +
                std::to_string(declared_));
  }
  if (size > kMaxChunkBytes)
    refuseAsset(chunk + " is " + std::to_string(size) + " bytes; a chunk is at most 1 MiB (" +
                std::to_string(kMaxChunkBytes) + " bytes)");
  if (size > declared_ - bytes_.size())
    refuseAsset(chunk + " goes past the declared total_size: " + std::to_string(bytes_.size() + size) + " bytes of " +
                std::to_string(declared_));
  bytes_ += message.chunk().data();
  ++chunks_;
}

std::string AssetUploadAssembler::finish() {
  if (chunks_ == 0) refuseAsset("the first message must name the sha256");
  if (bytes_.size() != declared_)
    refuseAsset("the stream ended after " + std::to_string(bytes_.size()) + " bytes of the declared total_size " +
                std::to_string(declared_));
  return std::move(bytes_);
}

}  // namespace lensfarm
