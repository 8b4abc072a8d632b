// SPDX-License-Identifier: AGPL-3.0-or-later
// The coordinator daemon: Options, BuildAndStart (which checks that the server
// really listens and reports the bound port) and a clean Shutdown. The gRPC
// service is a thin adapter over JobManager (job_manager.hpp).
#pragma once

#include <atomic>
#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "job_manager.hpp"
#include "leaf_dispatch.hpp"
#include "pdrmesh/status.hpp"
#include "tokens.hpp"

namespace grpc {
class Server;
class Service;
}  // namespace grpc

namespace pdrmesh::server {

class WorkerPool;

struct Options {
  /// host:port; port 0 picks a free port (see Coordinator::port()). Loopback by
  /// default: serving elsewhere needs TLS or allow_insecure_remote.
  std::string listen_address = "127.0.0.1:0";
  std::filesystem::path data_dir;     ///< required
  std::filesystem::path tokens_file;  ///< required: lines `user token`
  UserLimits limits;
  /// Jobs run at once at most (each within the memory budget).
  int runner_threads = 4;
  /// Bytes the running jobs' estimated peaks may add up to; 0: 80% of the
  /// memory available at start (ManagerConfig::memory_budget_bytes).
  double memory_budget_bytes = 0;
  double default_time_limit_s = 600;
  double max_time_limit_s = 3600;
  /// PEM files; both or neither. Without them the server speaks plaintext.
  std::filesystem::path tls_cert_file;
  std::filesystem::path tls_key_file;
  /// Allow plaintext (tokens in clear) on a non-loopback address.
  bool allow_insecure_remote = false;
  /// Server-side limit on one WatchJob stream, seconds.
  double max_watch_s = 24 * 3600;
  /// Threads serving client calls at most (grpc::ResourceQuota); calls beyond
  /// them wait for a thread. Streaming calls of all users together are held
  /// to three quarters of them (stream_limit_for_threads), further ones get
  /// RESOURCE_EXHAUSTED, so short calls always find a thread.
  int max_server_threads = 256;
  /// Leaves refined at once in this process when there are no workers
  /// (LocalLeafDispatch); 0: the hardware concurrency.
  std::size_t leaf_threads = 0;
  /// TEST ONLY (PDRMESH_COORDINATOR_TEST_CHECKPOINT_DELAY_MS): a job waits this
  /// long after storing each round checkpoint, so that the restart test can
  /// kill the coordinator while one stands, however fast the job.
  std::chrono::milliseconds test_checkpoint_delay{0};
  /// Finished jobs are deleted this many hours after they finished; 0: kept.
  double result_ttl_hours = 0;
  /// How often the expiry sweep runs, seconds.
  double sweep_interval_s = 60;

  // Workers (worker_pool.hpp). With a worker_listen_address or workers, leaves
  // go to worker daemons (RemoteLeafDispatch); without, they run in-process.
  /// host:port of the WorkerRegistry (workers register there); empty: none.
  std::string worker_listen_address;
  /// Static worker list, host:port each.
  std::vector<std::string> workers;
  /// The cluster's shared secret (first line); required with workers.
  std::filesystem::path cluster_token_file;
  /// PEM files of mutual TLS towards the workers and on the worker port: all or none.
  std::filesystem::path worker_tls_cert_file, worker_tls_key_file, worker_tls_ca_file;
  /// The name every worker certificate carries (checked instead of the address
  /// dialled); empty: each worker's advertised host.
  std::string worker_tls_server_name;
  /// One leaf RPC's deadline before the leaf goes to another worker, seconds.
  double leaf_deadline_s = 300;
};

/// True for 127.0.0.0/8, localhost, [::1] and unix: addresses.
bool is_loopback_address(std::string_view address);

class Coordinator {
 public:
  /// Loads the tokens, opens the data directory (re-queuing interrupted jobs),
  /// starts the runner and the gRPC server (JobService, the gRPC health service
  /// and reflection). `engine` null: PdrEngine with leaves run in this process
  /// on leaf_threads threads.
  static Result<std::unique_ptr<Coordinator>> BuildAndStart(const Options& options,
                                                            std::unique_ptr<MeshEngine> engine = nullptr);
  ~Coordinator();  ///< shuts down
  Coordinator(const Coordinator&) = delete;
  Coordinator& operator=(const Coordinator&) = delete;

  /// The port the server listens on (the chosen one when asked for 0).
  int port() const { return port_; }
  /// The worker port (WorkerRegistry), 0 without --worker-listen.
  int worker_port() const { return worker_port_; }
  /// The RemoteLeafDispatch over the worker pool; null when no workers are
  /// configured (the engine then runs leaves in-process).
  std::shared_ptr<LeafDispatch> remote_dispatch() const { return remote_dispatch_; }
  /// Ends watch streams, stops accepting calls (in-flight calls get
  /// `grace_s`), stops the runner. Idempotent.
  void Shutdown(double grace_s = 2.0);

 private:
  Coordinator() = default;
  std::unique_ptr<JobManager> manager_;
  TokenTable tokens_;
  std::atomic<bool> stopping_{false};
  std::unique_ptr<grpc::Service> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  // Workers.
  Status start_workers(const Options& options);
  std::shared_ptr<WorkerPool> pool_;
  std::shared_ptr<LeafDispatch> remote_dispatch_;
  std::unique_ptr<grpc::Service> registry_service_;
  std::unique_ptr<grpc::Server> worker_server_;
  int worker_port_ = 0;
  std::shared_ptr<void> parallelism_;  ///< a tbb::global_control allowing one thread per worker slot
};

}  // namespace pdrmesh::server
