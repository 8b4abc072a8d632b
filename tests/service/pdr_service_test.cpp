// SPDX-License-Identifier: AGPL-3.0-or-later
// The coordinator's PdrEngine end to end (in-process coordinator on loopback,
// leaves run in its process): the result equals mesh_parallel's bytes in every
// format, leaves are reported, a job is cancelled mid-refinement, jobs are
// deleted and expire, the security refusals come with the right codes while
// another user's job completes, and the health service answers. Also the job
// options' JSON and the client's progress display.
#include <grpcpp/generic/generic_stub.h>
#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "job_service.hpp"
#include "leaf_dispatch.hpp"
#include "pdr_engine.hpp"
#include "pdrmesh/layered_pipeline.hpp"
#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/volume_io.hpp"
#include "progress_display.hpp"
#include "service_fixture.hpp"

namespace pdrmesh::server {
namespace {

using test::file_bytes;

/// A unary call by method name with raw request bytes: its status and response bytes.
std::pair<grpc::Status, std::string> raw_unary(const std::shared_ptr<grpc::Channel>& channel, const std::string& method,
                                               const std::string& request_bytes, const std::string& token) {
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
  grpc::Slice slice(request_bytes);
  grpc::ByteBuffer request(&slice, 1), response;
  std::mutex mu;
  std::condition_variable cv;
  std::optional<grpc::Status> result;
  stub.UnaryCall(&context, method, grpc::StubOptions(), &request, &response, [&](grpc::Status s) {
    std::lock_guard lock(mu);
    result = s;
    cv.notify_all();
  });
  std::unique_lock lock(mu);
  cv.wait(lock, [&] { return result.has_value(); });
  std::string bytes;
  std::vector<grpc::Slice> slices;
  if (result->ok() && response.Dump(&slices).ok()) {
    for (const auto& sl : slices) bytes.append(reinterpret_cast<const char*>(sl.begin()), sl.size());
  }
  return {*result, bytes};
}

/// One request on a bidirectional stream by method name, then half-close: the
/// first response's bytes and the call's status.
class OneRequestStream final : public grpc::ClientBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer> {
 public:
  std::pair<grpc::Status, std::string> call(const std::shared_ptr<grpc::Channel>& channel, const std::string& method,
                                            const std::string& request_bytes) {
    grpc::GenericStub stub(channel);
    context_.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    grpc::Slice slice(request_bytes);
    request_ = grpc::ByteBuffer(&slice, 1);
    stub.PrepareBidiStreamingCall(&context_, method, grpc::StubOptions(), this);
    StartWrite(&request_);
    StartRead(&response_);
    StartCall();
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return done_; });
    return {status_, bytes_};
  }
  void OnWriteDone(bool /*ok*/) override { StartWritesDone(); }
  void OnReadDone(bool ok) override {
    std::vector<grpc::Slice> slices;
    if (!ok || !response_.Dump(&slices).ok()) return;
    std::lock_guard lock(mu_);
    for (const auto& sl : slices) bytes_.append(reinterpret_cast<const char*>(sl.begin()), sl.size());
  }
  void OnDone(const grpc::Status& s) override {
    std::lock_guard lock(mu_);
    status_ = s;
    done_ = true;
    cv_.notify_all();
  }

 private:
  grpc::ClientContext context_;
  grpc::ByteBuffer request_, response_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool done_ = false;
  grpc::Status status_;
  std::string bytes_;
};

/// Mesh options of a quick sphere job: depth 1 (8 leaves), both rounds, optimization.
v1::MeshOptions quick_options() {
  v1::MeshOptions o;
  o.set_depth(1);
  return o;
}

/// A dispatch whose kernels refine `free_leaves` leaves, then hold every
/// further leaf until released or until the job must stop (then kCancelled).
class HoldingDispatch final : public LeafDispatch {
 public:
  struct State {
    std::mutex mu;
    std::condition_variable cv;
    bool released = false;
    int held = 0;  ///< leaves waiting now
    std::atomic<int> started{0};
  };
  HoldingDispatch(std::shared_ptr<State> state, int free_leaves) : state_(std::move(state)), free_(free_leaves) {}
  Result<std::unique_ptr<LeafKernel>> kernel_for(const LeafJob& job) override {
    PDR_ASSIGN_OR_RETURN(auto inner, make_leaf_kernel(job.kernel));
    return std::unique_ptr<LeafKernel>(new Kernel(std::move(inner), state_, free_, job.keep_going));
  }
  std::size_t concurrency() const override { return 2; }

 private:
  class Kernel final : public LeafKernel {
   public:
    Kernel(std::unique_ptr<LeafKernel> inner, std::shared_ptr<State> state, int free_leaves,
           std::function<bool()> keep_going)
        : inner_(std::move(inner)), state_(std::move(state)), free_(free_leaves), keep_going_(std::move(keep_going)) {}
    Result<LeafTaskOutput> run(const LeafTaskInput& in, const SizingField& sizing) const override {
      if (state_->started++ >= free_) {
        std::unique_lock lock(state_->mu);
        ++state_->held;
        state_->cv.notify_all();
        while (!state_->released) {
          if (!keep_going_()) return cancelled("the job stopped while the leaf waited");
          state_->cv.wait_for(lock, std::chrono::milliseconds(10));
        }
      }
      return inner_->run(in, sizing);
    }
    std::string_view name() const override { return inner_->name(); }

   private:
    std::unique_ptr<LeafKernel> inner_;
    std::shared_ptr<State> state_;
    int free_;
    std::function<bool()> keep_going_;
  };
  std::shared_ptr<State> state_;
  int free_;
};

TEST_F(Service, PdrJobEqualsMeshParallelInEveryFormatAndReportsLeaves) {
  start(1);
  auto alice = client("tok-alice");
  v1::Job job;
  ASSERT_TRUE(alice->submit(kSphere, quick_options(), job).ok());
  std::vector<v1::JobEvent> events;
  const v1::Job done = watch(*alice, job.id(), &events);
  ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error();
  EXPECT_EQ(done.options().depth(), 1);
  EXPECT_EQ(done.options().kernel(), "native");
  EXPECT_EQ(done.leaves_total(), 0U) << "leaf counts are for the rounds only";
  bool saw_round = false;
  for (const auto& e : events) saw_round = saw_round || (e.job().leaves_total() > 0 && e.job().phase() == "refinement");
  EXPECT_TRUE(saw_round) << "a watcher sees the refinement round with its leaf count";

  // The same pipeline in this process: the same bytes.
  auto surface = read_surface(kSphere);
  ASSERT_TRUE(surface.ok());
  JobOptions options;
  options.depth = 1;
  auto local = mesh_parallel(*surface, parallel_options(options));
  ASSERT_TRUE(local.ok()) << local.status().to_string();
  const auto local_path = dir_.path() / "local.meshb";
  ASSERT_TRUE(write_volume(local->mesh, local_path).ok());
  EXPECT_EQ(done.tets(), local->mesh.tets.size());

  for (const char* suffix : {".meshb", ".vtu", ".mesh", ".ugrid", ".lb8.ugrid", ".b8.ugrid", ".msh", ".su2"}) {
    const auto out = dir_.path() / (std::string("job") + suffix);
    const grpc::Status s = alice->fetch(job.id(), out);
    ASSERT_TRUE(s.ok()) << suffix << ": " << s.error_message();
    auto mesh = read_volume(out);
    ASSERT_TRUE(mesh.ok()) << suffix << ": " << mesh.status().to_string();
    const ValidationReport v = validate_mesh(*mesh, &*surface);
    EXPECT_TRUE(v.ok()) << suffix << ": " << format_validation(v);
    EXPECT_EQ(mesh->tets, local->mesh.tets) << suffix;
  }
  EXPECT_EQ(file_bytes(dir_.path() / "job.meshb"), file_bytes(local_path)) << "byte-identical to the local run";
}

TEST_F(Service, LayeredJobEqualsMeshParallelLayeredAndEveryFormatHoldsItsPrisms) {
  start(1);
  auto alice = client("tok-alice");
  v1::MeshOptions options = quick_options();
  options.mutable_layers()->set_count(3);
  options.mutable_layers()->set_first_height(0.05);
  options.mutable_layers()->set_growth_ratio(1.3);
  v1::Job job;
  ASSERT_TRUE(alice->submit(kSphere, options, job).ok());
  const v1::Job done = watch(*alice, job.id());
  ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error();
  EXPECT_EQ(done.options().layers().count(), 3);
  EXPECT_DOUBLE_EQ(done.options().growth(), 1.3) << "the tets' growth continues the layers' ratio";

  // The same pipeline in this process: the same bytes.
  auto surface = read_surface(kSphere);
  ASSERT_TRUE(surface.ok());
  auto job_options = from_proto(options, JobOptions{});
  ASSERT_TRUE(job_options.ok()) << job_options.status().to_string();
  LayerOptions layers;
  layers.layers = 3;
  layers.first_height = 0.05;
  layers.growth_ratio = 1.3;
  auto local = mesh_parallel_layered(*surface, layers, parallel_options(*job_options));
  ASSERT_TRUE(local.ok()) << local.status().to_string();
  const VolumeMesh& mesh = local->layered.mesh;
  EXPECT_EQ(mesh.prisms.size(), 3 * surface->triangles.size());
  // Every format byte-identical to the local mesh written in it; those read back validate.
  for (const char* suffix : {".meshb", ".mesh", ".vtu", ".ugrid", ".msh", ".su2"}) {
    const auto out = dir_.path() / (std::string("layered") + suffix);
    const grpc::Status s = alice->fetch(job.id(), out);
    ASSERT_TRUE(s.ok()) << suffix << ": " << s.error_message();
    const auto local_path = dir_.path() / (std::string("local") + suffix);
    ASSERT_TRUE(write_volume(mesh, local_path).ok()) << suffix;
    EXPECT_EQ(file_bytes(out), file_bytes(local_path)) << suffix << ": byte-identical to the local run";
    if (std::string(suffix).starts_with(".mesh") || std::string(suffix) == ".vtu") {
      auto back = read_volume(out);
      ASSERT_TRUE(back.ok()) << suffix << ": " << back.status().to_string();
      const ValidationReport v = validate_mesh(*back, &*surface);
      EXPECT_TRUE(v.ok()) << suffix << ": " << format_validation(v);
      EXPECT_EQ(back->prisms, mesh.prisms) << suffix;
    }
  }
}

TEST_F(Service, RunningJobIsCancelledMidRefinement) {
  auto state = std::make_shared<HoldingDispatch::State>();
  start(1, {}, std::make_unique<PdrEngine>(std::make_shared<HoldingDispatch>(state, 1)));
  auto alice = client("tok-alice");
  v1::Job job;
  ASSERT_TRUE(alice->submit(kSphere, quick_options(), job).ok());
  {
    std::unique_lock lock(state->mu);
    ASSERT_TRUE(state->cv.wait_for(lock, std::chrono::seconds(20), [&] { return state->held > 0; }))
        << "the refinement round holds a leaf";
  }
  v1::Job now;
  ASSERT_TRUE(alice->get(job.id(), now).ok());
  EXPECT_EQ(now.state(), v1::JOB_STATE_RUNNING);
  // A round of leaf tasks: the seed rounds come before the refinement's.
  EXPECT_TRUE(now.phase() == "seeds" || now.phase() == "refinement") << now.phase();
  EXPECT_GT(now.leaves_total(), 0U);
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(alice->cancel(job.id(), now).ok());
  const v1::Job end = watch(*alice, job.id());
  EXPECT_EQ(end.state(), v1::JOB_STATE_CANCELLED) << end.error();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5)) << "the held leaves were not waited for";
  EXPECT_LT(state->started.load(), 16) << "no further leaves started after the cancel";
  EXPECT_EQ(alice->fetch(job.id(), dir_.path() / "x.meshb").error_code(), grpc::StatusCode::FAILED_PRECONDITION);
}

TEST_F(Service, DeleteRemovesFinishedQueuedAndRunningJobsWithTheirFiles) {
  auto state = std::make_shared<HoldingDispatch::State>();
  start(1, {}, std::make_unique<PdrEngine>(std::make_shared<HoldingDispatch>(state, 0)));
  auto alice = client("tok-alice");
  auto bob = client("tok-bob");
  const auto jobs_dir = dir_.path() / "data" / "jobs";
  v1::Job running, queued, seen;
  ASSERT_TRUE(alice->submit(kSphere, quick_options(), running).ok());
  {
    std::unique_lock lock(state->mu);
    ASSERT_TRUE(state->cv.wait_for(lock, std::chrono::seconds(20), [&] { return state->held > 0; }));
  }
  ASSERT_TRUE(alice->submit(kSphere, quick_options(), queued).ok());  // waits: one runner thread
  EXPECT_EQ(bob->remove(running.id(), seen).error_code(), grpc::StatusCode::NOT_FOUND) << "not bob's";

  ASSERT_TRUE(alice->remove(queued.id(), seen).ok());
  EXPECT_EQ(seen.state(), v1::JOB_STATE_QUEUED) << "answers with the job as it was";
  EXPECT_EQ(alice->get(queued.id(), seen).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_FALSE(std::filesystem::exists(jobs_dir / queued.id()));

  const grpc::Status s = alice->remove(running.id(), seen);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(alice->get(running.id(), seen).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_FALSE(std::filesystem::exists(jobs_dir / running.id()));

  // A finished job, with a converted result beside it.
  {
    std::lock_guard lock(state->mu);
    state->released = true;
  }
  v1::Job finished;
  ASSERT_TRUE(alice->submit(kSphere, quick_options(), finished).ok());
  ASSERT_EQ(watch(*alice, finished.id()).state(), v1::JOB_STATE_SUCCEEDED);
  ASSERT_TRUE(alice->fetch(finished.id(), dir_.path() / "f.vtu").ok());
  ASSERT_TRUE(std::filesystem::exists(jobs_dir / finished.id()));
  ASSERT_TRUE(alice->remove(finished.id(), seen).ok());
  EXPECT_EQ(seen.state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_FALSE(std::filesystem::exists(jobs_dir / finished.id()));
  v1::ListJobsResponse list;
  ASSERT_TRUE(alice->list(list).ok());
  EXPECT_EQ(list.jobs_size(), 0);
}

TEST_F(Service, FinishedJobsExpireAfterTheResultTtl) {
  Options o = options(1);
  // Two seconds: the watch below must see the job finish before the sweep
  // takes it (with half a second the test failed once on a loaded machine).
  o.result_ttl_hours = 2.0 / 3600;
  o.sweep_interval_s = 0.05;
  auto c = Coordinator::BuildAndStart(o);
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  coordinator_ = std::move(c).value();
  auto alice = client("tok-alice");
  v1::MeshOptions initial_only;
  initial_only.set_max_volume(1e9);
  v1::Job job, seen;
  ASSERT_TRUE(alice->submit(kSphere, initial_only, job).ok());
  ASSERT_EQ(watch(*alice, job.id()).state(), v1::JOB_STATE_SUCCEEDED);
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (alice->get(job.id(), seen).ok() && std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(alice->get(job.id(), seen).error_code(), grpc::StatusCode::NOT_FOUND) << "swept";
  EXPECT_FALSE(std::filesystem::exists(dir_.path() / "data" / "jobs" / job.id()));
}

TEST_F(Service, RefusalsHaveTheRightCodeAndMessageWhileAnotherUsersJobCompletes) {
  auto state = std::make_shared<HoldingDispatch::State>();
  UserLimits limits;
  limits.max_upload_bytes = 400000;  // sphere966.stl is 348 kB
  start(1, limits, std::make_unique<PdrEngine>(std::make_shared<HoldingDispatch>(state, 0)));
  auto bob = client("tok-bob");
  v1::Job bobs;
  ASSERT_TRUE(bob->submit(kSphere, quick_options(), bobs).ok());
  {  // bob's job is in the middle of its refinement during every refusal below
    std::unique_lock lock(state->mu);
    ASSERT_TRUE(state->cv.wait_for(lock, std::chrono::seconds(20), [&] { return state->held > 0; }));
  }
  auto expect = [](const grpc::Status& s, grpc::StatusCode code, const std::string& needle, const char* what) {
    EXPECT_EQ(s.error_code(), code) << what << ": " << s.error_message();
    EXPECT_NE(s.error_message().find(needle), std::string::npos) << what << ": " << s.error_message();
  };
  v1::Job job;
  v1::ListJobsResponse list;
  expect(client("")->list(list), grpc::StatusCode::UNAUTHENTICATED, "authorization", "no token");
  expect(client("tok-wrong")->submit(kSphere, quick_options(), job), grpc::StatusCode::UNAUTHENTICATED,
         "unknown token", "wrong token");
  auto alice = client("tok-alice");
  expect(alice->get(bobs.id(), job), grpc::StatusCode::NOT_FOUND, "no job", "another user's job");
  expect(alice->cancel(bobs.id(), job), grpc::StatusCode::NOT_FOUND, "no job", "another user's job");
  {
    const auto big = dir_.path() / "big.stl";
    std::ofstream(big) << std::string(400001, 'x');
    expect(alice->submit(big, quick_options(), job), grpc::StatusCode::RESOURCE_EXHAUSTED, "max_upload_bytes=400000",
           "oversized upload");
  }
  expect(alice->submit(write_open_tetrahedron(), quick_options(), job), grpc::StatusCode::INVALID_ARGUMENT,
         "open edge", "malformed surface");
  {
    const auto garbled = dir_.path() / "garbled.stl";
    std::ofstream(garbled) << "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 zero\n";
    expect(alice->submit(garbled, quick_options(), job), grpc::StatusCode::INVALID_ARGUMENT, "garbled.stl:",
           "unparsable surface");
  }
  {
    v1::MeshOptions bad = quick_options();
    bad.set_growth(0.5);
    expect(alice->submit(kSphere, bad, job), grpc::StatusCode::INVALID_ARGUMENT, "growth", "growth out of range");
    bad = quick_options();
    bad.set_kernel("magic");
    expect(alice->submit(kSphere, bad, job), grpc::StatusCode::INVALID_ARGUMENT, "kernel", "unknown kernel");
    bad = quick_options();
    bad.set_depth(11);
    expect(alice->submit(kSphere, bad, job), grpc::StatusCode::INVALID_ARGUMENT, "depth", "depth out of range");
    bad = quick_options();
    bad.mutable_layers()->set_count(3);
    expect(alice->submit(kSphere, bad, job), grpc::StatusCode::INVALID_ARGUMENT, "first layer's height",
           "layers without a first height");
    bad.mutable_layers()->set_first_height(0.05);
    bad.mutable_layers()->add_on("wing");
    expect(alice->submit(kSphere, bad, job), grpc::StatusCode::INVALID_ARGUMENT, "wing names no surface",
           "layers on an unknown surface");
    bad.mutable_layers()->clear_on();
    bad.mutable_layers()->add_in_regions("fluid");
    expect(alice->submit(kSphere, bad, job), grpc::StatusCode::INVALID_ARGUMENT, "is one region",
           "layers in regions of a surface of one region");
    bad.mutable_layers()->clear_in_regions();
    bad.set_max_volume(1);
    expect(alice->submit(kSphere, bad, job), grpc::StatusCode::INVALID_ARGUMENT, "not with max_volume",
           "layers with max_volume");
  }
  const auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(coordinator_->port()),
                                           grpc::InsecureChannelCredentials());
  {  // A chunk before the header.
    auto stub = v1::JobService::NewStub(channel);
    grpc::ClientContext context;
    context.AddMetadata("authorization", "Bearer tok-alice");
    v1::Job response;
    auto writer = stub->SubmitJob(&context, &response);
    v1::SubmitRequest chunk;
    chunk.set_chunk("solid x\n");
    writer->Write(chunk);
    writer->WritesDone();
    expect(writer->Finish(), grpc::StatusCode::INVALID_ARGUMENT, "first message must be the header",
           "chunk before header");
  }
  {  // Bytes that are no protobuf message at all.
    const auto [status, bytes] =
        raw_unary(channel, "/pdrmesh.v1.JobService/GetJob", std::string("\xff\xff\xff\xff garbage", 12), "tok-alice");
    EXPECT_FALSE(status.ok());
    EXPECT_NE(status.error_code(), grpc::StatusCode::UNAVAILABLE) << "the server answered, and is still up";
  }
  ASSERT_TRUE(alice->list(list).ok());
  EXPECT_EQ(list.jobs_size(), 0) << "no refused request created a job";
  {
    std::lock_guard lock(state->mu);
    state->released = true;
  }
  const v1::Job done = watch(*bob, bobs.id());
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error();
}

TEST_F(Service, HealthServiceAnswersServing) {
  start(0);
  const auto [status, bytes] = raw_unary(grpc::CreateChannel("127.0.0.1:" + std::to_string(coordinator_->port()),
                                                             grpc::InsecureChannelCredentials()),
                                         "/grpc.health.v1.Health/Check", "", "");  // HealthCheckRequest{service: ""}
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(bytes, std::string("\x08\x01", 2)) << "HealthCheckResponse{status: SERVING}";
}

TEST_F(Service, ReflectionListsTheServices) {
  start(0);
  // ServerReflectionRequest{list_services: ""}: field 7, length 0.
  const auto [status, bytes] = OneRequestStream().call(
      grpc::CreateChannel("127.0.0.1:" + std::to_string(coordinator_->port()), grpc::InsecureChannelCredentials()),
      "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", std::string("\x3a\x00", 2));
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_NE(bytes.find("pdrmesh.v1.JobService"), std::string::npos);
  EXPECT_NE(bytes.find("grpc.health.v1.Health"), std::string::npos);
}

TEST(JobOptions, RoundTripsThroughJsonAndRefusesOutOfRangeValuesByName) {
  JobOptions o;
  o.sizing.size = 0.25;
  o.sizing.hmax = 2;
  o.sizing.growth = 1.5;
  o.depth = 3;
  o.kernel = "tetgen";
  o.interface_round = false;
  o.optimize = false;
  o.time_limit_s = 42;
  auto back = JobOptions::from_json(o.to_json());
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->to_json(), o.to_json());
  EXPECT_EQ(back->sizing.size, 0.25);
  EXPECT_FALSE(back->sizing.hmin.has_value());
  EXPECT_EQ(back->kernel, "tetgen");
  EXPECT_FALSE(back->optimize);
  EXPECT_TRUE(JobOptions::from_json("{}").ok()) << "every option has a default";

  const std::pair<const char*, const char*> bad[] = {
      {R"({"growth": 1.0})", "growth"},      {R"({"size": -1})", "size"},
      {R"({"hmin": 2, "hmax": 1})", "hmin"}, {R"({"depth": 11})", "depth"},
      {R"({"depth": 1.5})", "depth"},        {R"({"kernel": "x"})", "kernel"},
      {R"({"optimize": 1})", "optimize"},    {R"({"time_limit_s": 0})", "time_limit_s"},
      {R"({"max_volume": "big"})", "max_volume"},
      {R"({"depth": 4294967297})", "depth"}};  // would wrap to 1 (found by fuzzing)
  for (const auto& [json, name] : bad) {
    const auto r = JobOptions::from_json(json);
    ASSERT_FALSE(r.ok()) << json;
    EXPECT_EQ(r.status().code(), StatusCode::kInvalidInput) << json;
    EXPECT_NE(r.status().message().find(name), std::string::npos) << json << ": " << r.status().message();
  }

  v1::MeshOptions proto;
  to_proto(o, proto);
  auto from = from_proto(proto, JobOptions{});
  ASSERT_TRUE(from.ok()) << from.status().to_string();
  EXPECT_EQ(from->to_json(), o.to_json()) << "proto and JSON carry the same options";

  // Layers: every field through JSON and proto; bad values named.
  o.layers = LayerRequest{};
  o.layers->layers = 20;
  o.layers->first_height = 1;
  o.layers->yplus = true;
  o.layers->reynolds = 1e6;
  o.layers->reference_length = 2;
  o.layers->growth_ratio = 1.15;
  o.layers->max_thickness = 0.5;
  o.layers->on = {"wall", "3"};
  o.layers->in = {"fluid"};
  back = JobOptions::from_json(o.to_json());
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->to_json(), o.to_json());
  ASSERT_TRUE(back->layers.has_value());
  EXPECT_EQ(back->layers->on, o.layers->on);
  EXPECT_EQ(back->layers->in, o.layers->in);
  EXPECT_TRUE(back->layers->yplus);
  to_proto(o, proto);
  from = from_proto(proto, JobOptions{});
  ASSERT_TRUE(from.ok()) << from.status().to_string();
  EXPECT_EQ(from->to_json(), o.to_json()) << "proto and JSON carry the same layers";
  const std::pair<const char*, const char*> bad_layers[] = {
      {R"({"layers": {"count": 0, "first_height": 1}})", "layers.count"},
      {R"({"layers": {"count": 3, "first_height": -1}})", "--first-height"},
      {R"({"layers": {"count": 3, "first_height": 1, "growth_ratio": 20}})", "--growth-ratio"},
      {R"({"layers": {"count": 3, "first_height_yplus": 1}})", "--reynolds"},
      {R"({"layers": {"count": 3, "first_height": 1, "on": "wall"}})", "layers.on"},
      {R"({"layers": {"count": 3, "first_height": 1, "in": [1]}})", "layers.in"},
      {R"({"layers": {"count": 3, "first_height": 1, "colour": 1}})", "colour"},
      {R"({"max_volume": 1, "layers": {"count": 3, "first_height": 1}})", "max_volume"}};
  for (const auto& [json, name] : bad_layers) {
    const auto r = JobOptions::from_json(json);
    ASSERT_FALSE(r.ok()) << json;
    EXPECT_EQ(r.status().code(), StatusCode::kInvalidInput) << json;
    EXPECT_NE(r.status().message().find(name), std::string::npos) << json << ": " << r.status().message();
  }
}

TEST(ProgressDisplay, PlainLinesOnPhaseChangesAndAtMostOneAnIntervalWithin) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  {
    cli::ProgressDisplay d(cli::ProgressDisplay::Mode::kLines, f, /*line_interval_s=*/3600);
    d.update({"sizing", 0, 0, 0, 1.0});
    d.update({"refinement", 1, 8, 100, 2.0});
    d.update({"refinement", 2, 8, 200, 2.5});  // within the interval: no line
    d.update({"optimization", 0, 0, 900, 3.0});
    d.say("done");
  }
  std::rewind(f);
  std::string text;
  for (int ch; (ch = std::fgetc(f)) != EOF;) text += static_cast<char>(ch);
  std::fclose(f);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 4) << text;
  EXPECT_NE(text.find("refinement"), std::string::npos);
  EXPECT_NE(text.find("1/8 leaves"), std::string::npos) << text;
  EXPECT_EQ(text.find("2/8 leaves"), std::string::npos) << text;
  EXPECT_NE(text.find("900 tets"), std::string::npos) << text;
  EXPECT_EQ(text.find('\r'), std::string::npos) << "no terminal controls in plain mode";
  EXPECT_NE(cli::ProgressDisplay::format_line({"refinement", 4, 8, 10, 1}, 1, true).find("[############............]"),
            std::string::npos);
}

}  // namespace
}  // namespace pdrmesh::server
