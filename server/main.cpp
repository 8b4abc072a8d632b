// SPDX-License-Identifier: AGPL-3.0-or-later
// pdrmesh-coordinator: the job server. Prints "listening on HOST:PORT" on
// stdout once it serves; stops cleanly on SIGINT or SIGTERM.
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <malloc.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>

#include "coordinator.hpp"

int main(int argc, char** argv) {
  CLI::App app{"pdrmesh-coordinator: the pdrmesh job server"};
  app.set_version_flag("--version", "pdrmesh-coordinator " PDRMESH_VERSION);
  pdrmesh::server::Options o;
  std::string log_level = "info";
  app.add_option("--listen", o.listen_address, "host:port to serve on (port 0: any free port)")->capture_default_str();
  app.add_option("--data-dir", o.data_dir, "directory of the job database and files")->required();
  app.add_option("--tokens", o.tokens_file, "tokens file: one 'user token' per line")->required()->check(CLI::ExistingFile);
  app.add_option("--max-upload-bytes", o.limits.max_upload_bytes, "per user: largest surface upload")
      ->capture_default_str();
  app.add_option("--max-queued-jobs", o.limits.max_queued_jobs, "per user: queued jobs at once")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-running-jobs", o.limits.max_running_jobs, "per user: running jobs at once")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-open-streams", o.limits.max_open_streams,
                 "per user: uploads, watches and downloads open at once")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-upload-seconds", o.limits.max_upload_s,
                 "one upload may take this long, first byte to last (slow or endless uploads are cut)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-server-threads", o.max_server_threads,
                 "threads serving client calls at most; streams (uploads, watches, downloads) of all users "
                 "together get three quarters of them, further ones RESOURCE_EXHAUSTED")
      ->check(CLI::Range(4, 100000))
      ->capture_default_str();
  app.add_option("--threads", o.runner_threads, "jobs run at once in total (within --memory-budget)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  double memory_budget_gb = 0;
  app.add_option("--memory-budget", memory_budget_gb,
                 "GB the running jobs' estimated peaks may add up to; a job that does not fit waits, one over "
                 "it alone is refused (default: 80% of the memory available at start)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--max-job-tets", o.limits.max_job_tets,
                 "per user: estimated tets of one job at most (0: only the memory budget limits them)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--default-time-limit", o.default_time_limit_s, "seconds a job may mesh unless it asks otherwise")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-time-limit", o.max_time_limit_s, "largest time limit a job may ask for")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--tls-cert", o.tls_cert_file, "PEM certificate chain (with --tls-key: serve TLS)")
      ->check(CLI::ExistingFile);
  app.add_option("--tls-key", o.tls_key_file, "PEM private key")->check(CLI::ExistingFile);
  app.add_flag("--allow-insecure", o.allow_insecure_remote,
               "allow plaintext on a non-loopback address (tokens travel in clear)");
  app.add_option("--leaf-threads", o.leaf_threads,
                 "leaves refined at once in this process when it has no workers (0: hardware concurrency)")
      ->capture_default_str();
  app.add_option("--result-ttl", o.result_ttl_hours,
                 "hours after which a finished job (record and files) is deleted; 0: kept until deleted")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--worker-listen", o.worker_listen_address,
                 "host:port where workers register (WorkerRegistry); unset: no registry");
  app.add_option("--workers", o.workers, "static worker list host:port,... (also works without --worker-listen)")
      ->delimiter(',');
  app.add_option("--cluster-token-file", o.cluster_token_file,
                 "file whose first line is the cluster's shared secret (required with --worker-listen or --workers)")
      ->check(CLI::ExistingFile);
  app.add_option("--worker-tls-cert", o.worker_tls_cert_file,
                 "PEM certificate chain for mutual TLS towards the workers and on the worker port")
      ->check(CLI::ExistingFile);
  app.add_option("--worker-tls-key", o.worker_tls_key_file, "PEM private key for --worker-tls-cert")
      ->check(CLI::ExistingFile);
  app.add_option("--worker-tls-ca", o.worker_tls_ca_file, "PEM CA that signs the workers' certificates")
      ->check(CLI::ExistingFile);
  app.add_option("--worker-tls-server-name", o.worker_tls_server_name,
                 "name every worker certificate carries, checked instead of the address dialled "
                 "(workers dialled by pod IP sharing one certificate)");
  app.add_option("--leaf-deadline", o.leaf_deadline_s,
                 "seconds one leaf RPC may take before the leaf goes to another worker")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, off")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  o.memory_budget_bytes = memory_budget_gb * 1e9;
  // glibc gives each thread that allocates its own malloc arena, up to 8 per
  // core, and rarely returns their memory: the coordinator's RSS grew about
  // 15% over 50 jobs of bench/soak.sh, and stayed flat with two arenas (README,
  // Reliability). The environment's MALLOC_ARENA_MAX still wins.
  if (std::getenv("MALLOC_ARENA_MAX") == nullptr) mallopt(M_ARENA_MAX, 2);
  spdlog::set_default_logger(spdlog::stderr_color_mt("pdrmesh-coordinator"));  // stdout: the address only
  spdlog::set_level(spdlog::level::from_str(log_level));
  // TEST ONLY (see Options::test_checkpoint_delay in coordinator.hpp).
  if (const char* delay = std::getenv("PDRMESH_COORDINATOR_TEST_CHECKPOINT_DELAY_MS")) {
    o.test_checkpoint_delay = std::chrono::milliseconds(std::atoi(delay));
    spdlog::warn("test mode: every job waits {} ms after each checkpoint (PDRMESH_COORDINATOR_TEST_CHECKPOINT_DELAY_MS)",
                 o.test_checkpoint_delay.count());
  }

  // Signals are taken synchronously by this thread; every thread started later
  // (gRPC, runner) inherits the blocked mask.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  auto coordinator = pdrmesh::server::Coordinator::BuildAndStart(o);
  if (!coordinator.ok()) {
    fmt::print(stderr, "pdrmesh-coordinator: error: {}\n", coordinator.status().to_string());
    return 1;
  }
  const auto colon = o.listen_address.rfind(':');
  fmt::print("listening on {}:{}\n", o.listen_address.substr(0, colon), (*coordinator)->port());
  if (!o.worker_listen_address.empty()) {
    const auto wcolon = o.worker_listen_address.rfind(':');
    fmt::print("workers on {}:{}\n", o.worker_listen_address.substr(0, wcolon), (*coordinator)->worker_port());
  }
  std::fflush(stdout);
  int sig = 0;
  sigwait(&stop_signals, &sig);
  spdlog::info("signal {}: shutting down", sig);
  (*coordinator)->Shutdown();
  return 0;
}
