// The rules of a worker's identity (coordinator/core/worker_registry.h), on the registry alone.
#include "coordinator/core/worker_registry.h"

#include <gtest/gtest.h>

#include "common/util/error.h"
#include "tests/coordinator/coordinator_fixtures.h"

namespace lensfarm {
namespace {

using Clock = WorkerRegistry::Clock;
using test::kindOf;

WorkerInfo named(const std::string& name) {
  WorkerInfo info;
  info.name = name;
  return info;
}

TEST(WorkerRegistry, IdsNameTheRunAndAreNeverReissued) {
  WorkerRegistry r;
  r.setEpoch(7);
  const auto now = Clock::now();
  const std::string a = r.add(named("a"), now, nullptr).id, b = r.add(named("b"), now, nullptr).id;
  EXPECT_EQ(a, "worker-7.1");
  EXPECT_EQ(b, "worker-7.2");
  r.forgetSilent(now + std::chrono::hours(1), std::chrono::seconds(60));
  EXPECT_EQ(r.size(), 0u);
  EXPECT_EQ(r.add(named("a"), now, nullptr).id, "worker-7.3") << "a forgotten id is not issued again";
}

TEST(WorkerRegistry, OnlyTheIssuedSessionAuthenticates) {
  WorkerRegistry r;
  WorkerRecord& w = r.add(named("a"), Clock::now(), nullptr);
  EXPECT_EQ(w.session.size(), 64u) << "32 random bytes as hex";
  EXPECT_NO_THROW(r.authenticate(w.id, w.session));
  EXPECT_EQ(kindOf([&] { r.authenticate(w.id, ""); }), FarmError::Kind::kUnauthenticated);
  std::string other = w.session;
  other.back() = other.back() == '0' ? '1' : '0';
  EXPECT_EQ(kindOf([&] { r.authenticate(w.id, other); }), FarmError::Kind::kPermissionDenied);
  EXPECT_EQ(kindOf([&] { r.authenticate("worker-0.99", w.session); }), FarmError::Kind::kUnknownWorker);
  EXPECT_NE(r.add(named("b"), Clock::now(), nullptr).session, w.session);
}

TEST(WorkerRegistry, AGoneWorkersIdIsRefusedAndItsNameReplacedByTheNextOfThatName) {
  WorkerRegistry r;
  WorkerRecord& w = r.add(named("render-3"), Clock::now(), nullptr);
  const std::string id = w.id;
  w.gone = WorkerState::kLost;
  w.goneReason = "connection closed";
  EXPECT_EQ(kindOf([&] { r.find(id); }), FarmError::Kind::kUnknownWorker);
  EXPECT_EQ(r.live(id), nullptr);
  ASSERT_NE(r.known(id), nullptr) << "still listed as lost";
  EXPECT_EQ(r.labelOf(id), "render-3 (" + id + ")");
  bool replaced = false;
  const std::string back = r.add(named("render-3"), Clock::now(), &replaced).id;
  EXPECT_TRUE(replaced);
  EXPECT_EQ(r.known(id), nullptr) << "the lost entry gave way to the worker back";
  EXPECT_EQ(&r.find(back), r.live(back));
  r.add(named(""), Clock::now(), &replaced);
  EXPECT_FALSE(replaced) << "an unnamed worker replaces no one";
}

TEST(WorkerRegistry, OnlyWorkersSilentForTheWholeSpanAreForgotten) {
  WorkerRegistry r;
  const auto t0 = Clock::now();
  const std::string old = r.add(named("old"), t0, nullptr).id;
  const std::string recent = r.add(named("recent"), t0 + std::chrono::seconds(50), nullptr).id;
  r.forgetSilent(t0 + std::chrono::seconds(61), std::chrono::seconds(60));
  EXPECT_EQ(r.known(old), nullptr);
  EXPECT_NE(r.known(recent), nullptr);
}

// A credential is one machine for the run: each registration of it gets the same id and record
// (its quarantine kept) with a new session, the last one superseding the one before; a gone
// credential's record is not forgotten, so its id and counts come back with it.
TEST(WorkerRegistry, ACredentialIsOneRecordWhateverItsRegistrations) {
  WorkerRegistry r;
  WorkerInfo info = named("gpu-a");
  info.credential = "gpu-a";
  WorkerRecord& first = r.add(info, Clock::now(), nullptr);
  const std::string id = first.id, session = first.session;
  first.quarantined = true;
  EXPECT_EQ(r.liveByCredential("gpu-a"), &first);
  EXPECT_EQ(r.liveByCredential(""), nullptr);
  info.name = "another-name";
  WorkerRecord& again = r.add(info, Clock::now(), nullptr);
  EXPECT_EQ(again.id, id);
  EXPECT_EQ(again.registrations, 2u);
  EXPECT_TRUE(again.quarantined) << "a quarantined machine stays quarantined when it registers again";
  EXPECT_NE(again.session, session);
  EXPECT_EQ(kindOf([&] { r.authenticate(id, session); }), FarmError::Kind::kPermissionDenied);
  EXPECT_NO_THROW(r.authenticate(id, again.session));
  again.gone = WorkerState::kLost;
  r.forgetSilent(Clock::now() + std::chrono::hours(1), std::chrono::seconds(60));
  ASSERT_NE(r.known(id), nullptr) << "a credential's record is kept";
  bool back = false;
  EXPECT_EQ(r.add(info, Clock::now(), &back).id, id);
  EXPECT_TRUE(back);
  EXPECT_EQ(r.size(), 1u);
  EXPECT_NE(r.add(named("gpu-a"), Clock::now(), nullptr).id, id) << "the shared token's worker of that name is another";
}

}  // namespace
}  // namespace lensfarm
