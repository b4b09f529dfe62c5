// lensfarm-scale: one coordinator under a thousand workers
// (docs/performance.md "The farm at scale"). The real lensfarm-coordinator runs
// as a child process (temp state dir, tokens, audit on as in production);
// simulated workers (bench/scale/simulated_farm.h) register, long-poll leases,
// heartbeat and upload exactly the leased region over real gRPC on loopback,
// each on its own connection, after sleeping for the unit's "render". Their
// values are known (bench/scale/synthetic_image.h), so the downloaded image
// proves that no unit was lost or counted twice.
//
// Per run (one job on a fresh coordinator) it reports the coordinator's CPU
// seconds and share of wall time, its peak resident memory against a bound
// derived from the job, the unit bytes it received (its metrics endpoint),
// p50/p99/max latency of each call kind as the workers saw it, units per
// second, and the time from the last unit's acknowledgment to the final image
// being downloaded. Before the job, the registered farm idles for a few
// seconds: the coordinator's CPU per idle call (heartbeats and empty long
// polls) is measured there, so the per-unit CPU can be told apart from it.
//
//   build/bench/lensfarm-scale --workers 1000                      (make load:
//   the two full-size jobs) build/bench/lensfarm-scale --workers 200 --still
//   960x540 --animation 480x270 --frames 24
//
// Exit code 0 when every job finished with the exact image within the memory
// bound, 1 otherwise.
#include <sys/resource.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "bench/scale/coordinator_process.h"
#include "bench/scale/simulated_farm.h"
#include "bench/scale/synthetic_image.h"
#include "common/farm/memory_estimate.h"
#include "common/film/image_io.h"
#include "common/scene/render_overrides.h"
#include "coordinator/core/audit.h"
#include "lensfarm/v1/client_service.grpc.pb.h"
#include "proto/channel_security.h"
#include "proto/convert.h"

namespace lensfarm::scale {
namespace {

using Clock = std::chrono::steady_clock;
using json = nlohmann::json;

// MemAvailable of /proc/meminfo, in bytes.
uint64_t availableMemoryBytes() {
  std::ifstream meminfo("/proc/meminfo");
  for (std::string line; std::getline(meminfo, line);)
    if (line.rfind("MemAvailable:", 0) == 0) return std::stoull(line.substr(13)) * 1024;
  return 0;
}

double secondsBetween(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

struct JobPlan {
  std::string name;
  int width = 0, height = 0;
  uint64_t samplesPerPixel = 4;
  int tileSize = 0;                  // RenderOverrides::tileSize: 0 automatic, -1 passes, N tiles
  std::optional<FrameRange> frames;  // an animation
  uint64_t frameCount() const { return frames ? frames->count() : 1; }
};

struct Settings {
  int workers = 1000;
  double renderSeconds = 0.2, idleSeconds = 3.0, timeoutSeconds = 600.0;
  std::optional<double> auditFraction;
  std::string coordinator = LENSFARM_COORDINATOR_BIN;
};

// A scene with nothing to load: the simulated workers never read it.
JobSpec jobSpecOf(const JobPlan& plan) {
  const json scene = {{"format", "lensfarm-scene/1"},
                      {"camera",
                       {{"type", "pinhole"},
                        {"position", {0, 0, -3}},
                        {"look_at", {0, 0, 0}},
                        {"sensor_width", 0.1},
                        {"focal_length", 0.1}}},
                      {"materials", {{"white", {{"type", "lambertian"}, {"albedo", 0.5}}}}},
                      {"shapes",
                       {{{"type", "quad"},
                         {"corner", {-1, -1, 0}},
                         {"edge1", {0, 2, 0}},
                         {"edge2", {2, 0, 0}},
                         {"material", "white"}}}},
                      {"render",
                       {{"resolution", {plan.width, plan.height}},
                        {"samples_per_pixel", plan.samplesPerPixel},
                        {"samples_per_unit", 1}}}};
  JobSpec spec{plan.name + ".json", scene.dump(), {}, {}, plan.frames};
  spec.overrides.tileSize = plan.tileSize;
  return spec;
}

class Client {
 public:
  Client(const std::string& address, const std::string& token)
      : stub_(v1::ClientService::NewStub(makeChannel(address, ChannelSecurity{"", "", "", token}))), token_(token) {}

  std::string submit(const JobSpec& spec) {
    v1::SubmitJobRequest request;
    *request.mutable_spec() = proto::toProto(spec);
    v1::SubmitJobResponse response;
    check(stub_->SubmitJob(context().get(), request, &response), "SubmitJob");
    return response.job_id();
  }
  // Retried for 30 s while the coordinator is unreachable (an overloaded one drops connections).
  v1::JobStatus get(const std::string& job) {
    v1::GetJobRequest request;
    request.set_job_id(job);
    v1::JobStatus status;
    grpc::Status s;
    for (int attempt = 0; attempt < 60; ++attempt) {
      s = stub_->GetJob(context().get(), request, &status);
      if (s.error_code() != grpc::StatusCode::UNAVAILABLE) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
    check(s, "GetJob");
    return status;
  }
  // The job's image (an animation's `frame`) as EXR bytes.
  std::string download(const std::string& job, std::optional<int64_t> frame) {
    v1::DownloadRequest request;
    request.set_job_id(job);
    if (frame) request.set_frame(*frame);
    request.set_format(v1::IMAGE_FORMAT_EXR);
    auto ctx = context();
    auto reader = stub_->Download(ctx.get(), request);
    std::string bytes;
    for (v1::FileChunk chunk; reader->Read(&chunk);) bytes += chunk.data();
    check(reader->Finish(), "Download");
    return bytes;
  }

 private:
  std::unique_ptr<grpc::ClientContext> context() const {
    auto c = std::make_unique<grpc::ClientContext>();
    c->AddMetadata("authorization", "Bearer " + token_);
    c->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
    return c;
  }
  static void check(const grpc::Status& s, const char* call) {
    if (!s.ok()) throw std::runtime_error(std::string(call) + ": " + s.error_message());
  }
  std::unique_ptr<v1::ClientService::Stub> stub_;
  std::string token_;
};

struct RunReport {
  JobPlan plan;
  bool done = false, exact = false, withinMemory = false;
  std::string failure;
  uint32_t tileSize = 0;  // the coordinator's choice; 0: passes
  uint64_t unitsTotal = 0, unitsDone = 0, paths = 0, auditsPassed = 0, auditsFailed = 0;
  double submitToDone = 0, coordinatorCpu = 0, idleCpuPerCall = 0, idleCallsPerSecond = 0;
  double lastAckToDone = 0, lastAckToDownloaded = 0;
  uint64_t idleRss = 0, peakRss = 0, rssBound = 0, bytesIn = 0, callsInRun = 0;
  FarmTally tally;
};

// The coordinator's peak memory may not exceed what it held with the farm registered and idle
// (connections, threads, gRPC buffers), plus the film of every frame open at once, plus five of
// the largest unit's buffers for every worker, plus 64 MiB of allocator slack.
//  - Film of a tiled job (coordinator/core/tile_film.h): a float image a frame being rendered, and when
//    it is served, the stored frame read back and its EXR: three float frames (12 B a cell each),
//    the bound tests/farm/tiles_farm_test.cpp checks. Frames open at once: the still; for an
//    animation, the frames the workers' leases span (units are frame-major) and two more.
//  - Film of a job in passes: the sensor, the convergence tracker's half-image, the developed
//    image, its EXR and the audit's rewind copies of the sensor (farm/memory_estimate.h gives
//    the bytes a cell of each).
//  - Five unit buffers a worker: an upload in flight is held as gRPC's receive slices, the
//    assembled message and the unit's SensorBuffer, the audit keeps a copy of a counted unit until
//    another worker renders it again (each worker's first unit is audited), and glibc keeps freed
//    blocks of that size for reuse. Measured, a thousand workers uploading at once raised the peak
//    by 2.9 to 3.9 units a worker.
uint64_t memoryBound(const JobPlan& plan, bool tiled, uint64_t unitsPerFrame, uint64_t largestUnitCells,
                     uint64_t idleRss, int workers) {
  const uint64_t cells = uint64_t(plan.width) * uint64_t(plan.height);
  const uint64_t filmPerCell =
      tiled ? 3 * kImageBytesPerCell
            : (1 + kRewindPoints) * kSensorBytesPerCell + kTrackerBytesPerCell + 2 * kImageBytesPerCell;
  const uint64_t framesSpanned = tiled ? uint64_t(workers) / unitsPerFrame + 2 : 1;
  const uint64_t openFrames = plan.frames ? std::min<uint64_t>(plan.frameCount(), framesSpanned) : 1;
  return idleRss + openFrames * cells * filmPerCell +
         uint64_t(workers) * 5 * largestUnitCells * kUnitBufferBytesPerCell + (uint64_t(64) << 20);
}

// Where `image` (scene frame `frame` of the job) differs from the known one; "" if nowhere.
std::string wrongPixel(const Image& image, const JobPlan& plan, int64_t frame) {
  const std::string where = plan.frames ? "frame " + std::to_string(frame) + ": " : std::string();
  if (image.width != plan.width || image.height != plan.height) return where + "the image has the wrong size";
  for (int y = 0; y < plan.height; ++y)
    for (int x = 0; x < plan.width; ++x) {
      const double expected = expectedCell(plan.width - 1 - x, plan.height - 1 - y, frame, plan.samplesPerPixel);
      for (int c = 0; c < 3; ++c) {
        const float value = image.rgb[3 * (size_t(y) * size_t(plan.width) + size_t(x)) + size_t(c)];
        if (value != float(expected))
          return where + "pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") holds " + std::to_string(value) +
                 ", not the mean of its samples " + std::to_string(expected);
      }
    }
  return "";
}

RunReport runJob(const Settings& settings, const JobPlan& plan) {
  RunReport report;
  report.plan = plan;
  std::vector<std::string> extra;
  if (settings.auditFraction) extra = {"--audit-fraction", std::to_string(*settings.auditFraction)};
  CoordinatorProcess coordinator(settings.coordinator, extra);
  Client client(coordinator.address(), coordinator.clientToken());
  FarmConfig config;
  config.address = coordinator.address();
  config.workerToken = coordinator.workerToken();
  config.workers = settings.workers;
  config.width = plan.width;
  config.height = plan.height;
  config.renderSeconds = settings.renderSeconds;
  // The coordinator holds up to five of a unit's buffers a worker and the simulators one: together
  // at most half the memory available now.
  config.maxUnitBytes = availableMemoryBytes() / 2 / (6 * uint64_t(settings.workers));
  SimulatedFarm farm(config);
  const auto registering = Clock::now();
  while (farm.registered() < settings.workers && secondsBetween(registering, Clock::now()) < 120)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  if (farm.registered() < settings.workers) throw std::runtime_error("not every simulated worker could register");

  // The idle farm: heartbeats and empty long polls only.
  const double idleCpu0 = coordinator.cpuSeconds();
  const uint64_t idleCalls0 = farm.heartbeatsSent() + farm.leaseCalls();
  const auto idleStart = Clock::now();
  std::this_thread::sleep_for(std::chrono::duration<double>(settings.idleSeconds));
  const double idleWall = secondsBetween(idleStart, Clock::now());
  const double idleCalls = double(farm.heartbeatsSent() + farm.leaseCalls() - idleCalls0);
  report.idleCpuPerCall = (coordinator.cpuSeconds() - idleCpu0) / std::max(1.0, idleCalls);
  report.idleCallsPerSecond = idleCalls / idleWall;
  report.idleRss = coordinator.residentBytes();

  farm.measureFromNow();
  const double cpu0 = coordinator.cpuSeconds();
  const uint64_t calls0 = farm.heartbeatsSent() + farm.leaseCalls();
  const auto submitted = Clock::now();
  const std::string job = client.submit(jobSpecOf(plan));
  v1::JobStatus status;
  for (;;) {
    try {
      status = client.get(job);
    } catch (const std::exception& e) {
      const std::string log = coordinator.log();
      throw std::runtime_error(std::string(e.what()) + (coordinator.running() ? "" : " (the coordinator exited)") +
                               "; its log ends: " + log.substr(log.size() > 2000 ? log.size() - 2000 : 0));
    }
    if (status.state() != v1::JOB_STATE_QUEUED && status.state() != v1::JOB_STATE_RUNNING) break;
    if (secondsBetween(submitted, Clock::now()) > settings.timeoutSeconds) break;
    if (farm.oversizedUnitBytes() > 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const auto doneAt = Clock::now();
  // The run's CPU: submission to the job seen done (serving the image is not the farm's work).
  report.coordinatorCpu = coordinator.cpuSeconds() - cpu0;
  report.callsInRun = farm.heartbeatsSent() + farm.leaseCalls() - calls0;
  report.done = status.state() == v1::JOB_STATE_DONE;
  // The final image: the still, or the animation's last frame.
  const std::optional<int64_t> lastFrame = plan.frames ? std::optional<int64_t>(plan.frames->last) : std::nullopt;
  std::string exr;
  if (report.done) exr = client.download(job, lastFrame);
  const auto downloadedAt = Clock::now();
  report.submitToDone = secondsBetween(submitted, doneAt);
  report.tally = farm.stop();
  // The job is seen done within one poll (10 ms) of it: the last acknowledgment
  // before that is the last unit's.
  const Clock::time_point lastAck = report.tally.lastAckBy(doneAt);
  report.lastAckToDone = secondsBetween(lastAck, doneAt);
  report.lastAckToDownloaded = secondsBetween(lastAck, downloadedAt);
  report.peakRss = coordinator.peakResidentBytes();
  const auto metrics = coordinator.metrics();
  const auto metric = [&](const std::string& name) { return metrics.count(name) ? metrics.at(name) : 0.0; };
  report.bytesIn = uint64_t(metric("lensfarm_received_bytes_total{kind=\"unit\"}"));
  report.unitsTotal = status.progress().units_total();
  report.unitsDone = status.progress().units_done();
  report.paths = status.progress().paths();
  report.auditsPassed = status.audits_passed();
  report.auditsFailed = status.audits_failed();
  report.tileSize = status.tile_size();
  report.rssBound = memoryBound(plan, report.tileSize > 0, std::max<uint64_t>(1, report.unitsTotal / plan.frameCount()),
                                report.tally.largestUnitCells, report.idleRss, settings.workers);
  report.withinMemory = report.peakRss <= report.rssBound;
  if (const uint64_t oversized = farm.oversizedUnitBytes(); oversized > 0) {
    report.done = false;
    report.failure = "the coordinator leased a unit of " + std::to_string(oversized / 1000000) + " MB of sums; " +
                     std::to_string(settings.workers) +
                     " workers uploading such units at once would not fit in this machine's memory (is the job tiled?)";
    return report;
  }
  if (!report.done) {
    report.failure = "the job ended " + v1::JobState_Name(status.state()) + " " + status.error();
    return report;
  }
  // The exact image: every pixel of every frame the known mean of its samples.
  report.failure = wrongPixel(decodeExr(exr), plan, lastFrame.value_or(0));
  try {
    for (uint64_t f = 0; plan.frames && f + 1 < plan.frameCount() && report.failure.empty(); ++f)
      report.failure =
          wrongPixel(decodeExr(client.download(job, plan.frames->frameAt(f))), plan, plan.frames->frameAt(f));
  } catch (const std::exception& e) {
    report.failure = e.what();
  }
  report.exact = report.failure.empty();
  if (!report.exact) report.failure += " (the coordinator's files are kept in " + coordinator.keepFiles() + ")";
  const uint64_t paths = uint64_t(plan.width) * uint64_t(plan.height) * plan.samplesPerPixel * plan.frameCount();
  if (report.paths != paths) {
    report.exact = false;
    report.failure = "the job counts " + std::to_string(report.paths) + " paths, not " + std::to_string(paths);
  }
  if (report.unitsDone != report.unitsTotal) {
    report.exact = false;
    report.failure = "units done " + std::to_string(report.unitsDone) + " of " + std::to_string(report.unitsTotal);
  }
  return report;
}

json latencyJson(const CallTimes& t) {
  return {{"count", t.count()},
          {"p50_ms", 1e3 * t.quantile(0.5)},
          {"p99_ms", 1e3 * t.quantile(0.99)},
          {"max_ms", 1e3 * t.max()}};
}

json reportJson(const RunReport& r, const Settings& s) {
  const double units = double(r.unitsDone);
  return {
      {"job", r.plan.name},
      {"width", r.plan.width},
      {"height", r.plan.height},
      {"frames", r.plan.frameCount()},
      {"spp", r.plan.samplesPerPixel},
      {"tile_size", r.tileSize},
      {"workers", s.workers},
      {"render_seconds", s.renderSeconds},
      {"done", r.done},
      {"exact_image", r.exact},
      {"units", r.unitsDone},
      {"submit_to_done_seconds", r.submitToDone},
      {"units_per_second", units / r.submitToDone},
      {"coordinator_cpu_seconds", r.coordinatorCpu},
      {"coordinator_cpu_percent_of_wall", 100.0 * r.coordinatorCpu / r.submitToDone},
      {"idle_cpu_per_call_us", 1e6 * r.idleCpuPerCall},
      {"idle_calls_per_second", r.idleCallsPerSecond},
      {"cpu_per_unit_ms", 1e3 * (r.coordinatorCpu - r.idleCpuPerCall * double(r.callsInRun)) / std::max(1.0, units)},
      {"idle_rss_mb", double(r.idleRss) / 1e6},
      {"peak_rss_mb", double(r.peakRss) / 1e6},
      {"rss_bound_mb", double(r.rssBound) / 1e6},
      {"bytes_in", r.bytesIn},
      {"bytes_uploaded_by_workers", r.tally.bytesUploaded},
      {"audits_passed", r.auditsPassed},
      {"audits_failed", r.auditsFailed},
      {"uploads_acknowledged", r.tally.unitsAccepted},
      {"uploads_duplicate", r.tally.duplicates},
      {"uploads_refused", r.tally.refused},
      {"failed_calls", r.tally.failedCalls},
      {"last_ack_to_done_seconds", r.lastAckToDone},
      {"last_ack_to_downloaded_seconds", r.lastAckToDownloaded},
      {"latency",
       {{"RegisterWorker", latencyJson(r.tally.registerWorker)},
        {"LeaseWork", latencyJson(r.tally.leaseGranted)},
        {"UploadResult", latencyJson(r.tally.upload)},
        {"Heartbeat", latencyJson(r.tally.heartbeat)},
        {"GetJobSpec", latencyJson(r.tally.jobSpec)}}},
      {"failed_call_messages", r.tally.failures},
      {"failure", r.failure}};
}

void printReport(const json& r) {
  std::printf(
      "\n== %s: %dx%d x %llu frame(s), %llu spp, %d workers, render "
      "%.3f s a unit ==\n",
      r["job"].get<std::string>().c_str(), r["width"].get<int>(), r["height"].get<int>(),
      (unsigned long long)r["frames"].get<uint64_t>(), (unsigned long long)r["spp"].get<uint64_t>(),
      r["workers"].get<int>(), r["render_seconds"].get<double>());
  const uint64_t tile = r["tile_size"].get<uint64_t>();
  std::printf(
      "  units %llu (%s) in %.2f s: %.1f units/s; exact image: %s\n", (unsigned long long)r["units"].get<uint64_t>(),
      tile > 0 ? ("tiles of " + std::to_string(tile)).c_str() : "passes", r["submit_to_done_seconds"].get<double>(),
      r["units_per_second"].get<double>(), r["exact_image"].get<bool>() ? "yes" : "NO");
  std::printf(
      "  coordinator CPU %.2f s = %.1f %% of wall; idle farm %.0f "
      "calls/s at %.1f us CPU each; %.3f ms CPU a unit\n",
      r["coordinator_cpu_seconds"].get<double>(), r["coordinator_cpu_percent_of_wall"].get<double>(),
      r["idle_calls_per_second"].get<double>(), r["idle_cpu_per_call_us"].get<double>(),
      r["cpu_per_unit_ms"].get<double>());
  std::printf("  coordinator RSS: idle farm %.0f MB, peak %.0f MB (bound %.0f MB)\n", r["idle_rss_mb"].get<double>(),
              r["peak_rss_mb"].get<double>(), r["rss_bound_mb"].get<double>());
  std::printf(
      "  bytes in %.1f MB (metrics), uploaded %.1f MB; audits passed "
      "%llu failed %llu\n",
      r["bytes_in"].get<double>() / 1e6, r["bytes_uploaded_by_workers"].get<double>() / 1e6,
      (unsigned long long)r["audits_passed"].get<uint64_t>(), (unsigned long long)r["audits_failed"].get<uint64_t>());
  std::printf(
      "  uploads acknowledged %llu, duplicate %llu, refused %llu; "
      "failed calls %llu\n",
      (unsigned long long)r["uploads_acknowledged"].get<uint64_t>(),
      (unsigned long long)r["uploads_duplicate"].get<uint64_t>(),
      (unsigned long long)r["uploads_refused"].get<uint64_t>(), (unsigned long long)r["failed_calls"].get<uint64_t>());
  for (const auto& [what, n] : r["failed_call_messages"].items())
    std::printf("    %llu x %s\n", (unsigned long long)n.get<uint64_t>(), what.c_str());
  std::printf(
      "  last upload acknowledged -> job done %.3f s -> image "
      "downloaded %.3f s\n",
      r["last_ack_to_done_seconds"].get<double>(), r["last_ack_to_downloaded_seconds"].get<double>());
  std::printf("  %-15s %9s %10s %10s %10s\n", "call", "count", "p50 ms", "p99 ms", "max ms");
  for (const auto& [call, t] : r["latency"].items())
    std::printf("  %-15s %9llu %10.2f %10.2f %10.2f\n", call.c_str(), (unsigned long long)t["count"].get<uint64_t>(),
                t["p50_ms"].get<double>(), t["p99_ms"].get<double>(), t["max_ms"].get<double>());
  if (!r["failure"].get<std::string>().empty()) std::printf("  FAILED: %s\n", r["failure"].get<std::string>().c_str());
}

JobPlan planOf(const std::string& name, const std::string& resolution, uint64_t spp, const std::string& tiles) {
  RenderOverrides o;
  parseResolution(resolution, o);
  parseTileSize(tiles, o);
  JobPlan plan;
  plan.name = name;
  plan.width = *o.width;
  plan.height = *o.height;
  plan.samplesPerPixel = spp;
  plan.tileSize = *o.tileSize;
  return plan;
}

}  // namespace
}  // namespace lensfarm::scale

int main(int argc, char** argv) {
  using namespace lensfarm::scale;
  CLI::App app{"lensfarm-scale: one coordinator under many simulated workers"};
  Settings settings;
  std::string still = "3840x2160", animation = "1920x1080", tiles = "auto", jsonFile;
  int64_t frames = 240;
  uint64_t spp = 4;
  double auditFraction = -1;
  app.add_option("--workers", settings.workers, "Simulated workers")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  app.add_option("--render-seconds", settings.renderSeconds, "A unit's simulated render time (+-50 %)")
      ->check(CLI::Range(0.0, 60.0))
      ->capture_default_str();
  app.add_option("--still", still, "The still's resolution; empty: no still")->capture_default_str();
  app.add_option("--animation", animation, "The animation's resolution; empty: no animation")->capture_default_str();
  app.add_option("--frames", frames, "The animation's frames (1-N)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--spp", spp, "Samples per pixel (a power of two keeps the image exact in floats)")
      ->check(CLI::Range(1, 1 << 16))
      ->capture_default_str();
  app.add_option("--tile-size", tiles, "auto, off (passes over the whole frame) or an edge in pixels")
      ->capture_default_str();
  app.add_option("--audit-fraction", auditFraction, "The coordinator's --audit-fraction; default: its own");
  app.add_option("--idle-seconds", settings.idleSeconds, "The idle farm's measuring time before the job")
      ->check(CLI::Range(0.5, 600.0))
      ->capture_default_str();
  app.add_option("--timeout", settings.timeoutSeconds, "Give a job up after this long, s")->capture_default_str();
  app.add_option("--json", jsonFile, "Also write the reports to this JSON file");
  CLI11_PARSE(app, argc, argv);
  if (auditFraction >= 0) settings.auditFraction = auditFraction;
  // Two sockets a simulated worker (its end and the coordinator's) and a few
  // more each.
  rlimit files{};
  if (::getrlimit(RLIMIT_NOFILE, &files) == 0 && files.rlim_cur < files.rlim_max) {
    files.rlim_cur = files.rlim_max;
    ::setrlimit(RLIMIT_NOFILE, &files);
  }
  std::vector<JobPlan> plans;
  try {
    if (!still.empty()) plans.push_back(planOf("still", still, spp, tiles));
    if (!animation.empty()) {
      plans.push_back(planOf("animation", animation, spp, tiles));
      plans.back().frames = lensfarm::FrameRange{1, frames, 1};
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  bool ok = true;
  json all = json::array();
  for (const JobPlan& plan : plans) {
    try {
      const RunReport r = runJob(settings, plan);
      all.push_back(reportJson(r, settings));
      printReport(all.back());
      ok &= r.done && r.exact && r.withinMemory;
      if (!r.withinMemory) std::printf("  FAILED: the coordinator's peak memory is over its bound\n");
    } catch (const std::exception& e) {
      std::printf("FAILED: %s: %s\n", plan.name.c_str(), e.what());
      ok = false;
    }
    std::fflush(stdout);
  }
  if (!jsonFile.empty()) std::ofstream(jsonFile) << all.dump(2) << "\n";
  std::printf("%s\n", ok ? "every job done, exact and within its memory bound" : "FAILED");
  return ok ? 0 : 1;
}
