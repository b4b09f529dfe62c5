// The farm's events (coordinator/core/event_feed.h, docs/api.md "Events") and changing a job's
// scheduling after submission (Coordinator::updateJob), on the plain Coordinator: the events of a
// job's life in order, numbered without gaps; the feed's window and long poll; an update that
// takes effect at once, survives a restart, and a refused one that changes nothing.
#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <set>
#include <string>

#include "coordinator/core/event_feed.h"
#include "tests/coordinator/coordinator_fixtures.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using test::workerInfo;

std::vector<std::string> typesOf(const std::vector<FarmEvent>& events, const std::string& jobId) {
  std::vector<std::string> types;
  for (const FarmEvent& e : events)
    if (e.jobId == jobId) types.push_back(e.type);
  return types;
}

Coordinator::Options noAudit() {
  Coordinator::Options o;
  o.auditFraction = 0.0;
  return o;
}

TEST(EventFeed, NumbersEventsWithoutGapsAndKeepsTheNewest) {
  EventFeed feed(3);
  EXPECT_EQ(feed.latest(), 0u);
  EXPECT_EQ(feed.oldest(), 1u);
  for (int i = 0; i < 5; ++i)
    feed.publish(FarmEvent{0, 0.0, farm_event::kJobDone, "job-" + std::to_string(i), "", "", ""});
  EXPECT_EQ(feed.latest(), 5u);
  EXPECT_EQ(feed.oldest(), 3u) << "three held: 3, 4, 5";
  const auto all = feed.after(0, 100);
  ASSERT_EQ(all.size(), 3u);
  EXPECT_EQ(all[0].sequence, 3u);
  EXPECT_EQ(all[2].jobId, "job-4");
  EXPECT_GT(all[0].unixSeconds, 1.7e9);
  EXPECT_EQ(feed.after(3, 100).size(), 2u);
  EXPECT_EQ(feed.after(4, 1).front().sequence, 5u);
  EXPECT_TRUE(feed.after(5, 100).empty());
  EXPECT_TRUE(feed.after(99, 100).empty());
}

TEST(EventFeed, ALongPollWakesAtTheNextEvent) {
  EventFeed feed;
  const auto start = std::chrono::steady_clock::now();
  auto waiting = std::async(std::launch::async, [&] { return feed.after(0, 10, std::chrono::seconds(20)); });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  feed.publish(FarmEvent{0, 0.0, farm_event::kWorkerJoined, "", "w1", "", ""});
  const auto events = waiting.get();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].workerId, "w1");
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10)) << "woken, not timed out";
}

TEST(FarmEvents, AJobsLifeIsPublishedInOrder) {
  Coordinator c(noAudit());
  const std::string job = c.submit(test::minimalSpec(2), 0, "ann").id;
  const std::string w = c.registerWorker(workerInfo("w1"));
  c.pauseJob(job);
  c.resumeJob(job);
  c.approveJob(job);
  for (int i = 0; i < 2; ++i) {
    const auto g = c.lease(w, 0.0);
    ASSERT_TRUE(g);
    ASSERT_TRUE(c.acceptResult(test::resultFor(w, *g, 0.5)));
  }
  ASSERT_TRUE(test::waitFor([&] { return c.job(job).state == JobState::kDone; }, 30));
  const auto events = c.events().after(0, 100);
  EXPECT_EQ(typesOf(events, job), (std::vector<std::string>{"job.submitted", "job.paused", "job.resumed",
                                                            "job.approved", "job.started", "job.done"}));
  for (size_t i = 0; i < events.size(); ++i) EXPECT_EQ(events[i].sequence, i + 1);
  EXPECT_EQ(events[0].owner, "ann");
  const auto joined =
      std::find_if(events.begin(), events.end(), [](const FarmEvent& e) { return e.type == "worker.joined"; });
  ASSERT_NE(joined, events.end());
  EXPECT_EQ(joined->workerId, w);
  c.workerLost(w, "connection closed");
  EXPECT_EQ(c.events().after(0, 100).back().type, "worker.lost");
}

TEST(FarmEvents, UpdatingAJobTakesEffectAtOnceAndARefusedUpdateChangesNothing) {
  test::TempDir dir;
  Coordinator::Options options = noAudit();
  options.stateDir = dir.path();
  std::string job;
  {
    Coordinator c(options);
    job = c.submit(test::minimalSpec(10), 0, "ann").id;
    Coordinator::JobUpdate update;
    update.priority = 4;
    update.maxWorkers = 1;
    update.shareWeight = 2.5;
    const JobInfo updated = c.updateJob(job, update);
    EXPECT_EQ(updated.priority, 4);
    EXPECT_EQ(updated.policy.maxWorkers, std::optional<uint32_t>(1));
    EXPECT_EQ(updated.policy.shareWeight, 2.5);
    const std::string w1 = c.registerWorker(workerInfo("w1")), w2 = c.registerWorker(workerInfo("w2"));
    ASSERT_TRUE(c.lease(w1, 0.0));
    EXPECT_FALSE(c.lease(w2, 0.0)) << "the cap of 1 holds at once";
    Coordinator::JobUpdate zero;
    zero.maxWorkers = 0;
    zero.priority = 9;
    EXPECT_EQ(test::kindOf([&] { c.updateJob(job, zero); }), FarmError::Kind::kInvalidArgument);
    EXPECT_EQ(c.job(job).priority, 4) << "a refused update changes nothing";
    EXPECT_EQ(test::kindOf([&] { c.updateJob("job-99", update); }), FarmError::Kind::kNotFound);
  }
  Coordinator c(options);  // durable
  EXPECT_EQ(c.job(job).priority, 4);
  EXPECT_EQ(c.job(job).policy.maxWorkers, std::optional<uint32_t>(1));
  EXPECT_EQ(c.job(job).policy.shareWeight, 2.5);
}

}  // namespace
}  // namespace lensfarm
