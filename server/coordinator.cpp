// SPDX-License-Identifier: AGPL-3.0-or-later
// Coordinator: wires the tokens, the JobManager and the gRPC server together.
#include "coordinator.hpp"

#include <fmt/format.h>
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <oneapi/tbb/global_control.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <iterator>
#include <thread>

#include "job_service.hpp"
#include "leaf_dispatch.hpp"
#include "pdr_engine.hpp"
#include "worker_pool.hpp"

namespace pdrmesh::server {
namespace {

Result<std::string> read_pem(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return not_found(fmt::format("{}: cannot open", path.string()));
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

}  // namespace

bool is_loopback_address(std::string_view address) { return worker::is_loopback_address(address); }

Status Coordinator::start_workers(const Options& options) {
  if (options.worker_listen_address.empty() && options.workers.empty()) return {};
  if (options.cluster_token_file.empty()) {
    return invalid_input("--cluster-token-file is required with --worker-listen or --workers");
  }
  WorkerPoolOptions po;
  po.static_workers = options.workers;
  PDR_ASSIGN_OR_RETURN(po.cluster_token, worker::read_cluster_token(options.cluster_token_file));
  po.tls = {options.worker_tls_cert_file, options.worker_tls_key_file, options.worker_tls_ca_file,
            options.worker_tls_server_name};
  PDR_TRY(po.tls.check("between the coordinator and its workers"));
  if (!(options.leaf_deadline_s > 0)) return invalid_input("the leaf deadline must be > 0 seconds");
  po.leaf_deadline_s = options.leaf_deadline_s;
  if (!po.tls.enabled() && !options.allow_insecure_remote) {
    std::vector<std::string> addresses = options.workers;
    if (!options.worker_listen_address.empty()) addresses.push_back(options.worker_listen_address);
    for (const std::string& a : addresses) {
      if (!is_loopback_address(a)) {
        return invalid_input(fmt::format("refusing to send the cluster token in clear text to or from {}: give "
                                         "--worker-tls-cert/--worker-tls-key/--worker-tls-ca, or --allow-insecure",
                                         a));
      }
    }
  }
  const bool mtls = po.tls.enabled();
  PDR_ASSIGN_OR_RETURN(pool_, WorkerPool::create(std::move(po)));
  remote_dispatch_ = std::make_shared<RemoteLeafDispatch>(pool_);
  // oneTBB starts no more threads than the hardware has unless allowed: one per worker slot.
  parallelism_ = std::make_shared<tbb::global_control>(tbb::global_control::max_allowed_parallelism, 1024);
  if (options.worker_listen_address.empty()) return {};
  PDR_ASSIGN_OR_RETURN(const auto creds, worker::server_credentials(
                                             {options.worker_tls_cert_file, options.worker_tls_key_file,
                                              options.worker_tls_ca_file, {}}));
  registry_service_ = make_worker_registry_service(pool_);
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options.worker_listen_address, creds, &worker_port_);
  builder.RegisterService(registry_service_.get());
  worker_server_ = builder.BuildAndStart();
  if (!worker_server_ || worker_port_ == 0) {
    pool_->stop();
    return io_error(fmt::format("cannot listen on {} for workers (address in use or invalid?)",
                                options.worker_listen_address));
  }
  spdlog::info("pdrmesh-coordinator: workers register on {} (port {}, {})", options.worker_listen_address,
               worker_port_, mtls ? "mutual TLS" : "plaintext");
  return {};
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
  grpc::EnableDefaultHealthCheckService(true);  // on both ports, with reflection
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  PDR_TRY(c->start_workers(options));

  ManagerConfig config;
  config.data_dir = options.data_dir;
  config.limits = options.limits;
  config.runner_threads = options.runner_threads;
  config.memory_budget_bytes = options.memory_budget_bytes;
  config.default_time_limit_s = options.default_time_limit_s;
  config.max_time_limit_s = options.max_time_limit_s;
  config.result_ttl_s = options.result_ttl_hours * 3600.0;
  config.sweep_interval_s = options.sweep_interval_s;
  const std::size_t threads =
      options.leaf_threads > 0 ? options.leaf_threads : std::max(1U, std::thread::hardware_concurrency());
  if (!engine && c->remote_dispatch_) {
    // No worker known at all (none listed, none registered yet): the leaves
    // run here rather than wait for one.
    std::shared_ptr<WorkerPool> pool = c->pool_;
    engine = std::make_unique<PdrEngine>(std::make_shared<FallbackLeafDispatch>(
                                             c->remote_dispatch_, std::make_shared<LocalLeafDispatch>(threads),
                                             [pool] { return !pool->workers().empty(); }),
                                         options.test_checkpoint_delay);
    spdlog::info("leaves run on worker daemons (in this process on {} thread(s) while no worker is known)", threads);
  } else if (!engine) {
    engine = std::make_unique<PdrEngine>(std::make_shared<LocalLeafDispatch>(threads), options.test_checkpoint_delay);
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
  c->service_ = std::make_unique<JobServiceImpl>(*c->manager_, c->tokens_, c->stopping_, options.max_watch_s,
                                                 stream_limit_for_threads(options.max_server_threads));
  grpc::ServerBuilder builder;
  grpc::ResourceQuota quota("pdrmesh-client-port");
  quota.SetMaxThreads(options.max_server_threads);
  builder.SetResourceQuota(quota);
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
  if (manager_) manager_->stop();  // running jobs stop: the pool cancels their leaf calls
  if (pool_) pool_->stop();
  if (worker_server_) {
    worker_server_->Shutdown(std::chrono::system_clock::now() + std::chrono::milliseconds(500));
  }
  spdlog::info("pdrmesh-coordinator stopped");
}

}  // namespace pdrmesh::server
