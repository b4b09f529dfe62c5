#include "coordinator/core/worker_registry.h"

#include <random>

#include "common/util/error.h"

namespace lensfarm {

namespace {
// `bytes` random bytes from the operating system's generator (std::random_device: getrandom on
// Linux), as hex.
std::string randomHex(size_t bytes) {
  std::random_device random;
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (size_t k = 0; k < bytes; k += 4) {
    const uint32_t word = random();
    for (int b = 0; b < 4 && k + size_t(b) < bytes; ++b) {
      const uint32_t byte = (word >> (8 * b)) & 0xffu;
      out += digits[byte >> 4];
      out += digits[byte & 15u];
    }
  }
  return out;
}

// Equal strings, in a time that does not depend on where they differ.
bool sameSecret(const std::string& a, const std::string& b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  for (size_t k = 0; k < a.size(); ++k) diff |= static_cast<unsigned char>(a[k] ^ (k < b.size() ? b[k] : 0));
  return diff == 0;
}
}  // namespace

WorkerRecord* WorkerRegistry::liveByCredential(const std::string& credential) {
  if (credential.empty()) return nullptr;
  for (auto& [id, w] : workers_)
    if (!w->gone && w->info.credential == credential) return w.get();
  return nullptr;
}

WorkerRecord& WorkerRegistry::add(const WorkerInfo& info, Clock::time_point now, bool* replacedGone) {
  if (!info.credential.empty())
    for (auto& [id, w] : workers_)
      if (w->info.credential == info.credential) {  // the machine again: its record, a new session
        const bool wasGone = w->gone.has_value();
        WorkerRecord& record = *w;
        record.info = info;
        record.lastHeartbeat = now;
        record.session = randomHex(32);
        record.gone.reset();
        record.goneReason.clear();
        record.attachment = 0;
        record.currentJobId.clear();
        record.currentUnit.reset();
        ++record.registrations;
        if (replacedGone) *replacedGone = wasGone;
        return record;
      }
  auto worker = std::make_unique<WorkerRecord>();
  worker->id = "worker-" + std::to_string(epoch_) + "." + std::to_string(next_++);
  worker->info = info;
  worker->lastHeartbeat = now;
  worker->session = randomHex(32);
  // A lost or departed worker of the same name is this one back: the new entry replaces it.
  bool back = false;
  for (auto it = workers_.begin(); it != workers_.end();) {
    // (A credential's record stays: it is the machine's identity for the run.)
    const bool same = it->second->gone && !info.name.empty() && it->second->info.name == info.name &&
                      it->second->info.credential.empty();
    back |= same;
    it = same ? workers_.erase(it) : std::next(it);
  }
  if (replacedGone) *replacedGone = back;
  WorkerRecord& record = *worker;
  workers_[record.id] = std::move(worker);
  return record;
}

WorkerRecord& WorkerRegistry::find(const std::string& id) {
  auto it = workers_.find(id);
  if (it == workers_.end())
    throw FarmError(FarmError::Kind::kUnknownWorker, "unknown worker " + id + "; register again");
  if (it->second->gone)  // its leases were revoked: a live process must start afresh
    throw FarmError(FarmError::Kind::kUnknownWorker, "unknown worker " + id + " (" +
                                                         workerStateName(*it->second->gone) + ": " +
                                                         it->second->goneReason + "); register again");
  return *it->second;
}

WorkerRecord* WorkerRegistry::live(const std::string& id) {
  WorkerRecord* w = known(id);
  return w && !w->gone ? w : nullptr;
}

WorkerRecord* WorkerRegistry::known(const std::string& id) {
  auto it = workers_.find(id);
  return it == workers_.end() ? nullptr : it->second.get();
}

const WorkerRecord* WorkerRegistry::known(const std::string& id) const {
  auto it = workers_.find(id);
  return it == workers_.end() ? nullptr : it->second.get();
}

void WorkerRegistry::authenticate(const std::string& id, const std::string& session) {
  const WorkerRecord& worker = find(id);
  if (session.empty())
    throw FarmError(FarmError::Kind::kUnauthenticated,
                    "no session for " + id + ": quote RegisterResponse.session with the worker id");
  if (!sameSecret(session, worker.session))
    throw FarmError(FarmError::Kind::kPermissionDenied,
                    worker.info.credential.empty()
                        ? "the session is not " + id + "'s"
                        : "the session is not " + id + "'s current one: another worker registered with credential " +
                              worker.info.credential + " since (a credential is one machine; each needs its own)");
}

std::string WorkerRegistry::labelOf(const std::string& id) const {
  const WorkerRecord* w = known(id);
  return w ? w->label() : id;
}

void WorkerRegistry::forgetSilent(Clock::time_point now, Clock::duration forgetAfter) {
  for (auto it = workers_.begin(); it != workers_.end();)
    it = now - it->second->lastHeartbeat > forgetAfter && it->second->info.credential.empty() ? workers_.erase(it)
                                                                                              : std::next(it);
}

}  // namespace lensfarm
