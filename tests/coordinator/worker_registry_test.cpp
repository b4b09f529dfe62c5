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

}  // namespace
}  // namespace lensfarm
