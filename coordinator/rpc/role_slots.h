#pragma once
// At most `perRole` calls of one kind at once per role (client, viewer, anyone): a Download
// stream holds a gRPC server thread for as long as its client takes to read it, so a role that
// opens streams and never reads them is stopped at the cap instead of taking a thread per stream
// (docs/farm.md "Limits"). take() gives a slot, returned when it is destroyed. Thread-safe.
#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace lensfarm {

class RoleSlots {
  struct State {
    std::mutex mutex;
    std::map<std::string, size_t> taken;
  };

 public:
  explicit RoleSlots(size_t perRole) : state_(std::make_shared<State>()), perRole_(perRole) {}

  class Slot {
   public:
    Slot(Slot&& other) noexcept = default;
    Slot& operator=(Slot&&) = delete;
    ~Slot() {
      if (!state_) return;
      std::lock_guard lock(state_->mutex);
      --state_->taken[role_];
    }

   private:
    friend class RoleSlots;
    Slot(std::shared_ptr<State> state, std::string role) : state_(std::move(state)), role_(std::move(role)) {}
    std::shared_ptr<State> state_;
    std::string role_;
  };

  // A slot for `role`, or nullopt when it holds perRole() already.
  std::optional<Slot> take(const std::string& role) {
    std::lock_guard lock(state_->mutex);
    size_t& taken = state_->taken[role];
    if (taken >= perRole_) return std::nullopt;
    ++taken;
    return Slot(state_, role);
  }
  size_t perRole() const { return perRole_; }

 private:
  std::shared_ptr<State> state_;
  size_t perRole_;
};

}  // namespace lensfarm
