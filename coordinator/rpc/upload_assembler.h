#pragma once
// Reassembles what a client stream uploads in pieces, checking everything the sender (or an
// attacker) could get wrong, so that nothing malformed is ever stored:
//  - UploadAssembler: a unit's result from an UploadResult stream: a missing or repeated header,
//    a bad frame size, an unknown encoding, pieces out of order, overlapping, too long or
//    misaligned, a compressed block that is corrupt, truncated or bigger than it may be
//    (farm/sums_codec.h), a truncated stream. Nothing it refuses ever reaches a job's sensor (Coordinator::acceptResult
//    checks the rest).
//  - AssetUploadAssembler: an asset's bytes from an UploadAsset stream: a hash that is not one, a
//    chunk over 1 MiB, bytes past or short of the declared total_size. AssetStore::put then checks
//    that the bytes hash to the name.
#include <cstdint>
#include <string>

#include "common/farm/farm_types.h"
#include "lensfarm/v1/client_service.pb.h"
#include "lensfarm/v1/worker_service.pb.h"

namespace lensfarm {

class AssetUploadAssembler {
 public:
  static constexpr uint64_t kMaxAssetBytes = uint64_t(2) << 30;  // 2 GiB
  static constexpr uint64_t kMaxChunkBytes = uint64_t(1) << 20;  // 1 MiB, as clients send (proto::kChunkBytes)

  // The next message of the stream. The first names the asset (sha256, 64 lowercase hex digits)
  // and its size (chunk.total_size); every one carries at most kMaxChunkBytes. Throws
  // FarmError(kInvalidArgument) naming what is wrong, a chunk by its index from 0 ("chunk[3]").
  void add(const v1::UploadAssetRequest& message);
  bool started() const { return chunks_ > 0; }
  const std::string& sha256() const { return sha256_; }  // once started
  uint64_t declared() const { return declared_; }        // once started: the asset's size
  // The asset's bytes, exactly total_size of them; throws FarmError(kInvalidArgument) for an
  // empty stream or one that ended short of its declared size.
  std::string finish();

 private:
  std::string sha256_;
  std::string bytes_;
  uint64_t declared_ = 0;  // the first message's total_size
  uint64_t chunks_ = 0;    // messages received
};

// What a result stream's first piece says (ResultHeader), decoded once: who sends it, for which
// lease and unit, and the shape and encoding of the sums that follow. `channels` is 3 where the
// header says 0 (an older worker).
struct UploadHeader {
  std::string workerId, session, jobId;
  uint64_t leaseId = 0, unitIndex = 0;
  uint32_t width = 0, height = 0, channels = 3;
  int encoding = 0;  // v1::SumsEncoding
};

class UploadAssembler {
 public:
  static constexpr uint32_t kMaxChannels = 64;  // sums a cell (ResultHeader.channels)
  // The first piece's header, decoded but not yet checked and nothing allocated: the caller
  // authenticates the sender and admits the upload (Coordinator::admitUpload) before any sum is
  // read. Then add() takes the same piece. Optional: add() begins by itself.
  const UploadHeader& begin(const v1::UploadResultRequest& first);
  // Throws FarmError(kInvalidArgument) naming what is wrong. Raw pieces are copied, compressed
  // ones (SUMS_ENCODING_SHUFFLE_ZSTD) decoded straight into the unit's buffer at their offset,
  // one block at a time: memory is the unit's buffer and one block, whatever a piece claims.
  void add(const v1::UploadResultRequest& piece);
  // Bytes of `sums` received so far, as sent (compressed or not).
  uint64_t wireBytes() const { return wireBytes_; }
  // The complete result; throws FarmError(kInvalidArgument) if the stream was truncated.
  UnitResult finish();

 private:
  void allocate();  // the header's sizes, channels and encoding checked; the unit's buffer
  UploadHeader header_;
  UnitResult result_;
  bool haveHeader_ = false;
  uint64_t pieces_ = 0;                         // added so far
  SumsEncoding encoding_ = SumsEncoding::kRaw;  // the header's
  uint64_t filled_ = 0;                         // doubles received so far
  uint64_t wireBytes_ = 0;                      // bytes of `sums` received so far
};

}  // namespace lensfarm
