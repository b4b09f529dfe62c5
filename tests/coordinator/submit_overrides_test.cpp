// Overrides a job arrives with over gRPC (RenderOverrides in JobSpec), through the coordinator's own
// SubmitJob handler called directly (no network): one that the coordinator cannot apply as every
// worker would is INVALID_ARGUMENT naming the field, and no job is queued.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/util/error.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/rpc/service.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// The minimal scene at 64x32, with `overrides`.
v1::SubmitJobRequest requestWith(const v1::RenderOverrides& overrides) {
  json scene = test::minimalSceneJson();
  scene["render"]["resolution"] = {64, 32};
  v1::SubmitJobRequest request;
  request.mutable_spec()->set_scene_name("wide.json");
  request.mutable_spec()->set_scene_json(scene.dump());
  *request.mutable_spec()->mutable_overrides() = overrides;
  return request;
}

TEST(SubmitOverrides, OneSideOfTheResolutionOrANonFiniteEvIsInvalidArgumentNamingTheField) {
  Coordinator coordinator;
  ClientServiceImpl service(coordinator);
  const auto submit = [&](const v1::RenderOverrides& overrides, v1::SubmitJobResponse* response) {
    grpc::ServerContext context;
    const v1::SubmitJobRequest request = requestWith(overrides);
    return service.SubmitJob(&context, &request, response);
  };

  struct Case {
    const char* what;
    v1::RenderOverrides overrides;
    std::string message;
  };
  std::vector<Case> cases(5);
  cases[0] = {"width alone", {}, "wide.json: overrides.width: given without overrides.height; give both or neither"};
  cases[0].overrides.set_width(16);
  cases[1] = {"height alone", {}, "wide.json: overrides.height: given without overrides.width; give both or neither"};
  cases[1].overrides.set_height(16);
  cases[2] = {"ev NaN", {}, "wide.json: overrides.ev: must be a finite number of stops in [-64, 64], got nan"};
  cases[2].overrides.set_ev(std::numeric_limits<double>::quiet_NaN());
  cases[3] = {"ev infinite", {}, "wide.json: overrides.ev: must be a finite number of stops in [-64, 64], got -inf"};
  cases[3].overrides.set_ev(-std::numeric_limits<double>::infinity());
  cases[4] = {"ev too large", {}, "wide.json: overrides.ev: must be a finite number of stops in [-64, 64], got 65"};
  cases[4].overrides.set_ev(65.0);
  for (const Case& c : cases) {
    v1::SubmitJobResponse response;
    const grpc::Status s = submit(c.overrides, &response);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.what << ": " << s.error_message();
    EXPECT_EQ(s.error_message(), c.message) << c.what;
    EXPECT_TRUE(response.job_id().empty()) << c.what;
  }
  EXPECT_TRUE(coordinator.jobs().empty()) << "no refused job is queued";

  // Both sides, and a finite ev: the job is the size asked for.
  v1::RenderOverrides both;
  both.set_width(16);
  both.set_height(24);
  both.set_ev(-1.5);
  v1::SubmitJobResponse response;
  const grpc::Status s = submit(both, &response);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(response.status().width(), 16u);
  EXPECT_EQ(response.status().height(), 24u);
  EXPECT_EQ(coordinator.jobs().size(), 1u);
}

TEST(SubmitOverrides, AnUnknownAovIsInvalidArgumentNamingItAndKnownOnesMakeTheJobsLayers) {
  Coordinator coordinator;
  ClientServiceImpl service(coordinator);
  v1::RenderOverrides overrides;
  overrides.set_aovs("albedo, sheen");
  grpc::ServerContext context;
  v1::SubmitJobRequest request = requestWith(overrides);
  v1::SubmitJobResponse response;
  grpc::Status s = service.SubmitJob(&context, &request, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << s.error_message();
  EXPECT_NE(s.error_message().find("overrides.aovs: unknown AOV \"sheen\""), std::string::npos) << s.error_message();
  EXPECT_TRUE(coordinator.jobs().empty());

  overrides.set_aovs("depth,albedo");  // any order, as a client in another language may send it
  request = requestWith(overrides);
  grpc::ServerContext again;
  s = service.SubmitJob(&again, &request, &response);
  ASSERT_TRUE(s.ok()) << s.error_message();
  const Image image = coordinator.image(response.job_id()).image;
  ASSERT_EQ(image.layers.size(), 2u);
  EXPECT_EQ(image.layers[0].name, "albedo");
  EXPECT_EQ(image.layers[1].name, "") << "Z";
}

// `adaptive` from a client in any language turns the scene's adaptive sampling on (a layout of
// rounds, kept across a restart: state_store.cpp) or off; with tiles or an animation it is refused.
TEST(SubmitOverrides, AdaptiveMakesALayoutOfRoundsAndIsRefusedWhereItCannotWork) {
  Coordinator coordinator;
  ClientServiceImpl service(coordinator);
  const auto submit = [&](const v1::RenderOverrides& overrides, v1::SubmitJobResponse* response) {
    grpc::ServerContext context;
    v1::SubmitJobRequest request = requestWith(overrides);
    json scene = json::parse(request.spec().scene_json());
    scene["render"]["samples_per_pixel"] = 64;
    request.mutable_spec()->set_scene_json(scene.dump());
    return service.SubmitJob(&context, &request, response);
  };
  v1::RenderOverrides on;
  on.set_adaptive(true);
  v1::SubmitJobResponse response;
  grpc::Status s = submit(on, &response);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(coordinator.job(response.job_id()).unitsTotal, 16u) << "64 spp in passes of 4: 4 uniform, 12 in rounds";
  on.set_tile_size(8);
  s = submit(on, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << s.error_message();
  EXPECT_NE(s.error_message().find("adaptive"), std::string::npos) << s.error_message();
  on.clear_tile_size();
  grpc::ServerContext context;
  v1::SubmitJobRequest animation = requestWith(on);
  animation.mutable_spec()->mutable_frames()->set_first(1);
  animation.mutable_spec()->mutable_frames()->set_last(3);
  animation.mutable_spec()->mutable_frames()->set_step(1);
  s = service.SubmitJob(&context, &animation, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << s.error_message();
  EXPECT_NE(s.error_message().find("adaptive sampling is for stills"), std::string::npos) << s.error_message();
  EXPECT_EQ(coordinator.jobs().size(), 1u);
}

// The same rule for every caller of Coordinator::submit (`lensfarm render`'s embedded coordinator,
// a restart's restore): an InputError, whatever the transport.
TEST(SubmitOverrides, CoordinatorSubmitRefusesOneSideOfTheResolution) {
  Coordinator coordinator;
  JobSpec spec;
  spec.sceneName = "wide.json";
  spec.sceneJson = test::minimalSceneJson().dump();
  spec.overrides.width = 64;
  try {
    coordinator.submit(spec, 0);
    FAIL() << "a width without a height must be refused";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("overrides.width"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(coordinator.jobs().empty());
}

}  // namespace
}  // namespace lensfarm

namespace lensfarm {
namespace {

// A snapshot's `ev` is checked like a submission's: a NaN is INVALID_ARGUMENT naming it, not a
// black image.
TEST(SubmitOverrides, ASnapshotsEvIsAFiniteNumberOfStops) {
  Coordinator coordinator;
  ClientServiceImpl service(coordinator);
  grpc::ServerContext submitContext;
  const v1::SubmitJobRequest submitRequest = requestWith({});
  v1::SubmitJobResponse submitted;
  ASSERT_TRUE(service.SubmitJob(&submitContext, &submitRequest, &submitted).ok());
  for (const double ev : {std::numeric_limits<double>::quiet_NaN(), 65.0}) {
    grpc::ServerContext context;
    v1::SnapshotRequest request;
    request.set_job_id(submitted.job_id());
    request.set_ev(ev);
    v1::Snapshot snapshot;
    const grpc::Status s = service.GetSnapshot(&context, &request, &snapshot);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << ev << ": " << s.error_message();
    EXPECT_NE(s.error_message().find("ev: must be a finite number of stops"), std::string::npos) << s.error_message();
  }
}

}  // namespace
}  // namespace lensfarm
