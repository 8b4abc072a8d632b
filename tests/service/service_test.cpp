// SPDX-License-Identifier: AGPL-3.0-or-later
// End-to-end tests of the service: an in-process coordinator on 127.0.0.1 with
// a temporary data directory, driven through the real client (ServiceClient
// over the generated stub).
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <new>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <memory>
#include <string>
#include <vector>

#include "coordinator.hpp"
#include "pdr_engine.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/volume_io.hpp"
#include "service_client.hpp"
#include "service_fixture.hpp"
#include "temp_dir.hpp"

namespace pdrmesh::server {
namespace {


/// What the gated engine's jobs wait for; shared by the test and the engine.
struct Gate {
  std::mutex mu;
  std::condition_variable cv;
  int entered = 0;
  bool open = false;
  void release() {
    std::lock_guard lock(mu);
    open = true;
    cv.notify_all();
  }
  /// True when `n` jobs have entered the engine within 10 s.
  bool wait_entered(int n) {
    std::unique_lock lock(mu);
    return cv.wait_for(lock, std::chrono::seconds(10), [&] { return entered >= n; });
  }
};

/// Holds every job in "tetrahedralizing" until the gate opens (or the job must
/// stop), then meshes it with the PdrEngine: running jobs on demand, without sleeps.
class GatedEngine final : public MeshEngine {
 public:
  explicit GatedEngine(std::shared_ptr<Gate> gate) : gate_(std::move(gate)) {}
  Result<VolumeMesh> mesh(const JobRecord& job, const JobDomain& domain, const JobOptions& options,
                          JobProgress& progress, const JobCheckpoint* checkpoint) override {
    {
      std::lock_guard lock(gate_->mu);
      ++gate_->entered;
      gate_->cv.notify_all();
    }
    for (;;) {
      if (!progress.report("tetrahedralizing", 0.3)) return internal_error("stopped");
      std::unique_lock lock(gate_->mu);
      if (gate_->cv.wait_for(lock, std::chrono::milliseconds(20), [&] { return gate_->open; })) break;
    }
    return engine_.mesh(job, domain, options, progress, checkpoint);
  }

 private:
  std::shared_ptr<Gate> gate_;
  PdrEngine engine_{std::make_shared<LocalLeafDispatch>(1)};
};

/// The result of job `id` (of the sphere), fetched as .meshb, read and
/// validated against the sphere (failures are the test's); empty when unreadable.
VolumeMesh fetch_valid_sphere_mesh(cli::ServiceClient& c, const std::string& id, const std::filesystem::path& dir) {
  const auto meshb = dir / "out.meshb";
  const grpc::Status fetched = c.fetch(id, meshb);
  EXPECT_TRUE(fetched.ok()) << fetched.error_message();
  auto mesh = read_volume(meshb);
  EXPECT_TRUE(mesh.ok()) << mesh.status().to_string();
  auto surface = read_surface(kSphere);
  EXPECT_TRUE(surface.ok());
  if (!mesh.ok() || !surface.ok()) return {};
  const ValidationReport report = validate_mesh(*mesh, &*surface);
  EXPECT_TRUE(report.ok()) << format_validation(report);
  return std::move(mesh).value();
}

TEST_F(Service, SubmitWatchFetchGivesAValidMeshOfTheSurface) {
  start(1);
  auto alice = client("tok-alice");
  v1::Job job;
  ASSERT_TRUE(alice->submit(kSphere, v1::MeshOptions(), job).ok());
  EXPECT_EQ(job.user(), "alice");
  EXPECT_EQ(job.input_name(), "sphere966.stl");
  std::vector<v1::JobEvent> events;
  const v1::Job done = watch(*alice, job.id(), &events);
  ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error();
  EXPECT_EQ(done.phase(), "done");
  EXPECT_EQ(done.progress(), 1.0);
  EXPECT_GT(done.tets(), 0U);
  ASSERT_FALSE(events.empty());
  for (std::size_t i = 1; i < events.size(); ++i) {
    EXPECT_GE(events[i].job().progress(), events[i - 1].job().progress()) << "progress never goes back";
  }
  EXPECT_GE(events.back().elapsed_s(), 0.0);

  const VolumeMesh mesh = fetch_valid_sphere_mesh(*alice, job.id(), dir_.path());
  EXPECT_EQ(mesh.tets.size(), done.tets());

  // Another format, converted by the coordinator: the same mesh.
  const auto vtu = dir_.path() / "out.lb8.ugrid";
  ASSERT_TRUE(alice->fetch(job.id(), vtu).ok());
  auto again = read_volume(vtu);
  ASSERT_TRUE(again.ok()) << again.status().to_string();
  EXPECT_EQ(again->tets, mesh.tets);
  EXPECT_EQ(again->points, mesh.points);
}

/// Reads a whole file (empty when missing).
std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

TEST_F(Service, BoundaryNamesFromTheSolidsAndTheOptionsReachEveryFetchedFormat) {
  // The sphere as three named STL solids by the height of each triangle's first point.
  auto sphere = read_surface(kSphere);
  ASSERT_TRUE(sphere.ok());
  for (std::size_t t = 0; t < sphere->triangles.size(); ++t) {
    const double z = sphere->points[sphere->triangles[t][0]][2];
    sphere->surface_ids[t] = z > 3 ? 1 : (z < -3 ? 2 : 3);  // radius 10
  }
  sphere->surface_names = {{1, "top"}, {2, "bottom"}};  // 3: unnamed
  const auto stl = dir_.path() / "named.stl";
  ASSERT_TRUE(write_surface(*sphere, stl).ok());

  start(1);
  auto alice = client("tok-alice");
  v1::MeshOptions options;
  (*options.mutable_surface_names())[2] = "base";  // over the solid's own name
  v1::Job job;
  ASSERT_TRUE(alice->submit(stl, options, job).ok());
  EXPECT_EQ(job.options().surface_names().at(2), "base");
  const v1::Job done = watch(*alice, job.id());
  ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error();

  const std::map<int, std::string> want{{1, "top"}, {2, "base"}};
  const auto su2 = dir_.path() / "out.su2";
  ASSERT_TRUE(alice->fetch(job.id(), su2).ok());
  const std::string text = slurp(su2);
  for (const char* tag : {"top", "base", "surface_3"})
    EXPECT_NE(text.find(fmt::format("MARKER_TAG= {}\n", tag)), std::string::npos) << tag;
  auto mesh = read_volume(su2);
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  EXPECT_EQ(mesh->boundary_names, want);
  auto surface = read_surface(stl);
  ASSERT_TRUE(surface.ok());
  const ValidationReport report = validate_mesh(*mesh, &*surface);
  EXPECT_TRUE(report.ok()) << format_validation(report);

  // UGRID: the client fetches its .mapbc beside it.
  const auto ugrid = dir_.path() / "out.lb8.ugrid";
  ASSERT_TRUE(alice->fetch(job.id(), ugrid).ok());
  EXPECT_EQ(slurp(dir_.path() / "out.mapbc"), "3\n1 3000 top\n2 3000 base\n3 3000 surface_3\n");
  auto grid = read_volume(ugrid);
  ASSERT_TRUE(grid.ok()) << grid.status().to_string();
  EXPECT_EQ(grid->boundary_names, want);
  std::vector<int> got = grid->boundary_ids, given = surface->surface_ids;
  std::sort(got.begin(), got.end());
  std::sort(given.begin(), given.end());
  EXPECT_EQ(got, given) << "the boundary carries the surface's ids";
}

TEST_F(Service, NamesForIdsTheSurfaceLacksOrBadNamesAreInvalidArgument) {
  start(1);
  auto alice = client("tok-alice");
  const std::pair<std::pair<int, std::string>, const char*> bad[] = {
      {{7, "inlet"}, "id 7 ('inlet') is not a surface id here (the ids are 1)"},
      {{1, "two words"}, "'two words' has the character ' '"}};
  for (const auto& [entry, why] : bad) {
    v1::MeshOptions options;
    (*options.mutable_surface_names())[entry.first] = entry.second;
    v1::Job job;
    const grpc::Status s = alice->submit(kSphere, options, job);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << s.error_message();
    EXPECT_NE(s.error_message().find(why), std::string::npos) << s.error_message();
  }
  v1::ListJobsResponse jobs;
  ASSERT_TRUE(alice->list(jobs).ok());
  EXPECT_EQ(jobs.jobs_size(), 0);
}

TEST_F(Service, DefectiveSurfaceIsInvalidArgumentNamingTheDefectAndCreatesNoJob) {
  start(1);
  auto alice = client("tok-alice");
  v1::Job job;
  const grpc::Status s = alice->submit(write_open_tetrahedron(), v1::MeshOptions(), job);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("open edge"), std::string::npos) << s.error_message();
  EXPECT_NE(s.error_message().find("open.stl"), std::string::npos) << s.error_message();
  v1::ListJobsResponse jobs;
  ASSERT_TRUE(alice->list(jobs).ok());
  EXPECT_EQ(jobs.jobs_size(), 0);
  EXPECT_FALSE(std::filesystem::exists(dir_.path() / "data" / "jobs") &&
               !std::filesystem::is_empty(dir_.path() / "data" / "jobs"))
      << "no job directory is left behind";
}

TEST_F(Service, MissingOrUnknownTokenIsUnauthenticated) {
  start(0);
  for (const std::string token : {"", "tok-mallory", "tok-alic"}) {
    auto c = client(token);
    v1::ListJobsResponse jobs;
    EXPECT_EQ(c->list(jobs).error_code(), grpc::StatusCode::UNAUTHENTICATED) << "token '" << token << "'";
    v1::Job job;
    EXPECT_EQ(c->submit(kSphere, v1::MeshOptions(), job).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  }
}

TEST_F(Service, AUsersJobIsNotFoundForAnotherUser) {
  start(0);
  auto alice = client("tok-alice");
  auto bob = client("tok-bob");
  v1::Job job;
  ASSERT_TRUE(alice->submit(kSphere, v1::MeshOptions(), job).ok());
  v1::Job seen;
  EXPECT_EQ(bob->get(job.id(), seen).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(bob->cancel(job.id(), seen).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(bob->fetch(job.id(), dir_.path() / "stolen.meshb").error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(bob->watch(job.id(), [](const v1::JobEvent&) {}, seen).error_code(), grpc::StatusCode::NOT_FOUND);
  v1::ListJobsResponse jobs;
  ASSERT_TRUE(bob->list(jobs).ok());
  EXPECT_EQ(jobs.jobs_size(), 0);
  ASSERT_TRUE(alice->get(job.id(), seen).ok());
  EXPECT_EQ(seen.state(), v1::JOB_STATE_QUEUED);
}

TEST_F(Service, QueuedJobLimitIsResourceExhaustedPerUser) {
  UserLimits limits;
  limits.max_queued_jobs = 1;
  start(0, limits);
  auto alice = client("tok-alice");
  v1::Job job;
  ASSERT_TRUE(alice->submit(kSphere, v1::MeshOptions(), job).ok());
  const grpc::Status s = alice->submit(kSphere, v1::MeshOptions(), job);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(s.error_message().find("max_queued_jobs=1"), std::string::npos) << s.error_message();
  EXPECT_TRUE(client("tok-bob")->submit(kSphere, v1::MeshOptions(), job).ok()) << "bob has his own limit";
}

TEST_F(Service, UploadLimitIsResourceExhausted) {
  UserLimits limits;
  limits.max_upload_bytes = 1000;
  start(0, limits);
  v1::Job job;
  const grpc::Status s = client("tok-alice")->submit(kSphere, v1::MeshOptions(), job);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(s.error_message().find("max_upload_bytes=1000"), std::string::npos) << s.error_message();
}

TEST_F(Service, CancelledQueuedJobEndsAndHasNoResult) {
  start(0);
  auto alice = client("tok-alice");
  v1::Job job;
  ASSERT_TRUE(alice->submit(kSphere, v1::MeshOptions(), job).ok());
  v1::Job cancelled;
  ASSERT_TRUE(alice->cancel(job.id(), cancelled).ok());
  EXPECT_EQ(cancelled.state(), v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(watch(*alice, job.id()).state(), v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(alice->fetch(job.id(), dir_.path() / "x.meshb").error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_FALSE(std::filesystem::exists(dir_.path() / "x.meshb"));
  EXPECT_FALSE(std::filesystem::exists(dir_.path() / "x.meshb.part"));
}

TEST_F(Service, QueuedJobRunsAfterARestartOnTheSameDataDirectory) {
  start(0);  // nothing runs: the job stays queued
  std::string id;
  {
    auto alice = client("tok-alice");
    v1::Job job;
    ASSERT_TRUE(alice->submit(kSphere, v1::MeshOptions(), job).ok());
    id = job.id();
  }
  coordinator_->Shutdown();
  coordinator_.reset();
  start(1);
  auto alice = client("tok-alice");
  const v1::Job done = watch(*alice, id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error();
  ASSERT_TRUE(alice->fetch(id, dir_.path() / "after_restart.meshb").ok());
  EXPECT_TRUE(read_volume(dir_.path() / "after_restart.meshb").ok());
}

TEST_F(Service, RunningJobIsCancelledAtItsNextPhase) {
  auto gate = std::make_shared<Gate>();
  start(1, {}, std::make_unique<GatedEngine>(gate));
  auto alice = client("tok-alice");
  v1::Job job;
  ASSERT_TRUE(alice->submit(kSphere, v1::MeshOptions(), job).ok());
  ASSERT_TRUE(gate->wait_entered(1));
  v1::Job now;
  ASSERT_TRUE(alice->cancel(job.id(), now).ok());
  EXPECT_EQ(now.state(), v1::JOB_STATE_RUNNING) << "running jobs end at their next phase boundary";
  EXPECT_EQ(watch(*alice, job.id()).state(), v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(alice->fetch(job.id(), dir_.path() / "x.meshb").error_code(), grpc::StatusCode::FAILED_PRECONDITION);
}

TEST_F(Service, RunningJobLimitKeepsAUsersFurtherJobsQueued) {
  auto gate = std::make_shared<Gate>();
  UserLimits limits;
  limits.max_running_jobs = 1;
  start(2, limits, std::make_unique<GatedEngine>(gate));
  auto alice = client("tok-alice");
  auto bob = client("tok-bob");
  v1::Job a1, a2, b1;
  ASSERT_TRUE(alice->submit(kSphere, v1::MeshOptions(), a1).ok());
  ASSERT_TRUE(alice->submit(kSphere, v1::MeshOptions(), a2).ok());
  ASSERT_TRUE(bob->submit(kSphere, v1::MeshOptions(), b1).ok());
  ASSERT_TRUE(gate->wait_entered(2)) << "alice's first and bob's job run on the two threads";
  v1::Job seen;
  ASSERT_TRUE(alice->get(a1.id(), seen).ok());
  EXPECT_EQ(seen.state(), v1::JOB_STATE_RUNNING);
  ASSERT_TRUE(alice->get(a2.id(), seen).ok());
  EXPECT_EQ(seen.state(), v1::JOB_STATE_QUEUED);
  ASSERT_TRUE(bob->get(b1.id(), seen).ok());
  EXPECT_EQ(seen.state(), v1::JOB_STATE_RUNNING);
  gate->release();
  EXPECT_EQ(watch(*alice, a2.id()).state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(watch(*alice, a1.id()).state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(watch(*bob, b1.id()).state(), v1::JOB_STATE_SUCCEEDED);
}

TEST_F(Service, ShutdownRequeuesARunningJobAndTheRestartFinishesIt) {
  auto gate = std::make_shared<Gate>();
  start(1, {}, std::make_unique<GatedEngine>(gate));
  std::string id;
  {
    auto alice = client("tok-alice");
    v1::Job job;
    ASSERT_TRUE(alice->submit(kSphere, v1::MeshOptions(), job).ok());
    id = job.id();
  }
  ASSERT_TRUE(gate->wait_entered(1));
  coordinator_->Shutdown();
  coordinator_.reset();
  start(1);
  const v1::Job done = watch(*client("tok-alice"), id);
  EXPECT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error();
}

TEST_F(Service, RefusesPlaintextOnANonLoopbackAddress) {
  Options o = options(0);
  o.listen_address = "0.0.0.0:0";
  const auto c = Coordinator::BuildAndStart(o);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.status().message().find("clear text"), std::string::npos) << c.status().message();
  EXPECT_TRUE(is_loopback_address("127.0.0.1:0"));
  EXPECT_TRUE(is_loopback_address("[::1]:5000"));
  EXPECT_FALSE(is_loopback_address("[::]:5000"));
}

TEST(VolumeFormatOf, PicksTheLongestSuffix) {
  EXPECT_EQ(cli::volume_format_of("a/b.lb8.ugrid"), "lb8.ugrid");
  EXPECT_EQ(cli::volume_format_of("b.UGRID"), "ugrid");
  EXPECT_EQ(cli::volume_format_of("b.meshb"), "meshb");
  EXPECT_EQ(cli::volume_format_of("b.mesh"), "mesh");
  EXPECT_EQ(cli::volume_format_of("b.stl"), "");
  EXPECT_EQ(volume_suffix("").value(), ".meshb");
  EXPECT_EQ(volume_suffix("../x.vtu").status().code(), StatusCode::kUnsupported);
}

TEST_F(Service, AJobOverTheTetLimitsIsResourceExhaustedWithTheEstimateAndCreatesNoJob) {
  // Without a per-user limit: far beyond any memory, the coordinator's memory budget refuses it.
  start(0);
  v1::MeshOptions tiny;
  tiny.set_size(1e-9);
  v1::Job job;
  grpc::Status s = client("tok-bob")->submit(kSphere, tiny, job);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(s.error_message().find("--size 1e-09 would make about"), std::string::npos) << s.error_message();
  EXPECT_NE(s.error_message().find("(the coordinator's memory budget); use --size "), std::string::npos)
      << s.error_message();
  coordinator_.reset();
  // The per-user limit, when lower, is the one named.
  UserLimits limits;
  limits.max_job_tets = 1000;  // the sphere at its own spacing is about 15,000
  start(0, limits);
  auto alice = client("tok-alice");
  s = alice->submit(kSphere, v1::MeshOptions(), job);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(s.error_message().find("the default sizing would make about"), std::string::npos) << s.error_message();
  EXPECT_NE(s.error_message().find("the limit is 1,000 tets (max_job_tets"), std::string::npos) << s.error_message();
  EXPECT_NE(s.error_message().find("use --size "), std::string::npos) << s.error_message();
  v1::ListJobsResponse jobs;
  ASSERT_TRUE(alice->list(jobs).ok());
  EXPECT_EQ(jobs.jobs_size(), 0);
  // Under the limit: accepted.
  v1::MeshOptions coarse;
  coarse.set_size(8);
  EXPECT_TRUE(alice->submit(kSphere, coarse, job).ok());
}

/// Runs out of memory in its first job, then meshes like the PdrEngine.
class OutOfMemoryOnceEngine final : public MeshEngine {
 public:
  Result<VolumeMesh> mesh(const JobRecord& job, const JobDomain& domain, const JobOptions& options,
                          JobProgress& progress, const JobCheckpoint* checkpoint) override {
    if (!thrown_.exchange(true)) throw std::bad_alloc();
    return engine_.mesh(job, domain, options, progress, checkpoint);
  }

 private:
  std::atomic<bool> thrown_{false};
  PdrEngine engine_{std::make_shared<LocalLeafDispatch>(1)};
};

TEST_F(Service, AnAllocationFailureFailsItsJobAndTheCoordinatorGoesOn) {
  start(1, {}, std::make_unique<OutOfMemoryOnceEngine>());
  auto alice = client("tok-alice");
  v1::Job first, second;
  ASSERT_TRUE(alice->submit(kSphere, v1::MeshOptions(), first).ok());
  const v1::Job failed = watch(*alice, first.id());
  EXPECT_EQ(failed.state(), v1::JOB_STATE_FAILED);
  EXPECT_NE(failed.error().find("out of memory while meshing"), std::string::npos) << failed.error();
  ASSERT_TRUE(alice->submit(kSphere, v1::MeshOptions(), second).ok());
  EXPECT_EQ(watch(*alice, second.id()).state(), v1::JOB_STATE_SUCCEEDED);
}

TEST_F(Service, AJobThatDoesNotFitTheMemoryBudgetBesideARunningOneWaits) {
  auto gate = std::make_shared<Gate>();
  Options o = options(2);
  // The sphere's estimate is 32 MB of fixed part and a few MB of tets: one fits, two do not.
  o.memory_budget_bytes = 50e6;
  start(o, std::make_unique<GatedEngine>(gate));
  auto alice = client("tok-alice");
  auto bob = client("tok-bob");
  v1::Job a, b;
  ASSERT_TRUE(alice->submit(kSphere, v1::MeshOptions(), a).ok());
  ASSERT_TRUE(gate->wait_entered(1));
  ASSERT_TRUE(bob->submit(kSphere, v1::MeshOptions(), b).ok());
  EXPECT_FALSE(gate->wait_entered(2)) << "bob's job started beside alice's over the budget";
  v1::Job seen;
  ASSERT_TRUE(bob->get(b.id(), seen).ok());
  EXPECT_EQ(seen.state(), v1::JOB_STATE_QUEUED);
  gate->release();
  EXPECT_EQ(watch(*alice, a.id()).state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(watch(*bob, b.id()).state(), v1::JOB_STATE_SUCCEEDED);
}

TEST_F(Service, ACoordinatorWithAWorkerRegistryButNoWorkerRefinesLeavesItself) {
  Options o = options(1);
  o.worker_listen_address = "127.0.0.1:0";
  o.cluster_token_file = dir_.path() / "cluster-token";
  std::ofstream(o.cluster_token_file) << "test-cluster-token-0123456789\n";
  start(o);
  ASSERT_NE(coordinator_->remote_dispatch(), nullptr);
  auto alice = client("tok-alice");
  v1::MeshOptions depth1;
  depth1.set_depth(1);
  v1::Job job;
  ASSERT_TRUE(alice->submit(kSphere, depth1, job).ok());
  const v1::Job done = watch(*alice, job.id());
  ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error();
  EXPECT_GT(fetch_valid_sphere_mesh(*alice, job.id(), dir_.path()).tets.size(), 0U);
}

}  // namespace
}  // namespace pdrmesh::server
