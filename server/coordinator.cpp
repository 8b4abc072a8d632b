// SPDX-License-Identifier: AGPL-3.0-or-later
// Coordinator: wires the tokens, the JobManager and the gRPC server together.
#include "coordinator.hpp"

#include <fmt/format.h>
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <thread>
#include <fstream>
#include <iterator>

#include "job_service.hpp"
#include "leaf_dispatch.hpp"
#include "pdr_engine.hpp"

namespace pdrmesh::server {
namespace {

Result<std::string> read_pem(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return not_found(fmt::format("{}: cannot open", path.string()));
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

}  // namespace

bool is_loopback_address(std::string_view address) {
  if (address.substr(0, 5) == "unix:") return true;
  const auto colon = address.rfind(':');
  const std::string_view host = address.substr(0, colon);
  return host == "localhost" || host == "[::1]" || host.substr(0, 4) == "127.";
}

Result<std::unique_ptr<Coordinator>> Coordinator::BuildAndStart(const Options& options,
                                                                std::unique_ptr<MeshEngine> engine) {
  if (options.data_dir.empty()) return invalid_input("no data directory given");
  if (options.tokens_file.empty()) return invalid_input("no tokens file given");
  if (options.tls_cert_file.empty() != options.tls_key_file.empty()) {
    return invalid_input("TLS needs both a certificate and a key file");
  }
  const bool tls = !options.tls_cert_file.empty();
  if (!tls && !options.allow_insecure_remote && !is_loopback_address(options.listen_address)) {
    return invalid_input(fmt::format("refusing to send bearer tokens in clear text on {}: give a TLS certificate "
                                     "and key, or allow insecure remote access explicitly",
                                     options.listen_address));
  }
  std::unique_ptr<Coordinator> c(new Coordinator());
  PDR_ASSIGN_OR_RETURN(c->tokens_, TokenTable::load(options.tokens_file));
  if (c->tokens_.size() == 0) return invalid_input(fmt::format("{}: no tokens", options.tokens_file.string()));

  ManagerConfig config;
  config.data_dir = options.data_dir;
  config.limits = options.limits;
  config.runner_threads = options.runner_threads;
  config.default_time_limit_s = options.default_time_limit_s;
  config.max_time_limit_s = options.max_time_limit_s;
  config.result_ttl_s = options.result_ttl_hours * 3600.0;
  config.sweep_interval_s = options.sweep_interval_s;
  if (!engine) {
    const std::size_t threads =
        options.leaf_threads > 0 ? options.leaf_threads : std::max(1U, std::thread::hardware_concurrency());
    engine = std::make_unique<PdrEngine>(std::make_shared<LocalLeafDispatch>(threads));
    spdlog::info("leaves run in this process on {} thread(s)", threads);
  }
  PDR_ASSIGN_OR_RETURN(c->manager_, JobManager::open(std::move(config), std::move(engine)));

  std::shared_ptr<grpc::ServerCredentials> creds = grpc::InsecureServerCredentials();
  if (tls) {
    PDR_ASSIGN_OR_RETURN(const std::string cert, read_pem(options.tls_cert_file));
    PDR_ASSIGN_OR_RETURN(const std::string key, read_pem(options.tls_key_file));
    grpc::SslServerCredentialsOptions ssl;
    ssl.pem_key_cert_pairs.push_back({key, cert});
    creds = grpc::SslServerCredentials(ssl);
  }
  c->service_ = std::make_unique<JobServiceImpl>(*c->manager_, c->tokens_, c->stopping_, options.max_watch_s);
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options.listen_address, creds, &c->port_);
  builder.RegisterService(c->service_.get());
  c->server_ = builder.BuildAndStart();
  if (!c->server_ || c->port_ == 0) {
    c->manager_->stop();
    return io_error(fmt::format("cannot listen on {} (address in use or invalid?)", options.listen_address));
  }
  spdlog::info("pdrmesh-coordinator listening on {} (port {}, {}), data in {}", options.listen_address, c->port_,
               tls ? "TLS" : "plaintext", options.data_dir.string());
  return c;
}

Coordinator::~Coordinator() { Shutdown(); }

void Coordinator::Shutdown(double grace_s) {
  if (stopping_.exchange(true)) return;
  if (manager_) manager_->changes().notify();  // wakes the watch streams, which see stopping_
  if (server_) {
    server_->Shutdown(std::chrono::system_clock::now() +
                      std::chrono::duration_cast<std::chrono::system_clock::duration>(
                          std::chrono::duration<double>(grace_s)));
  }
  if (manager_) manager_->stop();
  spdlog::info("pdrmesh-coordinator stopped");
}

}  // namespace pdrmesh::server
