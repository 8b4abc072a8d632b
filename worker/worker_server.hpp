// SPDX-License-Identifier: AGPL-3.0-or-later
// The pdrmesh-worker daemon as a library: a gRPC server of WorkerService
// (RefineLeaf on `threads` leaves at once, GetWorkerInfo), the standard health
// service and reflection, and, with a coordinator address, registration and
// heartbeats towards its WorkerRegistry. main.cpp only parses flags and waits
// for SIGTERM; tests start Workers in their own process.
//
// Stateless: a worker holds nothing a coordinator needs back, only a small LRU
// cache of decoded sizing fields by digest (see the proto).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "leaf_rpc.hpp"
#include "pdrmesh/status.hpp"

namespace pdrmesh::worker {

struct WorkerOptions {
  /// host:port; port 0 picks a free one (see Worker::port()).
  std::string listen_address = "127.0.0.1:0";
  /// What the coordinator dials; empty: the listen host with the bound port.
  std::string advertise_address;
  /// The coordinator's WorkerRegistry (its --worker-listen); empty: serve only.
  std::string coordinator_address;
  /// Leaves refined at once; 0: the hardware's concurrency.
  unsigned threads = 0;
  /// The cluster's shared secret; required.
  std::string cluster_token;
  /// Mutual TLS for the server and towards the coordinator; none: plaintext.
  TlsFiles tls;
  /// Plaintext on a non-loopback listen or coordinator address (refused otherwise).
  bool allow_insecure_remote = false;
  /// Bounds on one task (RESOURCE_EXHAUSTED beyond).
  std::uint64_t max_input_bytes = kDefaultMaxInputBytes;
  std::uint64_t max_sizing_bytes = kDefaultMaxSizingBytes;
  /// Decoded sizing fields kept (least recently used goes first).
  std::size_t sizing_cache_entries = 4;
  /// Wait before registering again after a failed attempt.
  std::chrono::milliseconds register_retry{1000};
  /// TEST ONLY: sleep this long before refining each leaf, so that a test can
  /// catch a worker in the middle of a job (main.cpp reads it from the
  /// environment variable PDRMESH_WORKER_TEST_LEAF_DELAY_MS; never set it in production).
  std::chrono::milliseconds test_leaf_delay{0};
  /// TEST ONLY: every leaf's kernel throws std::bad_alloc, as when the machine
  /// runs out of memory (main.cpp: PDRMESH_WORKER_TEST_LEAF_BAD_ALLOC=1).
  bool test_leaf_bad_alloc = false;
};

struct WorkerStats {
  std::uint64_t leaves_done = 0;    ///< results sent
  std::uint64_t leaves_failed = 0;  ///< kernel errors sent
  std::uint64_t sizing_misses = 0;  ///< FAILED_PRECONDITION "sizing unknown" answers
  std::uint64_t sizing_received = 0;
  unsigned busy = 0;                ///< leaves running now
  bool registered = false;          ///< holds a registration with the coordinator
};

class Worker {
 public:
  /// Checks the options, binds, starts serving (health SERVING) and, with a
  /// coordinator address, the registration thread.
  static Result<std::unique_ptr<Worker>> Start(WorkerOptions options);
  ~Worker();  ///< Drain(0) when not drained yet
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;

  int port() const;
  /// host:port with the bound port.
  std::string listen_address() const;
  /// What the worker registers as.
  std::string advertise_address() const;
  unsigned threads() const;
  WorkerStats stats() const;

  /// Graceful stop: health NOT_SERVING, new leaves get UNAVAILABLE, LeaveWorker
  /// to the coordinator, running leaves finish for at most `timeout_s`, then the
  /// server shuts down. True when no leaf was cut off. Idempotent.
  bool Drain(double timeout_s);

  struct State;  // shared with the gRPC handlers and the registration thread

 private:
  Worker() = default;
  std::shared_ptr<State> state_;
};

}  // namespace pdrmesh::worker
