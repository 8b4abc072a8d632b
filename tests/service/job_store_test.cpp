// SPDX-License-Identifier: AGPL-3.0-or-later
// JobStore (SQLite) and TokenTable unit tests.
#include <gtest/gtest.h>

#include "job_store.hpp"
#include "temp_dir.hpp"
#include "tokens.hpp"

namespace pdrmesh::server {
namespace {

JobRecord make_job(std::string id, std::string user) {
  JobRecord j;
  j.id = std::move(id);
  j.user = std::move(user);
  j.input_name = "part.stl";
  j.input_bytes = 123;
  j.options_json = R"({"time_limit_s":60.0})";
  j.created_ms = now_unix_ms();
  return j;
}

TEST(JobStore, CreateGetUpdateRoundTrip) {
  test::TempDir dir;
  auto store = JobStore::open(dir.path() / "jobs.db");
  ASSERT_TRUE(store.ok()) << store.status().to_string();
  JobRecord a = make_job("a1", "alice");
  ASSERT_TRUE((*store)->create(a).ok());
  EXPECT_GT(a.seq, 0);
  a.state = JobState::kFailed;
  a.phase = "failed";
  a.progress = 0.5;
  a.error = "invalid input: part.stl: open edge";
  a.tets = 77;
  a.points = 30;
  a.finished_ms = a.created_ms + 5;
  ASSERT_TRUE((*store)->update(a).ok());
  auto got = (*store)->get("a1");
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(got->user, "alice");
  EXPECT_EQ(got->state, JobState::kFailed);
  EXPECT_EQ(got->phase, "failed");
  EXPECT_EQ(got->progress, 0.5);
  EXPECT_EQ(got->error, a.error);
  EXPECT_EQ(got->tets, 77U);
  EXPECT_EQ(got->points, 30U);
  EXPECT_EQ(got->options_json, a.options_json);
  EXPECT_EQ(got->input_bytes, 123U);
  EXPECT_EQ(got->finished_ms, a.finished_ms);
  EXPECT_EQ(got->seq, a.seq);
}

TEST(JobStore, DuplicateIdAndMissingJobAreErrors) {
  test::TempDir dir;
  auto store = JobStore::open(dir.path() / "jobs.db");
  ASSERT_TRUE(store.ok());
  JobRecord a = make_job("a1", "alice");
  ASSERT_TRUE((*store)->create(a).ok());
  JobRecord again = make_job("a1", "bob");
  EXPECT_FALSE((*store)->create(again).ok());
  EXPECT_EQ((*store)->get("nope").status().code(), StatusCode::kNotFound);
  EXPECT_EQ((*store)->update(make_job("nope", "alice")).code(), StatusCode::kNotFound);
}

TEST(JobStore, OtherUsersJobIsNotFound) {
  test::TempDir dir;
  auto store = JobStore::open(dir.path() / "jobs.db");
  ASSERT_TRUE(store.ok());
  JobRecord a = make_job("a1", "alice");
  ASSERT_TRUE((*store)->create(a).ok());
  EXPECT_TRUE((*store)->get("a1", std::string_view("alice")).ok());
  const auto other = (*store)->get("a1", std::string_view("bob"));
  EXPECT_EQ(other.status().code(), StatusCode::kNotFound);
  EXPECT_EQ(other.status().message(), "no job a1");  // the wording of a job that does not exist
}

TEST(JobStore, ListsOnlyTheUsersJobsNewestFirstAndCountsByState) {
  test::TempDir dir;
  auto store = JobStore::open(dir.path() / "jobs.db");
  ASSERT_TRUE(store.ok());
  for (const char* id : {"j1", "j2", "j3"}) {
    JobRecord j = make_job(id, "alice");
    ASSERT_TRUE((*store)->create(j).ok());
  }
  JobRecord b = make_job("b1", "bob");
  ASSERT_TRUE((*store)->create(b).ok());
  auto list = (*store)->list("alice");
  ASSERT_TRUE(list.ok());
  ASSERT_EQ(list->size(), 3U);
  EXPECT_EQ((*list)[0].id, "j3");
  EXPECT_EQ((*list)[2].id, "j1");
  JobRecord j2 = (*list)[1];
  j2.state = JobState::kRunning;
  ASSERT_TRUE((*store)->update(j2).ok());
  EXPECT_EQ(*(*store)->count("alice", JobState::kQueued), 2);
  EXPECT_EQ(*(*store)->count("alice", JobState::kRunning), 1);
  EXPECT_EQ(*(*store)->count("bob", JobState::kQueued), 1);
}

TEST(JobStore, ReopenRequeuesRunningJobsAndKeepsFinishedOnes) {
  test::TempDir dir;
  {
    auto store = JobStore::open(dir.path() / "jobs.db");
    ASSERT_TRUE(store.ok());
    const std::pair<const char*, JobState> jobs[] = {{"q1", JobState::kQueued},
                                                     {"r1", JobState::kRunning},
                                                     {"s1", JobState::kSucceeded},
                                                     {"q2", JobState::kQueued},
                                                     {"f1", JobState::kFailed}};
    for (auto [id, state] : jobs) {
      JobRecord j = make_job(id, "alice");
      ASSERT_TRUE((*store)->create(j).ok());
      j.state = state;
      j.started_ms = state == JobState::kQueued ? 0 : j.created_ms;
      j.phase = state == JobState::kRunning ? "tetrahedralizing" : j.phase;
      j.progress = state == JobState::kRunning ? 0.3 : 0;
      ASSERT_TRUE((*store)->update(j).ok());
    }
  }
  auto store = JobStore::open(dir.path() / "jobs.db");
  ASSERT_TRUE(store.ok());
  auto queued = (*store)->recover();
  ASSERT_TRUE(queued.ok());
  std::vector<std::string> ids;
  for (const auto& j : *queued) {
    ids.push_back(j.id);
    EXPECT_EQ(j.state, JobState::kQueued);
    EXPECT_EQ(j.phase, "queued");
    EXPECT_EQ(j.progress, 0);
    EXPECT_EQ(j.started_ms, 0);
  }
  EXPECT_EQ(ids, (std::vector<std::string>{"q1", "r1", "q2"}));  // submission order
  EXPECT_EQ((*store)->get("s1")->state, JobState::kSucceeded);
  EXPECT_EQ((*store)->get("f1")->state, JobState::kFailed);
}

TEST(TokenTable, MapsTokensToUsersAndRejectsMalformedLines) {
  auto t = TokenTable::parse("# comment\nalice tok-a\n\n  bob   tok-b  \n", "tokens");
  ASSERT_TRUE(t.ok()) << t.status().to_string();
  EXPECT_EQ(t->size(), 2U);
  EXPECT_EQ(t->user_for("tok-a"), "alice");
  EXPECT_EQ(t->user_for("tok-b"), "bob");
  EXPECT_FALSE(t->user_for("tok-"));
  EXPECT_FALSE(t->user_for("tok-ab"));
  EXPECT_FALSE(t->user_for(""));
  const auto bad = TokenTable::parse("alice tok-a\nbob\n", "tokens");
  EXPECT_EQ(bad.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(bad.status().message().find("tokens:2"), std::string::npos) << bad.status().message();
  const auto dup = TokenTable::parse("alice same\nbob same\n", "tokens");
  EXPECT_EQ(dup.status().code(), StatusCode::kInvalidInput);
}

TEST(TokenTable, BearerTokenNeedsTheScheme) {
  EXPECT_EQ(bearer_token("Bearer abc"), "abc");
  EXPECT_FALSE(bearer_token("abc"));
  EXPECT_FALSE(bearer_token("Bearer "));
  EXPECT_FALSE(bearer_token("Basic abc"));
}

}  // namespace
}  // namespace pdrmesh::server
