// SPDX-License-Identifier: AGPL-3.0-or-later
// A job's round checkpoint (JobCheckpoint) with the PdrEngine, without gRPC: a
// job stopped after its first round goes on from it with the bytes of an
// uninterrupted run, and a checkpoint written for another key or damaged on
// disk is not used. Also: the engine asks its dispatch for the concurrency as
// the job goes (workers joining mid-job widen it), with the same bytes.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "job_checkpoint.hpp"
#include "leaf_dispatch.hpp"
#include "pdr_engine.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/validate.hpp"
#include "temp_dir.hpp"

namespace pdrmesh::server {
namespace {

/// Records the phases reported (report() calls are serialised); stops the job
/// when `stop_at` is reported (keep_going() may be asked from any thread).
class Phases final : public JobProgress {
 public:
  explicit Phases(std::string stop_at = {}) : stop_at_(std::move(stop_at)) {}
  bool report(std::string_view phase, double) override {
    if (seen.empty() || seen.back() != phase) seen.emplace_back(phase);
    if (phase == stop_at_) stopped = true;
    return !stopped;
  }
  bool keep_going() override { return !stopped; }
  void mesh_size(std::uint64_t, std::uint64_t) override {}
  void leaves(std::uint64_t, std::uint64_t) override {}
  bool saw(std::string_view phase) const { return std::find(seen.begin(), seen.end(), phase) != seen.end(); }

  std::vector<std::string> seen;
  std::atomic<bool> stopped = false;

 private:
  std::string stop_at_;
};

/// A job of `user` on sphere966 at depth 2, as the engine tests run it.
struct SphereJob {
  Result<SurfaceMesh> surface;
  JobRecord job;
  JobOptions options;
  SphereJob(std::string id, std::string user)
      // (job_manager_test.cpp, built with this file as one unit, has its own kSphere.)
      : surface(read_surface(std::filesystem::path(PDRMESH_CORPUS_DIR) / "sphere966.stl")) {
    job.id = std::move(id);
    job.user = std::move(user);
    options.depth = 2;
  }
};

TEST(JobCheckpoint, AJobStoppedAfterItsFirstRoundGoesOnFromItWithTheBytesOfAWholeRun) {
  test::TempDir dir;
  SphereJob sj("j1", "alice");
  ASSERT_TRUE(sj.surface.ok()) << sj.surface.status().to_string();
  const SurfaceMesh* surface = &*sj.surface;
  const JobRecord& job = sj.job;
  const JobOptions& options = sj.options;
  PdrEngine engine(std::make_shared<LocalLeafDispatch>(2));

  Phases whole_run;
  auto whole = engine.mesh(job, JobDomain{*surface, {}}, options, whole_run, nullptr);
  ASSERT_TRUE(whole.ok()) << whole.status().to_string();
  ASSERT_TRUE(whole_run.saw("refinement"));
  ASSERT_TRUE(whole_run.saw("optimization"));

  const std::filesystem::path file = dir.path() / "checkpoint.pdrck";
  const JobCheckpoint checkpoint(file, "key of job j1");
  Phases stopped("optimization");  // the refinement is done and stored by then
  EXPECT_FALSE(engine.mesh(job, JobDomain{*surface, {}}, options, stopped, &checkpoint).ok());
  ASSERT_TRUE(std::filesystem::exists(file));
  {
    const std::optional<PdrCheckpoint> stored = checkpoint.load();
    ASSERT_TRUE(stored.has_value());
    EXPECT_EQ(stored->rounds_done, 1);
    EXPECT_EQ(stored->round, "refinement");
    EXPECT_TRUE(validate_mesh(stored->mesh, &*surface).ok());
  }

  Phases resumed_run;
  auto resumed = engine.mesh(job, JobDomain{*surface, {}}, options, resumed_run, &checkpoint);
  ASSERT_TRUE(resumed.ok()) << resumed.status().to_string();
  EXPECT_FALSE(resumed_run.saw("initial mesh"));
  EXPECT_FALSE(resumed_run.saw("refinement"));
  EXPECT_TRUE(resumed_run.saw("optimization"));
  const ValidationReport v = validate_mesh(*resumed, &*surface);
  EXPECT_TRUE(v.ok()) << validation_status(v).message();
  EXPECT_EQ(resumed->points, whole->points);
  EXPECT_EQ(resumed->tets, whole->tets);
  EXPECT_EQ(resumed->boundary, whole->boundary);
  EXPECT_EQ(resumed->boundary_ids, whole->boundary_ids);
  // It stored a later round (rounds closer together than 20 times a store's
  // time are skipped, so not necessarily the last).
  const std::optional<PdrCheckpoint> last = checkpoint.load();
  ASSERT_TRUE(last.has_value());
  EXPECT_GT(last->rounds_done, 1);
  EXPECT_TRUE(validate_mesh(last->mesh, surface).ok());
}

/// The local dispatch, telling a job a concurrency that grows each time it is
/// asked (workers joining during the job), and counting the questions.
class GrowingDispatch final : public LeafDispatch {
 public:
  Result<std::unique_ptr<LeafKernel>> kernel_for(const LeafJob& job) override { return local_.kernel_for(job); }
  std::size_t concurrency() const override { return 1 + asked_.fetch_add(1) % 4; }
  std::size_t asked() const { return asked_.load(); }

 private:
  LocalLeafDispatch local_{1};
  mutable std::atomic<std::size_t> asked_{0};
};

TEST(PdrEngine, AsksItsDispatchForTheConcurrencyAsTheJobGoesAndKeepsTheBytes) {
  SphereJob sj("j2", "bob");
  ASSERT_TRUE(sj.surface.ok()) << sj.surface.status().to_string();
  const SurfaceMesh* surface = &*sj.surface;
  const JobRecord& job = sj.job;
  const JobOptions& options = sj.options;
  Phases fixed_run, growing_run;
  auto fixed = PdrEngine(std::make_shared<LocalLeafDispatch>(1)).mesh(job, JobDomain{*surface, {}}, options, fixed_run, nullptr);
  ASSERT_TRUE(fixed.ok()) << fixed.status().to_string();
  auto dispatch = std::make_shared<GrowingDispatch>();
  auto growing = PdrEngine(dispatch).mesh(job, JobDomain{*surface, {}}, options, growing_run, nullptr);
  ASSERT_TRUE(growing.ok()) << growing.status().to_string();
  EXPECT_GT(dispatch->asked(), 20u);  // at every hand-out, not once a job
  EXPECT_EQ(growing->points, fixed->points);
  EXPECT_EQ(growing->tets, fixed->tets);
  const ValidationReport v = validate_mesh(*growing, &*surface);
  EXPECT_TRUE(v.ok()) << validation_status(v).message();
}

TEST(JobCheckpoint, TheExecutablesDigestIsReadOnceAndNotZero) {
  const std::uint64_t d = executable_digest();
  EXPECT_NE(d, 0u);
  EXPECT_EQ(executable_digest(), d);
}

TEST(JobCheckpoint, OneWrittenForAnotherKeyOrDamagedIsNotUsedAndIsRemoved) {
  test::TempDir dir;
  const std::filesystem::path file = dir.path() / "checkpoint.pdrck";
  PdrCheckpoint c;
  c.rounds_done = 1;
  c.round = "refinement";
  c.mesh.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  c.mesh.tets = {{0, 1, 2, 3}};
  c.mesh.boundary = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  c.mesh.boundary_ids = {1, 1, 1, 1};
  c.mesh.tet_regions = {0};
  const JobCheckpoint mine(file, "pdrmesh 1\noptions {}\ninput 1\n");
  EXPECT_FALSE(mine.load().has_value());  // no file yet
  ASSERT_TRUE(mine.store(c).ok());
  const std::optional<PdrCheckpoint> back = mine.load();
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->mesh.points, c.mesh.points);
  EXPECT_FALSE(std::filesystem::exists(file.string() + ".tmp"));

  const JobCheckpoint upgraded(file, "pdrmesh 2\noptions {}\ninput 1\n");
  EXPECT_FALSE(upgraded.load().has_value());
  EXPECT_FALSE(std::filesystem::exists(file));

  ASSERT_TRUE(mine.store(c).ok());
  {
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(40);  // a byte of the checkpoint, past the job header
    f.put('\x7f');
  }
  EXPECT_FALSE(mine.load().has_value());
  EXPECT_FALSE(std::filesystem::exists(file));
}

}  // namespace
}  // namespace pdrmesh::server
