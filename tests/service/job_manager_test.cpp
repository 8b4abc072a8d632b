// SPDX-License-Identifier: AGPL-3.0-or-later
// The coordinator's own concurrency, without gRPC (so that ThreadSanitizer sees
// all of it: scripts/sanitize.sh runs this binary under TSan; Debian's gRPC is
// not instrumented): JobManager with several runner threads and the PdrEngine
// running leaves on its own threads, jobs of two users at once, a cancel
// mid-run, a delete, and a reader thread listing and polling all the while.
#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "job_manager.hpp"
#include "leaf_dispatch.hpp"
#include "pdr_engine.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/volume_io.hpp"
#include "temp_dir.hpp"

namespace pdrmesh::server {
namespace {

using namespace std::chrono_literals;

const std::filesystem::path kSphere = std::filesystem::path(PDRMESH_CORPUS_DIR) / "sphere966.stl";

using test::file_bytes;

/// Polls until the job is final (or `timeout`); the last record seen.
JobRecord wait_final(JobManager& m, const std::string& user, const std::string& id,
                     std::chrono::seconds timeout = 300s) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  JobRecord last;
  while (std::chrono::steady_clock::now() < end) {
    const std::uint64_t seen = m.changes().version();
    Result<JobRecord> r = m.get(user, id);
    if (!r.ok()) break;
    last = *r;
    if (is_final(last.state)) break;
    m.changes().wait(seen, 200ms);
  }
  return last;
}

TEST(JobManagerThreads, JobsOfTwoUsersRunTogetherWithACancelADeleteAndAReader) {
  // Before any thread starts, as the daemons do: spdlog's registry is built in
  // its (uninstrumented) library on first use, which TSan cannot see.
  spdlog::set_level(spdlog::level::warn);
  test::TempDir dir;
  ManagerConfig config;
  config.data_dir = dir.path() / "data";
  config.runner_threads = 3;
  config.limits.max_running_jobs = 2;
  auto opened = JobManager::open(config, std::make_unique<PdrEngine>(std::make_shared<LocalLeafDispatch>(2)));
  ASSERT_TRUE(opened.ok()) << opened.status().to_string();
  JobManager& m = **opened;
  const std::string bytes = file_bytes(kSphere);
  ASSERT_FALSE(bytes.empty());

  JobOptions quick;
  quick.depth = 1;
  JobOptions slow;  // some 100,000 tets: still running when it is cancelled
  slow.sizing.size = 0.8;
  auto submit = [&](const std::string& user, const JobOptions& o) {
    Result<JobRecord> r = m.submit(user, "sphere966.stl", bytes, o);
    EXPECT_TRUE(r.ok()) << r.status().to_string();
    return r.ok() ? r->id : std::string();
  };
  const std::string a1 = submit("alice", quick), b1 = submit("bob", quick);
  const std::string a2 = submit("alice", slow), b2 = submit("bob", quick);

  std::atomic<bool> stop{false};
  std::atomic<int> reads{0};
  std::thread reader([&] {
    while (!stop.load()) {
      for (const char* user : {"alice", "bob"}) {
        Result<std::vector<JobRecord>> jobs = m.list(user);
        ASSERT_TRUE(jobs.ok());
        for (const JobRecord& j : *jobs) {
          EXPECT_EQ(j.user, user);
          (void)m.get(user, j.id);
        }
        ++reads;
      }
      m.changes().wait(m.changes().version(), 20ms);
    }
  });

  // Cancel alice's slow job once it runs.
  for (int i = 0; i < 3000; ++i) {
    Result<JobRecord> r = m.get("alice", a2);
    ASSERT_TRUE(r.ok());
    if (r->state == JobState::kRunning || is_final(r->state)) break;
    std::this_thread::sleep_for(10ms);
  }
  ASSERT_TRUE(m.cancel("alice", a2).ok());

  const JobRecord ra1 = wait_final(m, "alice", a1), rb1 = wait_final(m, "bob", b1);
  const JobRecord ra2 = wait_final(m, "alice", a2), rb2 = wait_final(m, "bob", b2);
  stop = true;
  reader.join();
  EXPECT_GT(reads.load(), 0);
  EXPECT_EQ(ra1.state, JobState::kSucceeded) << ra1.error;
  EXPECT_EQ(rb1.state, JobState::kSucceeded) << rb1.error;
  EXPECT_EQ(rb2.state, JobState::kSucceeded) << rb2.error;
  EXPECT_EQ(ra2.state, JobState::kCancelled) << ra2.error;

  // The same options give the same bytes, whoever asked and whatever ran beside.
  Result<std::filesystem::path> fa1 = m.result_file("alice", a1, "");
  Result<std::filesystem::path> fb1 = m.result_file("bob", b1, "");
  ASSERT_TRUE(fa1.ok() && fb1.ok());
  EXPECT_EQ(file_bytes(*fa1), file_bytes(*fb1));
  Result<VolumeMesh> mesh = read_volume(*fa1);
  Result<SurfaceMesh> surface = read_surface(kSphere);
  ASSERT_TRUE(mesh.ok() && surface.ok());
  const ValidationReport report = validate_mesh(*mesh, &*surface);
  EXPECT_TRUE(report.ok()) << format_validation(report);
  EXPECT_EQ(mesh->tets.size(), ra1.tets);

  ASSERT_TRUE(m.remove("bob", b2).ok());
  EXPECT_FALSE(m.get("bob", b2).ok());
  EXPECT_FALSE(m.get("alice", b1).ok()) << "bob's job is not alice's";
  m.stop();
}

}  // namespace
}  // namespace pdrmesh::server
