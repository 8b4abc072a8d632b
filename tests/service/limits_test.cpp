// SPDX-License-Identifier: AGPL-3.0-or-later
// Protections of the client port: an upload that never ends or trickles is
// cut, a user's open streams are capped, a surface whose header declares
// billions of triangles is refused at once (each time another user goes on);
// with TLS, plaintext and untrusted clients get nothing.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <iterator>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "call_limits.hpp"
#include "certificates.hpp"
#include "coordinator.hpp"
#include "service_client.hpp"
#include "service_fixture.hpp"

namespace pdrmesh::server {
namespace {

using namespace std::chrono_literals;

class Limits : public Service {
 protected:
  std::unique_ptr<v1::JobService::Stub> stub() const {
    return v1::JobService::NewStub(grpc::CreateChannel("127.0.0.1:" + std::to_string(coordinator_->port()),
                                                       grpc::InsecureChannelCredentials()));
  }
  /// Bob's queued job and a watch of it, to show he is still served.
  void expect_bob_served() const {
    auto bob = client("tok-bob");
    v1::Job job;
    const grpc::Status submitted = bob->submit(kSphere, v1::MeshOptions{}, job);
    ASSERT_TRUE(submitted.ok()) << submitted.error_message();
    v1::Job got;
    ASSERT_TRUE(bob->get(job.id(), got).ok());
    EXPECT_EQ(got.state(), v1::JOB_STATE_QUEUED);
  }
};

TEST_F(Limits, AnUploadThatTricklesIsCutAtTheUploadTimeLimit) {
  UserLimits limits;
  limits.max_upload_s = 1;
  start(0, limits);
  auto s = stub();
  grpc::ClientContext context;
  context.AddMetadata("authorization", "Bearer tok-alice");
  context.set_deadline(std::chrono::system_clock::now() + 30s);  // far beyond the server's limit
  v1::Job response;
  auto writer = s->SubmitJob(&context, &response);
  v1::SubmitRequest header;
  header.mutable_header()->set_file_name("slow.stl");
  header.mutable_header()->set_total_bytes(1000);
  ASSERT_TRUE(writer->Write(header));
  const auto t0 = std::chrono::steady_clock::now();
  v1::SubmitRequest chunk;
  chunk.set_chunk("s");
  // One byte every 100 ms: 1000 bytes would take 100 s.
  while (writer->Write(chunk) && std::chrono::steady_clock::now() - t0 < 20s) std::this_thread::sleep_for(100ms);
  const grpc::Status status = writer->Finish();
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << "the server cut it, not our 30 s deadline";
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 15s);
  v1::ListJobsResponse list;
  ASSERT_TRUE(client("tok-alice")->list(list).ok());
  EXPECT_EQ(list.jobs_size(), 0);
  expect_bob_served();
}

TEST_F(Limits, AUsersOpenStreamsAreCappedAndOthersGoOn) {
  UserLimits limits;
  limits.max_open_streams = 2;
  start(0, limits);  // no runner: jobs stay queued, so their watches stay open
  auto alice = client("tok-alice");
  v1::Job job;
  ASSERT_TRUE(alice->submit(kSphere, v1::MeshOptions{}, job).ok());
  auto s = stub();
  std::vector<std::unique_ptr<grpc::ClientContext>> contexts;
  std::vector<std::unique_ptr<grpc::ClientReader<v1::JobEvent>>> watches;
  v1::WatchJobRequest request;
  request.set_job_id(job.id());
  for (int i = 0; i < 2; ++i) {
    contexts.push_back(std::make_unique<grpc::ClientContext>());
    contexts.back()->AddMetadata("authorization", "Bearer tok-alice");
    watches.push_back(s->WatchJob(contexts.back().get(), request));
    v1::JobEvent event;
    ASSERT_TRUE(watches.back()->Read(&event));  // the stream is open on the server
  }
  grpc::ClientContext third;
  third.AddMetadata("authorization", "Bearer tok-alice");
  auto refused = s->WatchJob(&third, request);
  v1::JobEvent event;
  EXPECT_FALSE(refused->Read(&event));
  const grpc::Status status = refused->Finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(status.error_message().find("--max-open-streams"), std::string::npos) << status.error_message();
  expect_bob_served();
  // Closing a stream frees its slot once the server sees it closed (its watch
  // loop wakes at least every 500 ms).
  contexts[0]->TryCancel();
  (void)watches[0]->Finish();
  bool reopened_ok = false;
  for (int attempt = 0; attempt < 50 && !reopened_ok; ++attempt) {
    grpc::ClientContext again;
    again.AddMetadata("authorization", "Bearer tok-alice");
    auto reopened = s->WatchJob(&again, request);
    reopened_ok = reopened->Read(&event);
    again.TryCancel();
    (void)reopened->Finish();
    if (!reopened_ok) std::this_thread::sleep_for(100ms);
  }
  EXPECT_TRUE(reopened_ok);
  for (std::size_t i = 1; i < contexts.size(); ++i) {
    contexts[i]->TryCancel();
    (void)watches[i]->Finish();
  }
}

/// Threads of this process (the coordinator runs in it).
std::size_t thread_count() {
  return static_cast<std::size_t>(std::distance(std::filesystem::directory_iterator("/proc/self/task"),
                                                std::filesystem::directory_iterator{}));
}

TEST_F(Limits, TwoHundredStreamsStayWithinTheThreadCapAndJobsGoOn) {
  // 20 users open 10 uploads each (within their own --max-open-streams) and
  // hold them: the server's threads stop at --max-server-threads, the streams
  // beyond three quarters of it get RESOURCE_EXHAUSTED at once (bob's second
  // upload too), and short calls still find a thread: bob follows his first
  // job to the end meanwhile.
  constexpr int kUsers = 20, kPerUser = 10, kThreads = 48;
  const int max_streams = stream_limit_for_threads(kThreads);
  ASSERT_LT(max_streams, kThreads);
  {
    std::ofstream tokens(dir_.path() / "tokens");
    tokens << "bob tok-bob\n";
    for (int u = 0; u < kUsers; ++u) tokens << "user" << u << " tok-" << u << "\n";
  }
  Options o = options(1);
  o.max_server_threads = kThreads;
  start(o);
  auto bob = client("tok-bob");
  v1::MeshOptions slower;  // some 100,000 tets: a few seconds, so it runs through the flood
  slower.set_size(0.8);
  v1::Job job;
  ASSERT_TRUE(bob->submit(kSphere, slower, job).ok());
  const std::size_t before = thread_count();
  const auto flood_ms =
      std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
          .count();

  auto s = stub();
  struct Upload {
    std::unique_ptr<grpc::ClientContext> context = std::make_unique<grpc::ClientContext>();
    v1::Job response;
    std::unique_ptr<grpc::ClientWriter<v1::SubmitRequest>> writer;
  };
  std::vector<Upload> uploads(kUsers * kPerUser);
  v1::SubmitRequest header;
  header.mutable_header()->set_file_name("held.stl");
  header.mutable_header()->set_total_bytes(1000);
  for (std::size_t i = 0; i < uploads.size(); ++i) {
    Upload& u = uploads[i];
    u.context->AddMetadata("authorization", "Bearer tok-" + std::to_string(i % kUsers));
    u.writer = s->SubmitJob(u.context.get(), &u.response);
    (void)u.writer->Write(header);
  }
  // Let the server take or refuse each: a refused upload fails a write once
  // its status has come back. On a loaded machine that takes more than the
  // second it takes here, and counting before it came back saw a stream not
  // yet refused as held.
  const int expect_refused = kUsers * kPerUser - max_streams;
  std::vector<char> known_refused(uploads.size(), 0);
  v1::SubmitRequest probe;
  probe.set_chunk("s");
  int refused_seen = 0;
  for (int round = 0; round < 300 && refused_seen < expect_refused; ++round) {
    std::this_thread::sleep_for(100ms);
    for (std::size_t i = 0; i < uploads.size(); ++i)
      if (!known_refused[i] && !uploads[i].writer->Write(probe)) {
        known_refused[i] = 1;
        ++refused_seen;
      }
  }
  const std::size_t during = thread_count();
  // The cap, plus gRPC's own pollers and timers and the client side's threads.
  EXPECT_LE(during, before + kThreads + 16) << "before " << before;

  v1::Job refused_job;
  const grpc::Status full = bob->submit(kSphere, v1::MeshOptions{}, refused_job);
  EXPECT_EQ(full.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << "an upload is a stream too";
  v1::Job got;
  for (int i = 0; i < 600 && got.state() != v1::JOB_STATE_SUCCEEDED && got.state() != v1::JOB_STATE_FAILED; ++i) {
    ASSERT_TRUE(bob->get(job.id(), got).ok());
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_EQ(got.state(), v1::JOB_STATE_SUCCEEDED) << got.error();
  EXPECT_GT(got.finished_unix_ms(), flood_ms) << "the job should have run on during the flood";

  // A refused upload was closed by the server: a further write fails and
  // Finish gives its status. A held one is still open: cancel it.
  v1::SubmitRequest chunk;
  chunk.set_chunk("s");
  int refused = 0, held = 0, refused_by_us = 0;
  for (Upload& u : uploads) {
    if (u.writer->Write(chunk)) {
      ++held;
      u.context->TryCancel();
      (void)u.writer->Finish();
      continue;
    }
    const grpc::Status status = u.writer->Finish();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
    // Ours (the stream cap) or gRPC's own when a burst finds no thread free.
    const bool ours = status.error_message().find("--max-server-threads") != std::string::npos;
    EXPECT_TRUE(ours || status.error_message() == "Server Threadpool Exhausted") << status.error_message();
    ++refused;
    refused_by_us += ours ? 1 : 0;
  }
  std::printf("threads %zu -> %zu; %d uploads held, %d refused (%d by the stream cap)\n", before, during, held,
              refused, refused_by_us);
  EXPECT_LE(held, max_streams);
  EXPECT_GE(refused, kUsers * kPerUser - max_streams);
  EXPECT_TRUE(bob->fetch(job.id(), dir_.path() / "bob.vtu").ok());
}

TEST_F(Limits, ASurfaceDeclaringBillionsOfTrianglesIsRefusedAtOnce) {
  start(0);
  // A binary STL header claiming 4,000,000,000 triangles, with one.
  const auto path = dir_.path() / "huge.stl";
  {
    std::ofstream out(path, std::ios::binary);
    out << std::string(80, ' ');
    const std::uint32_t count = 4000000000U;
    out.write(reinterpret_cast<const char*>(&count), 4);
    const float tri[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
    out.write(reinterpret_cast<const char*>(tri), sizeof tri);
    out << std::string(2, '\0');
  }
  auto alice = client("tok-alice");
  v1::Job job;
  const auto t0 = std::chrono::steady_clock::now();
  const grpc::Status status = alice->submit(path, v1::MeshOptions{}, job);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(status.error_message().find("huge.stl"), std::string::npos) << status.error_message();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 5s);
  expect_bob_served();
}

TEST_F(Limits, TlsOnTheClientPortServesOnlyTlsClients) {
  if (!make_certificates(dir_.path(), "server") || !make_certificates(dir_.path(), "other")) {
    GTEST_SKIP() << "no openssl";
  }
  Options o = options(0);
  o.tls_cert_file = dir_.path() / "server.pem";
  o.tls_key_file = dir_.path() / "server.key";
  auto c = Coordinator::BuildAndStart(o);
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  const auto connect = [&](const std::string& ca) {
    cli::ClientConfig config;
    config.server = "127.0.0.1:" + std::to_string((*c)->port());
    config.token = "tok-alice";
    config.tls_ca_file = ca.empty() ? "" : (dir_.path() / ca).string();
    config.timeout_s = 5;
    std::unique_ptr<cli::ServiceClient> client;
    EXPECT_TRUE(cli::ServiceClient::connect(config, client).ok());
    return client;
  };
  v1::ListJobsResponse list;
  EXPECT_TRUE(connect("server-ca.pem")->list(list).ok());
  EXPECT_EQ(connect("")->list(list).error_code(), grpc::StatusCode::UNAVAILABLE);  // plaintext
  EXPECT_EQ(connect("other-ca.pem")->list(list).error_code(), grpc::StatusCode::UNAVAILABLE);  // untrusted
}

}  // namespace
}  // namespace pdrmesh::server
