// The cross-worker audit (docs/farm.md "Audit"), driven directly (no network; the real-process
// test is tests/farm/audit_farm_test.cpp): the comparison, the book of units under audit, the
// film's rewind, and the coordinator's rule that a wrong worker is quarantined and the image
// keeps the bits a farm without it makes.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <thread>

#include "coordinator/core/accumulator.h"
#include "coordinator/core/audit.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/core/job_units.h"
#include "tests/coordinator/coordinator_fixtures.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

constexpr int kWidth = 4, kHeight = 3;

JobSpec auditSpec(uint64_t units, int width = kWidth, int height = kHeight) {
  json scene = test::minimalSceneJson();
  scene["render"]["samples_per_pixel"] = units;
  scene["render"]["samples_per_unit"] = 1;
  scene["render"]["resolution"] = {width, height};
  JobSpec spec;
  spec.sceneName = "audit.json";
  spec.sceneJson = scene.dump();
  return spec;
}

// A unit's result as a deterministic renderer gives it: every sum a function of the unit and the
// cell alone (values whose sums depend on their order), times `scale` (1 for an honest worker).
UnitResult rendered(const std::string& worker, const LeaseGrant& g, double scale = 1.0, int width = kWidth,
                    int height = kHeight) {
  UnitResult r = test::resultFor(worker, g, 0.0, 0.0, width, height);
  for (size_t k = 0; k < r.buffer.sums.size(); ++k)
    r.buffer.sums[k] = scale * (std::fmod(double(g.unit.index * 7919 + k * 104729) * 0.6180339887, 1.0) * 1e3 + 1e-3);
  return r;
}

struct Worker {
  std::string id;
  // Its sums for unit `u`, its n-th (from 0) result: 1 when honest.
  std::function<double(uint64_t n)> scale = [](uint64_t) { return 1.0; };
  uint64_t results = 0;
  std::function<void(UnitResult&)> alter = [](UnitResult&) {};  // after scaling
};

// Leases and uploads round-robin until the job ends (a quarantined worker is leased nothing).
void drive(Coordinator& c, const std::string& job, std::vector<Worker>& workers, int width = kWidth,
           int height = kHeight) {
  for (int round = 0; round < 20000 && !isTerminal(c.job(job).state); ++round)
    for (Worker& w : workers)
      if (auto g = c.lease(w.id, 0.0)) {
        UnitResult r = rendered(w.id, *g, w.scale(w.results++), width, height);
        w.alter(r);
        c.acceptResult(r);
      }
  ASSERT_TRUE(isTerminal(c.job(job).state)) << "the job never ended";
}

// The sensor a farm of one honest worker makes for the job, without audits.
std::string cleanSensor(uint64_t units) {
  Coordinator::Options options;
  options.auditFraction = 0.0;
  Coordinator c(options);
  const std::string job = c.submit(auditSpec(units), 0).id;
  std::vector<Worker> one = {{c.registerWorker(test::workerInfo("clean"))}};
  drive(c, job, one);
  return c.sensorState(job);
}

bool anyEventHas(const JobInfo& info, const std::string& part) {
  for (const auto& e : info.events)
    if (e.text.find(part) != std::string::npos) return true;
  return false;
}

std::string eventsOf(const JobInfo& info) {
  std::string all;
  for (const auto& e : info.events) all += e.text + "\n";
  return all;
}

const WorkerView& viewOf(const Coordinator& c, const std::string& id, std::vector<WorkerView>& keep) {
  keep = c.workers();
  for (const WorkerView& v : keep)
    if (v.id == id) return v;
  throw std::runtime_error("no worker " + id);
}

TEST(Audit, SumsDifferBeyondTheToleranceNameTheLargestDifferenceAndItsCell) {
  const std::vector<double> a = {1.0, 2.0, 0.0, 4.0, 5.0, 6.0};
  EXPECT_EQ(sumsDiffer(a, a, 0.0), std::nullopt);
  std::vector<double> b = a;
  b[4] *= 1.001;  // cell 1, relative 1e-3
  b[0] *= 1.0 + 1e-8;
  EXPECT_EQ(sumsDiffer(a, b, 1e-2), std::nullopt) << "within tolerance";
  const auto d = sumsDiffer(a, b, 1e-6);
  ASSERT_TRUE(d);
  EXPECT_NE(d->find("1.0e-03"), std::string::npos) << *d;
  EXPECT_NE(d->find("cell 1"), std::string::npos) << *d;
  b = a;
  b[2] = 1e-300;  // against an exact zero: relative difference 1
  EXPECT_TRUE(sumsDiffer(a, b, 1e-6));
  EXPECT_TRUE(sumsDiffer(a, std::vector<double>(3, 1.0), 1.0)) << "different sizes";
}

TEST(Audit, TheBookLeasesAUnitOnlyToWorkersThatDidNotRenderItAndAMajorityOfThreeDecides) {
  const auto sums = [](double v) { return std::make_shared<const std::vector<double>>(3, v); };
  AuditBook book;
  book.open(7, {"a", sums(1.0)}, 42);
  EXPECT_FALSE(book.lease("a")) << "the worker that rendered it";
  EXPECT_EQ(book.lease("b"), 7u);
  EXPECT_FALSE(book.lease("c")) << "leased to b";
  book.release(7, "b");
  EXPECT_EQ(book.lease("b"), 7u) << "released: b may take it again";

  // b agrees: both right, the audit closes.
  auto v = book.settle(7, {"b", nullptr}, std::nullopt, std::nullopt);
  ASSERT_TRUE(v);
  EXPECT_EQ(v->kind, AuditBook::Verdict::Kind::kAgreed);
  EXPECT_EQ(v->right, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(v->acceptedSeq, 42u);
  EXPECT_TRUE(book.empty());

  // b disagrees: c decides, against the counted result or against the dissent.
  for (const bool countedWrong : {true, false}) {
    book.open(3, {"a", sums(1.0)}, 1);
    ASSERT_EQ(book.lease("b"), 3u);
    v = book.settle(3, {"b", sums(2.0)}, std::string("differ"), std::nullopt);
    ASSERT_TRUE(v);
    EXPECT_EQ(v->kind, AuditBook::Verdict::Kind::kDisputed);
    EXPECT_FALSE(book.lease("b")) << "b rendered it";
    ASSERT_EQ(book.lease("c"), 3u);
    v = countedWrong ? book.settle(3, {"c", nullptr}, std::string("differ"), std::nullopt)
                     : book.settle(3, {"c", nullptr}, std::nullopt, std::string("differ"));
    ASSERT_TRUE(v);
    EXPECT_EQ(v->kind, AuditBook::Verdict::Kind::kSettled);
    EXPECT_EQ(v->wrong, countedWrong ? "a" : "b");
    EXPECT_TRUE(book.empty());
  }
  // Three that all differ: nobody is named.
  book.open(5, {"a", sums(1.0)}, 1);
  book.settle(5, {"b", sums(2.0)}, std::string("differ"), std::nullopt);
  v = book.settle(5, {"c", nullptr}, std::string("differ"), std::string("differ"));
  ASSERT_TRUE(v);
  EXPECT_EQ(v->kind, AuditBook::Verdict::Kind::kInconclusive);
  EXPECT_TRUE(v->wrong.empty());

  // A quarantined worker: audits of its results close, its dissent is withdrawn.
  book.open(1, {"x", sums(1.0)}, 1);
  book.open(2, {"a", sums(1.0)}, 2);
  book.settle(2, {"x", sums(2.0)}, std::string("differ"), std::nullopt);
  book.forgetWorker("x");
  EXPECT_FALSE(book.contains(1));
  ASSERT_TRUE(book.find(2));
  EXPECT_FALSE(book.find(2)->dissent);
}

// Units whose every sum is `value`, summed by an accumulator of `units` units of one sample.
UnitResult unitOf(uint64_t unit, const std::string& worker) {
  LeaseGrant g;
  g.jobId = "job-1";
  g.unit.index = unit;
  g.unit.sampleCount = 1;
  return rendered(worker, g);
}

TEST(Audit, TheFilmRewindsToABitwiseCopyAndSummingAgainGivesTheSameBits) {
  RenderSettings settings;
  settings.width = kWidth;
  settings.height = kHeight;
  settings.samplesPerPixel = 20;
  Accumulator reference(settings, 1, 20);
  for (uint64_t u = 0; u < 20; ++u) reference.add(unitOf(u, "a"), nullptr);

  Accumulator film(settings, 1, 20);
  film.keepRewindPoints(4, 3);  // copies after units 4, 8, 12
  for (uint64_t u = 0; u < 14; ++u) film.add(unitOf(u, "a"), nullptr);
  film.add(unitOf(16, "x"), nullptr);  // waiting for 14 and 15
  film.add(unitOf(17, "a"), nullptr);
  const uint64_t before = film.generation();
  const Accumulator::Rewound r = film.rewind(10, [](const UnitResult& u) { return u.workerId == "x"; });
  EXPECT_EQ(r.units, 8u) << "the latest copy at or before unit 10";
  EXPECT_EQ(r.kept, (std::set<uint64_t>{17})) << "x's waiting result is dropped";
  EXPECT_EQ(r.progress.units, 8u);
  EXPECT_EQ(r.progress.samplesPerPixel, 8u);
  EXPECT_GT(film.generation(), before);
  film.add(unitOf(9, "a"), nullptr, before);  // accepted before the rewind: ignored
  for (uint64_t u = 8; u < 20; ++u)
    if (u != 17) film.add(unitOf(u, "a"), nullptr, film.generation());
  EXPECT_TRUE(film.serializedSensor() == reference.serializedSensor()) << "the film differs from one summed once";
  EXPECT_EQ(film.develop().stats.paths, reference.develop().stats.paths);

  // Before the first copy: back to the empty film. After the newest: nothing summed is undone.
  Accumulator early(settings, 1, 20);
  early.keepRewindPoints(4, 3);
  for (uint64_t u = 0; u < 6; ++u) early.add(unitOf(u, "a"), nullptr);
  EXPECT_EQ(early.rewind(2, [](const UnitResult&) { return false; }).units, 0u);
  EXPECT_EQ(early.rewind(9, [](const UnitResult&) { return false; }).units, 0u) << "nothing summed at or after 9";
}

TEST(Audit, JobUnitsRewoundCountOnlyThePrefixAndTheKeptOnes) {
  JobUnits units(10);
  for (int i = 0; i < 8; ++i) units.markReceived(units.takePending());
  EXPECT_EQ(units.rewindTo(3, {5}), 4u) << "3, 4, 6, 7 are no longer counted";
  EXPECT_EQ(units.countedPrefix(), 3u);
  EXPECT_TRUE(units.isReceived(5));
  std::vector<uint64_t> order;
  while (units.hasPending()) order.push_back(units.takePending());
  EXPECT_EQ(order, (std::vector<uint64_t>{3, 4, 6, 7, 8, 9}));
}

// A farm where one worker multiplies its sums by 1.001: it is caught, quarantined, and the job
// ends with the bits of a farm of honest workers, whoever leased what first.
TEST(Audit, AWrongWorkerIsQuarantinedAndTheImageKeepsTheCleanBits) {
  const uint64_t units = 40;
  const std::string clean = cleanSensor(units);
  for (int rotation = 0; rotation < 4; ++rotation) {
    Coordinator::Options options;
    options.auditFraction = 0.1;
    Coordinator c(options);
    const std::string job = c.submit(auditSpec(units), 0).id;
    std::vector<Worker> workers;
    for (const char* name : {"a", "b", "c", "bad"}) workers.push_back({c.registerWorker(test::workerInfo(name))});
    const std::string bad = workers[3].id;
    workers[3].scale = [](uint64_t) { return 1.001; };
    std::rotate(workers.begin(), workers.begin() + rotation, workers.end());
    drive(c, job, workers);
    const JobInfo info = c.job(job);
    EXPECT_EQ(info.state, JobState::kDone) << info.error;
    EXPECT_TRUE(c.sensorState(job) == clean) << "rotation " << rotation << "\n" << eventsOf(info);
    std::vector<WorkerView> keep;
    const WorkerView& caught = viewOf(c, bad, keep);
    EXPECT_TRUE(caught.quarantined);
    EXPECT_NE(caught.quarantineReason.find("differ by up to 1.0e-03"), std::string::npos) << caught.quarantineReason;
    EXPECT_GE(info.auditsFailed, 1u);
    EXPECT_GE(info.auditsPassed, 1u);
    EXPECT_EQ(info.auditsPending, 0u);
    EXPECT_TRUE(anyEventHas(info, "bad (" + bad + ") is wrong")) << eventsOf(info);
    for (const Worker& w : workers)
      if (w.id != bad) {
        EXPECT_FALSE(viewOf(c, w.id, keep).quarantined) << w.id;
      }
    const MetricsSnapshot m = c.metricsSnapshot();
    EXPECT_EQ(m.auditsFailed, info.auditsFailed);
    EXPECT_EQ(m.unitsRerendered, info.unitsRerendered);
  }
}

// The same with every worker on a thread of its own, so that results arrive while a rewind runs
// (a unit accepted before the rewind and summed after it is dropped and rendered again).
TEST(Audit, WorkersOnTheirOwnThreadsStillGiveTheCleanBits) {
  const uint64_t units = 60;
  const std::string clean = cleanSensor(units);
  for (int iteration = 0; iteration < 10; ++iteration) {
    Coordinator::Options options;
    options.auditFraction = 0.3;
    Coordinator c(options);
    const std::string job = c.submit(auditSpec(units), 0).id;
    std::vector<Worker> workers;
    for (const char* name : {"a", "b", "c", "bad"}) workers.push_back({c.registerWorker(test::workerInfo(name))});
    // Wrong from its first result, which is always audited: caught in every iteration (a worker
    // wrong only later is caught with probability 1 - (1 - fraction)^units, as docs/farm.md says).
    workers[3].scale = [](uint64_t) { return 1.001; };
    std::vector<std::thread> threads;
    for (Worker& w : workers)
      threads.emplace_back([&c, &job, &w] {
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
        while (!isTerminal(c.job(job).state) && std::chrono::steady_clock::now() < deadline)
          if (auto g = c.lease(w.id, 0.02)) {
            try {
              c.acceptResult(rendered(w.id, *g, w.scale(w.results++)));
            } catch (const FarmError& e) {
              // Its lease was revoked meanwhile (it was quarantined, or the job stopped): what a
              // worker does is drop the unit.
              EXPECT_EQ(e.kind(), FarmError::Kind::kFailedPrecondition) << e.what();
            }
          }
      });
    for (std::thread& t : threads) t.join();
    const JobInfo info = c.job(job);
    ASSERT_EQ(info.state, JobState::kDone) << eventsOf(info);
    EXPECT_TRUE(c.sensorState(job) == clean) << "iteration " << iteration << "\n" << eventsOf(info);
  }
}

// A worker right at first and wrong from its 30th result on (a machine going bad): with every
// unit audited, it is caught at its first wrong result, and only units from the film's copy before
// it are rendered again, not the 30-odd before.
TEST(Audit, AWorkerGoingWrongIsCaughtAndOnlyUnitsSinceItsLastAgreeingAuditAreRenderedAgain) {
  const uint64_t units = 90;
  const std::string clean = cleanSensor(units);
  Coordinator::Options options;
  options.auditFraction = 1.0;
  Coordinator c(options);
  const std::string job = c.submit(auditSpec(units), 0).id;
  std::vector<Worker> workers;
  for (const char* name : {"a", "b", "turning"}) workers.push_back({c.registerWorker(test::workerInfo(name))});
  workers[2].scale = [](uint64_t n) { return n < 30 ? 1.0 : 1.001; };
  drive(c, job, workers);
  const JobInfo info = c.job(job);
  EXPECT_EQ(info.state, JobState::kDone) << info.error;
  EXPECT_TRUE(c.sensorState(job) == clean) << eventsOf(info);
  std::vector<WorkerView> keep;
  EXPECT_TRUE(viewOf(c, workers[2].id, keep).quarantined);
  EXPECT_GE(info.auditsPassed, 20u);
  EXPECT_LT(info.unitsRerendered, 12u) << "a rewind to the copy before its first wrong unit, not to the start\n"
                                       << eventsOf(info);
  EXPECT_TRUE(anyEventHas(info, "quarantined")) << eventsOf(info);
}

// Two workers that disagree, and no third: nobody can be named. The job ends, saying so.
TEST(Audit, TwoWorkersThatDisagreeWithNoThirdQuarantineNobody) {
  Coordinator::Options options;
  options.auditFraction = 0.02;
  Coordinator c(options);
  const std::string job = c.submit(auditSpec(6), 0).id;
  std::vector<Worker> workers = {{c.registerWorker(test::workerInfo("a"))}, {c.registerWorker(test::workerInfo("b"))}};
  workers[1].scale = [](uint64_t) { return 1.001; };
  drive(c, job, workers);
  const JobInfo info = c.job(job);
  EXPECT_EQ(info.state, JobState::kDone);
  EXPECT_TRUE(anyEventHas(info, "a third worker decides")) << eventsOf(info);
  EXPECT_TRUE(anyEventHas(info, "not settled: no other worker")) << eventsOf(info);
  std::vector<WorkerView> keep;
  for (const Worker& w : workers) EXPECT_FALSE(viewOf(c, w.id, keep).quarantined);
}

// A farm of two builds (docs/farm.md "Mixed machines"): a worker of another build whose results
// differ from the others' in one cell of 256 by 1e-5, as another compiler's or Embree's rounding
// does, is never quarantined: each disagreement is explained by the builds in an event, and counted
// as explained. The same difference from a worker of the same build, or a difference in every cell
// from a worker of another build, is a wrong result.
TEST(Audit, AnotherBuildsRoundingIsExplainedAndOnlyAWrongResultIsQuarantined) {
  const auto roundingInOneCell = [](UnitResult& r) { r.buffer.sums[40] *= 1.0 + 1e-5; };
  const auto infoOf = [](const std::string& name, const std::string& build) {
    WorkerInfo info = test::workerInfo(name);
    info.build = build;
    return info;
  };
  struct Case {
    std::string build;  // the odd worker's (the others': "gcc A")
    bool everyCell;     // its results differ in every cell (else in one)
    bool quarantined;
  };
  for (const Case& k : {Case{"gcc B", false, false}, Case{"gcc A", false, true}, Case{"gcc B", true, true}}) {
    SCOPED_TRACE(k.build + (k.everyCell ? ", every cell" : ", one cell"));
    Coordinator::Options options;
    options.auditFraction = 1.0;
    Coordinator c(options);
    const std::string job = c.submit(auditSpec(12, 16, 16), 0).id;
    std::vector<Worker> workers;
    for (const char* name : {"a", "b"}) workers.push_back({c.registerWorker(infoOf(name, "gcc A"))});
    workers.push_back({c.registerWorker(infoOf("odd", k.build))});
    if (k.everyCell)
      workers[2].scale = [](uint64_t) { return 1.001; };
    else
      workers[2].alter = roundingInOneCell;
    drive(c, job, workers, 16, 16);
    const JobInfo info = c.job(job);
    EXPECT_EQ(info.state, JobState::kDone) << info.error;
    std::vector<WorkerView> keep;
    EXPECT_EQ(viewOf(c, workers[2].id, keep).quarantined, k.quarantined) << eventsOf(info);
    EXPECT_FALSE(viewOf(c, workers[0].id, keep).quarantined);
    EXPECT_FALSE(viewOf(c, workers[1].id, keep).quarantined);
    if (!k.quarantined) {
      EXPECT_GE(info.auditsExplained, 1u) << eventsOf(info);
      EXPECT_EQ(info.auditsFailed, 0u) << eventsOf(info);
      EXPECT_TRUE(anyEventHas(info, "a difference of machines, not a wrong result")) << eventsOf(info);
      EXPECT_TRUE(anyEventHas(info, ": gcc B, kernel not said; the others: gcc A, kernel not said)")) << eventsOf(info);
    } else {
      EXPECT_EQ(info.auditsExplained, 0u) << eventsOf(info);
      EXPECT_GE(info.auditsFailed, 1u) << eventsOf(info);
    }
  }
}

TEST(Audit, RoundingLooksLikeAFewCellsAndASmallRmseAWrongResultDoesNot) {
  std::vector<double> a(3 * 100);
  for (size_t k = 0; k < a.size(); ++k) a[k] = 1.0 + double(k % 7);
  std::vector<double> b = a;
  b[5] *= 1.0 + 1e-4;  // one cell of 100: 1 %
  EXPECT_TRUE(differenceLooksLikeRounding(a, b, 1e-6));
  b[3 * 50] *= 1.0 + 1e-4;  // two cells of 100
  EXPECT_TRUE(differenceLooksLikeRounding(a, b, 1e-6));
  b[3 * 70] *= 1.0 + 1e-4;  // three: more than kRoundingCells
  EXPECT_FALSE(differenceLooksLikeRounding(a, b, 1e-6));
  b = a;
  b[0] *= 1.5;  // one cell, but far more than rounding: relative RMSE above kRoundingRmse
  EXPECT_FALSE(differenceLooksLikeRounding(a, b, 1e-6));
  EXPECT_FALSE(differenceLooksLikeRounding(a, std::vector<double>(3, 1.0), 1e-6)) << "different sizes";
}

// An audit never holds a job hostage: a worker that heartbeats but never asks for work is the only
// one that could render the pending audit (the other rendered the unit). The job says why it
// waits, and once auditWaitSeconds pass the next call waives the audit with an event naming the
// worker; the job ends with the counted result.
TEST(Audit, AnAuditNoWorkerTakesIsWaivedAndTheJobSaysWhyItWaits) {
  Coordinator::Options options;
  options.auditFraction = 1.0;
  options.auditWaitSeconds = 0.3;
  Coordinator c(options);
  const std::string job = c.submit(auditSpec(2), 0).id;
  const std::string honest = c.registerWorker(test::workerInfo("honest"));
  const std::string hung = c.registerWorker(test::workerInfo("hung"));
  c.heartbeat(hung, {});
  while (auto g = c.lease(honest, 0.0)) c.acceptResult(rendered(honest, *g));
  JobInfo info = c.job(job);
  ASSERT_EQ(info.unitsDone, 2u);
  ASSERT_EQ(info.state, JobState::kRunning) << "its audits are pending";
  EXPECT_NE(info.stalledReason.find("every unit is in; waiting for 2 audit(s)"), std::string::npos)
      << info.stalledReason;
  EXPECT_NE(info.stalledReason.find("waived in"), std::string::npos) << info.stalledReason;
  ASSERT_TRUE(test::waitFor(
      [&] {
        c.heartbeat(hung, {});  // it keeps heartbeating, and never asks for work
        c.lease(honest, 0.0);   // the honest worker's calls notice the wait is over
        return c.job(job).state == JobState::kDone;
      },
      30))
      << c.job(job).stalledReason;
  info = c.job(job);
  EXPECT_TRUE(anyEventHas(info, "not settled: waived after")) << eventsOf(info);
  EXPECT_TRUE(anyEventHas(info, "hung")) << eventsOf(info);
  EXPECT_EQ(c.sensorState(job), cleanSensor(2)) << "the counted results stand";
}

// One worker alone (`lensfarm render`) is never audited: nothing to compare with, nothing spent.
// Each agreeing audit is counted once per worker, by role: the counted unit's worker confirmed
// (auditsPassed), the worker that rendered it again (auditsRendered). Over a farm the two sums
// are each the job's passed audits: a count doubled (both roles as "passed") would give twice.
TEST(Audit, EachWorkersAuditsAreCountedOnceByRole) {
  Coordinator::Options options;
  options.auditFraction = 0.25;
  Coordinator c(options);
  const std::string job = c.submit(auditSpec(40), 0).id;
  std::vector<Worker> workers;
  for (const char* name : {"a", "b", "c"}) workers.push_back({c.registerWorker(test::workerInfo(name))});
  drive(c, job, workers);
  const JobInfo info = c.job(job);
  ASSERT_GE(info.auditsPassed, 3u) << "each worker's first unit at least";
  EXPECT_EQ(info.auditsFailed, 0u);
  uint64_t confirmed = 0, rendered = 0;
  std::vector<WorkerView> keep;
  for (const Worker& w : workers) {
    const WorkerView& v = viewOf(c, w.id, keep);
    EXPECT_GE(v.auditsPassed, 1u) << w.id << ": its first unit is audited";
    confirmed += v.auditsPassed, rendered += v.auditsRendered;
  }
  EXPECT_EQ(confirmed, info.auditsPassed);
  EXPECT_EQ(rendered, info.auditsPassed);
}

TEST(Audit, AFarmOfOneAuditsNothing) {
  Coordinator c;
  const std::string job = c.submit(auditSpec(8), 0).id;
  std::vector<Worker> one = {{c.registerWorker(test::workerInfo("alone"))}};
  drive(c, job, one);
  const JobInfo info = c.job(job);
  EXPECT_EQ(info.auditsPassed + info.auditsFailed + info.auditsPending, 0u);
  EXPECT_EQ(c.metricsSnapshot().unitsLeased, 8u);
}

// With a state dir, a rewind removes the undone units from the ledger: a coordinator restarted
// after the quarantine resumes the job and ends with the clean bits.
TEST(Audit, ARewindIsDurable) {
  const uint64_t units = 40;
  const std::string clean = cleanSensor(units);
  test::TempDir dir;
  Coordinator::Options options;
  options.auditFraction = 1.0;
  options.stateDir = dir / "state";
  std::string job;
  {
    Coordinator c(options);
    job = c.submit(auditSpec(units), 0).id;
    std::vector<Worker> workers;
    for (const char* name : {"a", "b", "turning"}) workers.push_back({c.registerWorker(test::workerInfo(name))});
    workers[2].scale = [](uint64_t n) { return n < 4 ? 1.0 : 1.001; };
    // Until the wrong worker is quarantined, then stop with the job unfinished.
    std::vector<WorkerView> keep;
    for (int round = 0; round < 1000 && !viewOf(c, workers[2].id, keep).quarantined; ++round)
      for (Worker& w : workers)
        if (auto g = c.lease(w.id, 0.0)) c.acceptResult(rendered(w.id, *g, w.scale(w.results++)));
    ASSERT_TRUE(viewOf(c, workers[2].id, keep).quarantined);
    ASSERT_FALSE(isTerminal(c.job(job).state)) << "stop before the end, to resume";
    ASSERT_GT(c.job(job).unitsRerendered, 0u);
  }
  options.auditFraction = 0.0;
  Coordinator resumed(options);
  std::vector<Worker> honest = {{resumed.registerWorker(test::workerInfo("after"))}};
  drive(resumed, job, honest);
  EXPECT_TRUE(resumed.sensorState(job) == clean) << "the resumed job differs from a clean run";
}

}  // namespace
}  // namespace lensfarm
