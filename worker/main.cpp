// SPDX-License-Identifier: AGPL-3.0-or-later
// pdrmesh-worker: the leaf-refinement daemon (flags: /work/briefs/flags.md and
// worker/README.md). Prints "listening on HOST:PORT" on stdout once it serves;
// SIGTERM or SIGINT drains it (see Worker::Drain) and it exits 0.
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <thread>

#include "worker_server.hpp"

int main(int argc, char** argv) {
  CLI::App app{"pdrmesh-worker: refines octree leaves for a pdrmesh coordinator"};
  app.set_version_flag("--version", "pdrmesh-worker " PDRMESH_VERSION);
  pdrmesh::worker::WorkerOptions o;
  std::string token_file, log_level = "info";
  double drain_timeout_s = 30;
  app.add_option("--listen", o.listen_address, "host:port to serve WorkerService on (port 0: any free port)")
      ->capture_default_str();
  app.add_option("--advertise", o.advertise_address,
                 "host:port the coordinator dials (default: the listen host with the bound port)");
  app.add_option("--coordinator", o.coordinator_address,
                 "the coordinator's worker port (its --worker-listen): register there and send heartbeats; "
                 "without it the worker only serves (for a coordinator that lists it in --workers)");
  app.add_option("--threads", o.threads, "leaves refined at once (default: hardware concurrency)")
      ->check(CLI::PositiveNumber);
  app.add_option("--cluster-token-file", token_file,
                 "file whose first line is the cluster's shared secret; every call must carry it")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--tls-cert", o.tls.cert, "PEM certificate chain (mutual TLS, with --tls-key and --tls-ca)")
      ->check(CLI::ExistingFile);
  app.add_option("--tls-key", o.tls.key, "PEM private key")->check(CLI::ExistingFile);
  app.add_option("--tls-ca", o.tls.ca, "PEM CA that must sign the certificates of callers and of the coordinator")
      ->check(CLI::ExistingFile);
  app.add_flag("--allow-insecure", o.allow_insecure_remote,
               "allow plaintext on a non-loopback address (the cluster token travels in clear)");
  app.add_option("--drain-timeout", drain_timeout_s,
                 "on SIGTERM: stop taking leaves and finish running ones for at most this many seconds")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, off")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  spdlog::set_default_logger(spdlog::stderr_color_mt("pdrmesh-worker"));  // stdout: the address only
  spdlog::set_level(spdlog::level::from_str(log_level));

  auto token = pdrmesh::worker::read_cluster_token(token_file);
  if (!token.ok()) {
    fmt::print(stderr, "pdrmesh-worker: error: {}\n", token.status().to_string());
    return 1;
  }
  o.cluster_token = std::move(*token);
  // TEST ONLY (see WorkerOptions::test_leaf_delay): lets the fault tests catch a worker mid-job.
  if (const char* delay = std::getenv("PDRMESH_WORKER_TEST_LEAF_DELAY_MS")) {
    o.test_leaf_delay = std::chrono::milliseconds(std::atoi(delay));
    spdlog::warn("test mode: every leaf waits {} ms first (PDRMESH_WORKER_TEST_LEAF_DELAY_MS)", o.test_leaf_delay.count());
  }
  if (const char* fail = std::getenv("PDRMESH_WORKER_TEST_LEAF_BAD_ALLOC"); fail != nullptr && fail[0] == '1') {
    o.test_leaf_bad_alloc = true;
    spdlog::warn("test mode: every leaf runs out of memory (PDRMESH_WORKER_TEST_LEAF_BAD_ALLOC)");
  }

  // Signals are taken synchronously by this thread; every later thread inherits the mask.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  auto worker = pdrmesh::worker::Worker::Start(std::move(o));
  if (!worker.ok()) {
    fmt::print(stderr, "pdrmesh-worker: error: {}\n", worker.status().to_string());
    return 1;
  }
  fmt::print("listening on {}\n", (*worker)->listen_address());
  std::fflush(stdout);
  int sig = 0;
  sigwait(&stop_signals, &sig);
  spdlog::info("signal {}: draining (at most {} s)", sig, drain_timeout_s);
  // A kernel cannot be interrupted: past the drain timeout (and a short grace
  // for the server to stop) the process ends anyway.
  auto drained = std::async(std::launch::async, [&] { return (*worker)->Drain(drain_timeout_s); });
  if (drained.wait_for(std::chrono::duration<double>(drain_timeout_s + 2)) != std::future_status::ready) {
    spdlog::warn("leaves still running after the drain timeout: exiting");
    spdlog::shutdown();
    std::_Exit(0);
  }
  return 0;
}
