// SPDX-License-Identifier: AGPL-3.0-or-later
// The coordinator's side of the workers: WorkerPool (who can refine leaves, and
// how many at once) and RemoteLeafDispatch, the LeafDispatch that sends each
// leaf task to a worker daemon over WorkerService.RefineLeaf.
//
// Pool. Workers come from the static --workers list (probed with
// GetWorkerInfo every heartbeat interval) and from WorkerRegistry calls
// (RegisterWorker, then Heartbeat every interval, LeaveWorker when they
// drain). A worker's slots are its threads. A worker is available while it
// was heard from within `missed_heartbeats` intervals, has not left, runs our
// version, and is not taken out: a failed call (unavailable, deadline, cut
// stream, bad result) takes it out for `failure_backoff_s`. A registered
// worker that misses its heartbeats is forgotten (its next heartbeat is
// answered "known: false" and it registers again). Workers may come and go
// while jobs run.
//
// Slots are handed out fairly: round-robin over the users that have leaves
// waiting, FIFO within a user; a leaf that failed on a worker prefers a worker
// it has not tried (it goes back to a tried one only when no untried worker is
// available at all). The chosen worker is the one with the most free slots.
//
// Leaves. RemoteLeafDispatch::kernel_for(job) gives a kernel whose run()
// waits for a slot (checking job.keep_going: kCancelled once it is false),
// sends the task with a deadline of leaf_deadline_s, and accepts the first
// complete result that decodes and passes validate_leaf_output. On
// UNAVAILABLE, DEADLINE_EXCEEDED, a cut stream or a bad result the worker is
// taken out and the leaf goes to another worker, at most max_attempts times;
// then kIoError naming the job, the leaf and each worker tried with its error.
// A failed attempt's call is cancelled before the leaf goes elsewhere, so a
// late answer is never read: each run() returns exactly one result. A kernel
// error reported by the worker (the same on every worker) and INVALID_ARGUMENT
// or RESOURCE_EXHAUSTED (the task itself is wrong or too big) fail the leaf at
// once. The sizing field travels as its digest; a worker that lacks it answers
// FAILED_PRECONDITION "sizing unknown" and the same slot sends it again with
// the field (not counted as an attempt). A call in flight is cancelled within
// ~0.1 s of its job's keep_going turning false.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "leaf_dispatch.hpp"
#include "leaf_rpc.hpp"
#include "pdrmesh/status.hpp"

namespace grpc {
class Service;
}  // namespace grpc

namespace pdrmesh::server {

struct WorkerPoolOptions {
  std::vector<std::string> static_workers;  ///< host:port of each --workers entry
  std::string cluster_token;                ///< required
  worker::TlsFiles tls;                     ///< mutual TLS towards the workers; none: plaintext
  double leaf_deadline_s = 300;             ///< one RefineLeaf call
  double heartbeat_interval_s = 1;          ///< told to registering workers; static probe period
  int missed_heartbeats = 3;                ///< silent this many intervals: out (registered: forgotten)
  double failure_backoff_s = 10;            ///< a worker whose call failed is out this long
  int max_attempts = 4;                     ///< workers tried per leaf
};

struct WorkerSnapshot {
  std::string id;       ///< registration id; empty for a static worker never registered
  std::string address;
  bool is_static = false;
  bool available = false;
  unsigned threads = 0, busy = 0;
  std::uint64_t leaves_done = 0, failures = 0;
  std::string last_error;
};

class WorkerPool {
 public:
  /// Probes the static workers once (so that total_slots() counts those that
  /// answer) and starts the monitor threads. invalid_input without a token.
  static Result<std::shared_ptr<WorkerPool>> create(WorkerPoolOptions options);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;
  /// Stops the monitors, cancels calls in flight, fails waiting leaves with
  /// kCancelled. Idempotent.
  void stop();

  // ---- WorkerRegistry (the gRPC service calls these)
  struct Registration {
    std::string worker_id;
    unsigned heartbeat_interval_ms = 0;
  };
  /// invalid_input without an address or threads; unsupported on a version
  /// mismatch. Replaces an earlier registration of the same address.
  Result<Registration> register_worker(const std::string& address, unsigned threads, std::string_view version);
  /// False when the id is unknown (forgotten): the worker registers again.
  bool heartbeat(std::string_view worker_id, unsigned busy);
  /// No new leaves go to it; leaves it runs finish.
  void leave(std::string_view worker_id);

  /// Slots (threads) of the available workers.
  std::size_t total_slots() const;
  std::vector<WorkerSnapshot> workers() const;
  /// Leaves waiting for a slot now.
  std::size_t waiting() const;
  const WorkerPoolOptions& options() const { return options_; }

  struct Entry;  // one worker (internal)
  /// One slot on one worker, held while a leaf runs there.
  class Lease {
   public:
    Lease() = default;
    Lease(Lease&& other) noexcept;
    Lease& operator=(Lease&& other) noexcept;
    ~Lease();  ///< releases as a success
    const std::string& address() const;
    Entry& entry() const { return *entry_; }
    /// Gives the slot back; `error` non-empty: the worker failed and is taken out.
    void release(std::string_view error = {});

   private:
    friend class WorkerPool;
    WorkerPool* pool_ = nullptr;
    std::shared_ptr<Entry> entry_;
  };
  /// Waits for a slot for one of `user`'s leaves (fair between users, see the
  /// top of this file), preferring workers not in `tried`. kCancelled when
  /// keep_going() turns false or the pool stops.
  Result<Lease> acquire(const std::string& user, const std::set<std::string>& tried,
                        const std::function<bool()>& keep_going);

  /// While alive, the call is cancelled once keep_going() is false or the pool stops.
  class CallGuard {
   public:
    CallGuard(WorkerPool& pool, void* client_context, const std::function<bool()>* keep_going);
    ~CallGuard();
    CallGuard(const CallGuard&) = delete;
    CallGuard& operator=(const CallGuard&) = delete;

   private:
    WorkerPool& pool_;
    std::uint64_t id_;
  };

  struct State;  // internal

 private:
  explicit WorkerPool(WorkerPoolOptions options);
  WorkerPoolOptions options_;
  std::shared_ptr<State> state_;
};

/// The gRPC WorkerRegistry over a pool (cluster token checked on every call).
std::unique_ptr<grpc::Service> make_worker_registry_service(std::shared_ptr<WorkerPool> pool);

struct DispatchStats {
  std::uint64_t attempts = 0;        ///< RefineLeaf calls (sizing resends not counted)
  std::uint64_t accepted = 0;        ///< results returned to the engine
  std::uint64_t retried = 0;         ///< attempts that failed and moved the leaf on
  std::uint64_t sizing_resends = 0;  ///< "sizing unknown" answers
  std::uint64_t sizing_encodes = 0;  ///< sizing fields encoded (once per job's field)
};

class RemoteLeafDispatch final : public LeafDispatch {
 public:
  explicit RemoteLeafDispatch(std::shared_ptr<WorkerPool> pool);
  /// invalid_input for an unknown kernel name (checked here, where the leaf's
  /// needs_manifold_hull() is answered too).
  Result<std::unique_ptr<LeafKernel>> kernel_for(const LeafJob& job) override;
  /// Slots of the available workers (at least 1); the process running the
  /// engine must allow that many oneTBB threads (tbb::global_control).
  std::size_t concurrency() const override;
  DispatchStats stats() const;
  WorkerPool& pool() const { return *pool_; }

  struct Counters {
    std::atomic<std::uint64_t> attempts{0}, accepted{0}, retried{0}, sizing_resends{0}, sizing_encodes{0};
  };
  struct SizingBlob;  ///< a job's encoded sizing field, shared by its kernels

 private:
  std::shared_ptr<WorkerPool> pool_;
  std::shared_ptr<Counters> counters_;
  std::mutex blobs_mu_;
  /// By job id: the kernels of one job (the refiner's and the optimizer's)
  /// share one encoding of its field; an entry lives while a kernel holds it.
  std::map<std::string, std::weak_ptr<SizingBlob>> blobs_;
};

}  // namespace pdrmesh::server
