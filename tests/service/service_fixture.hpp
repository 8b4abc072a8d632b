// SPDX-License-Identifier: AGPL-3.0-or-later
// The service tests' fixture: an in-process coordinator on 127.0.0.1 with a
// temporary data directory and two users (alice, bob), and real clients.
#pragma once

#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "coordinator.hpp"
#include "service_client.hpp"
#include "temp_dir.hpp"

namespace pdrmesh::server {

inline const std::filesystem::path kSphere = std::filesystem::path(PDRMESH_CORPUS_DIR) / "sphere966.stl";

class Service : public ::testing::Test {
 protected:
  void SetUp() override {
    spdlog::set_level(spdlog::level::off);
    std::ofstream(dir_.path() / "tokens") << "# user token\nalice tok-alice\nbob tok-bob\n";
  }

  Options options(int threads, UserLimits limits = {}) const {
    Options o;
    o.data_dir = dir_.path() / "data";
    o.tokens_file = dir_.path() / "tokens";
    o.runner_threads = threads;
    o.limits = limits;
    o.default_time_limit_s = 60;
    o.leaf_threads = 2;
    return o;
  }

  void start(int threads, UserLimits limits = {}, std::unique_ptr<MeshEngine> engine = nullptr) {
    start(options(threads, limits), std::move(engine));
  }
  void start(const Options& o, std::unique_ptr<MeshEngine> engine = nullptr) {
    auto c = Coordinator::BuildAndStart(o, std::move(engine));
    ASSERT_TRUE(c.ok()) << c.status().to_string();
    coordinator_ = std::move(c).value();
    ASSERT_GT(coordinator_->port(), 0);
  }

  std::unique_ptr<cli::ServiceClient> client(const std::string& token) const {
    cli::ClientConfig config;
    config.server = "127.0.0.1:" + std::to_string(coordinator_->port());
    config.token = token;
    config.timeout_s = 30;
    config.watch_timeout_s = 60;
    std::unique_ptr<cli::ServiceClient> c;
    EXPECT_TRUE(cli::ServiceClient::connect(config, c).ok());
    return c;
  }

  /// Watches to the end; returns the final job and the events' states in order.
  static v1::Job watch(cli::ServiceClient& c, const std::string& id, std::vector<v1::JobEvent>* events = nullptr) {
    v1::Job last;
    const grpc::Status s = c.watch(
        id, [&](const v1::JobEvent& e) { if (events) events->push_back(e); }, last);
    EXPECT_TRUE(s.ok()) << s.error_message();
    return last;
  }

  std::filesystem::path write_open_tetrahedron() const {
    // A tetrahedron with its fourth face missing: three open edges.
    const auto path = dir_.path() / "open.stl";
    std::ofstream(path) << "solid open\n"
                           "facet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 0 1 0\nvertex 1 0 0\nendloop\nendfacet\n"
                           "facet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 0 1\nendloop\nendfacet\n"
                           "facet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 0 0 1\nvertex 0 1 0\nendloop\nendfacet\n"
                           "endsolid open\n";
    return path;
  }

  test::TempDir dir_;
  std::unique_ptr<Coordinator> coordinator_;
};

}  // namespace pdrmesh::server
