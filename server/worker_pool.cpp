// SPDX-License-Identifier: AGPL-3.0-or-later
// WorkerPool, the WorkerRegistry service and RemoteLeafDispatch (see
// worker_pool.hpp for the behaviour).
#include "worker_pool.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <grpcpp/grpcpp.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <map>
#include <random>
#include <thread>

#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/v1/pdrmesh.grpc.pb.h"

namespace pdrmesh::server {
namespace {

using Clock = std::chrono::steady_clock;
namespace v1 = pdrmesh::v1;

constexpr auto kMonitorTick = std::chrono::milliseconds(100);
constexpr auto kWaitPoll = std::chrono::milliseconds(50);
/// Largest leaf result a coordinator takes, whatever its leaf (see also leaf_output_byte_limit).
constexpr std::uint64_t kMaxOutputBytes = std::uint64_t{1} << 32;

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

std::chrono::system_clock::time_point deadline_in(double s) {
  return std::chrono::system_clock::now() +
         std::chrono::duration_cast<std::chrono::system_clock::duration>(std::chrono::duration<double>(s));
}

std::string_view code_name(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK: return "OK";
    case grpc::StatusCode::CANCELLED: return "CANCELLED";
    case grpc::StatusCode::UNKNOWN: return "UNKNOWN";
    case grpc::StatusCode::INVALID_ARGUMENT: return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED: return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND: return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS: return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED: return "PERMISSION_DENIED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION: return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED: return "ABORTED";
    case grpc::StatusCode::OUT_OF_RANGE: return "OUT_OF_RANGE";
    case grpc::StatusCode::UNIMPLEMENTED: return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL: return "INTERNAL";
    case grpc::StatusCode::UNAVAILABLE: return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS: return "DATA_LOSS";
    case grpc::StatusCode::UNAUTHENTICATED: return "UNAUTHENTICATED";
    default: return "?";
  }
}

std::string describe(const grpc::Status& st) {
  return fmt::format("{}: {}", code_name(st.error_code()), st.error_message());
}

}  // namespace

// ---------------------------------------------------------------- pool state

struct WorkerPool::Entry {
  std::string id;  ///< registration id; empty: static, never registered
  std::string address;
  bool is_static = false;
  std::unique_ptr<v1::WorkerService::Stub> stub;
  // Under State::mu.
  unsigned threads = 0, busy = 0;
  Clock::time_point last_seen{}, out_until{};
  bool seen = false, left = false, version_ok = true, was_available = false;
  std::uint64_t done = 0, failures = 0;
  std::string last_error;
};

struct WorkerPool::State {
  WorkerPoolOptions options;
  std::shared_ptr<grpc::ChannelCredentials> credentials;
  std::string nonce;

  mutable std::mutex mu;
  std::condition_variable cv;
  std::vector<std::shared_ptr<Entry>> entries;  ///< ascending address
  std::uint64_t next_id = 0;
  bool stopping = false;

  struct Waiter {
    std::string user;
    const std::set<std::string>* tried = nullptr;
    std::shared_ptr<Entry> granted;
  };
  std::map<std::string, std::deque<std::shared_ptr<Waiter>>> queues;  ///< per user, FIFO
  std::string last_user;  ///< the user served last (round-robin)

  struct Call {
    grpc::ClientContext* context;
    const std::function<bool()>* keep_going;
  };
  std::map<std::uint64_t, Call> calls;
  std::uint64_t next_call = 0;

  std::mutex threads_mu;
  std::condition_variable threads_cv;
  bool threads_stop = false;
  std::thread monitor, prober;

  Clock::duration silence_limit() const {
    return seconds(options.heartbeat_interval_s * std::max(options.missed_heartbeats, 1));
  }
  bool available(const Entry& e, Clock::time_point now) const {
    return e.seen && !e.left && e.version_ok && e.threads > 0 && now - e.last_seen <= silence_limit() &&
           now >= e.out_until;
  }

  /// Logs availability changes (under mu).
  void log_transitions(Clock::time_point now) {
    for (const auto& e : entries) {
      const bool a = available(*e, now);
      if (a == e->was_available) continue;
      e->was_available = a;
      if (a) {
        spdlog::info("worker {} available ({} threads)", e->address, e->threads);
      } else {
        spdlog::warn("worker {} taken out{}", e->address, e->last_error.empty() ? "" : ": " + e->last_error);
      }
    }
  }

  /// The worker for a waiter: available with a free slot, preferring one not
  /// tried (unless every available worker was tried), most free slots first.
  std::shared_ptr<Entry> pick(const Waiter& w, Clock::time_point now) const {
    bool untried_exists = false;
    for (const auto& e : entries) {
      if (available(*e, now) && w.tried->count(e->address) == 0) untried_exists = true;
    }
    std::shared_ptr<Entry> best;
    for (const auto& e : entries) {
      if (!available(*e, now) || e->busy >= e->threads) continue;
      if (untried_exists && w.tried->count(e->address) != 0) continue;
      if (!best || e->threads - e->busy > best->threads - best->busy) best = e;
    }
    return best;
  }

  /// Hands free slots to waiters: round-robin over users, FIFO within one.
  void assign(Clock::time_point now) {
    bool granted_any = false;
    for (bool progress = true; progress && !queues.empty();) {
      progress = false;
      auto start = queues.upper_bound(last_user);
      for (std::size_t n = 0; n < queues.size() && !progress; ++n) {
        if (start == queues.end()) start = queues.begin();
        auto& [user, queue] = *start;
        for (auto it = queue.begin(); it != queue.end(); ++it) {
          if (auto e = pick(**it, now)) {
            ++e->busy;
            (*it)->granted = std::move(e);
            queue.erase(it);
            last_user = user;
            progress = granted_any = true;
            break;
          }
        }
        if (progress) {
          if (queue.empty()) queues.erase(start);
        } else {
          ++start;
        }
      }
    }
    if (granted_any) cv.notify_all();
  }

  void remove_waiter(const std::shared_ptr<Waiter>& w) {
    auto q = queues.find(w->user);
    if (q == queues.end()) return;
    q->second.erase(std::remove(q->second.begin(), q->second.end(), w), q->second.end());
    if (q->second.empty()) queues.erase(q);
  }

  std::shared_ptr<Entry> make_entry(const std::string& address) const {
    auto e = std::make_shared<Entry>();
    e->address = address;
    e->stub = v1::WorkerService::NewStub(worker::make_channel(address, credentials, options.tls.server_name));
    return e;
  }
  void insert_sorted(std::shared_ptr<Entry> e) {
    auto at = std::lower_bound(entries.begin(), entries.end(), e,
                               [](const auto& a, const auto& b) { return a->address < b->address; });
    entries.insert(at, std::move(e));
  }

  void monitor_loop();
  void prober_loop();
  void probe(Entry& e);
};

void WorkerPool::State::monitor_loop() {
  std::unique_lock tl(threads_mu);
  while (!threads_stop) {
    threads_cv.wait_for(tl, kMonitorTick, [&] { return threads_stop; });
    // Cancel calls whose job stopped (keep_going is read outside our lock).
    std::vector<std::pair<std::uint64_t, const std::function<bool()>*>> todo;
    {
      std::lock_guard lock(mu);
      for (const auto& [id, call] : calls) todo.emplace_back(id, call.keep_going);
    }
    std::vector<std::uint64_t> cancel;
    for (const auto& [id, keep_going] : todo) {
      if (keep_going != nullptr && *keep_going && !(*keep_going)()) cancel.push_back(id);
    }
    std::lock_guard lock(mu);
    for (const std::uint64_t id : cancel) {
      if (auto it = calls.find(id); it != calls.end()) it->second.context->TryCancel();
    }
    const auto now = Clock::now();
    // Registered workers that went silent are forgotten.
    std::erase_if(entries, [&](const std::shared_ptr<Entry>& e) {
      if (e->is_static || now - e->last_seen <= silence_limit()) return false;
      spdlog::warn("worker {} ({}) missed {} heartbeats: forgotten until it registers again", e->id, e->address,
                   options.missed_heartbeats);
      return true;
    });
    log_transitions(now);
    assign(now);  // backoffs may have ended
  }
}

void WorkerPool::State::probe(Entry& e) {
  grpc::ClientContext context;
  worker::add_cluster_token(context, options.cluster_token);
  context.set_deadline(deadline_in(std::clamp(options.heartbeat_interval_s, 0.2, 2.0)));
  v1::GetWorkerInfoRequest request;
  v1::WorkerInfo info;
  const grpc::Status st = e.stub->GetWorkerInfo(&context, request, &info);
  std::lock_guard lock(mu);
  if (!st.ok()) {
    if (e.seen && Clock::now() - e.last_seen > silence_limit()) e.last_error = describe(st);
    return;
  }
  e.seen = true;
  e.last_seen = Clock::now();
  e.threads = info.threads();
  e.left = info.draining();
  e.version_ok = info.version() == worker::pdrmesh_version();
  if (!e.version_ok) {
    e.last_error = fmt::format("runs pdrmesh {}, the coordinator {}", info.version(), worker::pdrmesh_version());
  }
  assign(e.last_seen);
}

void WorkerPool::State::prober_loop() {
  std::unique_lock tl(threads_mu);
  while (!threads_stop) {
    threads_cv.wait_for(tl, seconds(options.heartbeat_interval_s), [&] { return threads_stop; });
    if (threads_stop) break;
    tl.unlock();
    std::vector<std::shared_ptr<Entry>> statics;
    {
      std::lock_guard lock(mu);
      for (const auto& e : entries) {
        if (e->is_static) statics.push_back(e);
      }
    }
    for (const auto& e : statics) probe(*e);
    tl.lock();
  }
}

// ---------------------------------------------------------------- pool

WorkerPool::WorkerPool(WorkerPoolOptions options) : options_(std::move(options)) {}

Result<std::shared_ptr<WorkerPool>> WorkerPool::create(WorkerPoolOptions options) {
  if (options.cluster_token.empty()) return invalid_input("the worker pool needs the cluster token");
  if (!(options.leaf_deadline_s > 0) || !(options.heartbeat_interval_s > 0) || options.max_attempts < 1) {
    return invalid_input("worker pool: the leaf deadline and heartbeat interval must be > 0, max attempts >= 1");
  }
  PDR_TRY(options.tls.check("towards the workers"));
  std::shared_ptr<WorkerPool> pool(new WorkerPool(options));
  auto s = std::make_shared<State>();
  s->options = std::move(options);
  PDR_ASSIGN_OR_RETURN(s->credentials, worker::channel_credentials(s->options.tls));
  std::random_device rd;
  s->nonce = fmt::format("{:08x}", rd());
  for (const std::string& a : s->options.static_workers) {
    if (a.empty()) continue;
    auto e = s->make_entry(a);
    e->is_static = true;
    s->insert_sorted(std::move(e));
  }
  pool->state_ = s;
  for (const auto& e : std::vector<std::shared_ptr<Entry>>(s->entries)) s->probe(*e);
  {
    std::lock_guard lock(s->mu);
    s->log_transitions(Clock::now());
  }
  s->monitor = std::thread([s] { s->monitor_loop(); });
  s->prober = std::thread([s] { s->prober_loop(); });
  return pool;
}

WorkerPool::~WorkerPool() { stop(); }

void WorkerPool::stop() {
  State& s = *state_;
  {
    std::lock_guard lock(s.threads_mu);
    if (s.threads_stop) return;
    s.threads_stop = true;
  }
  s.threads_cv.notify_all();
  if (s.monitor.joinable()) s.monitor.join();
  if (s.prober.joinable()) s.prober.join();
  std::lock_guard lock(s.mu);
  s.stopping = true;
  for (auto& [id, call] : s.calls) call.context->TryCancel();
  s.cv.notify_all();
}

Result<WorkerPool::Registration> WorkerPool::register_worker(const std::string& address, unsigned threads,
                                                             std::string_view version) {
  if (address.empty()) return invalid_input("RegisterWorker: no address");
  if (threads == 0) return invalid_input(fmt::format("RegisterWorker {}: threads must be at least 1", address));
  if (version != worker::pdrmesh_version()) {
    return unsupported(fmt::format("worker {} runs pdrmesh {}, the coordinator {}: refused", address, version,
                                   worker::pdrmesh_version()));
  }
  State& s = *state_;
  std::lock_guard lock(s.mu);
  auto it = std::find_if(s.entries.begin(), s.entries.end(), [&](const auto& e) { return e->address == address; });
  std::shared_ptr<Entry> e;
  if (it != s.entries.end() && (*it)->is_static) {
    e = *it;
  } else {
    if (it != s.entries.end()) s.entries.erase(it);  // an earlier registration: replaced
    e = s.make_entry(address);
    s.insert_sorted(e);
  }
  e->id = fmt::format("{}-{}", s.nonce, ++s.next_id);
  e->threads = threads;
  e->seen = true;
  e->left = false;
  e->version_ok = true;
  e->last_seen = Clock::now();
  e->last_error.clear();
  spdlog::info("worker {} registered from {} ({} threads)", e->id, address, threads);
  s.log_transitions(e->last_seen);
  s.assign(e->last_seen);
  return Registration{e->id, static_cast<unsigned>(s.options.heartbeat_interval_s * 1000)};
}

bool WorkerPool::heartbeat(std::string_view worker_id, unsigned busy) {
  State& s = *state_;
  std::lock_guard lock(s.mu);
  for (const auto& e : s.entries) {
    if (e->id != worker_id || worker_id.empty()) continue;
    e->last_seen = Clock::now();
    spdlog::trace("heartbeat from worker {} ({} busy)", worker_id, busy);
    return true;
  }
  return false;
}

void WorkerPool::leave(std::string_view worker_id) {
  State& s = *state_;
  std::lock_guard lock(s.mu);
  for (const auto& e : s.entries) {
    if (e->id != worker_id || worker_id.empty()) continue;
    e->left = true;
    e->last_error = "left (draining)";
    spdlog::info("worker {} ({}) leaves", worker_id, e->address);
    s.log_transitions(Clock::now());
  }
  std::erase_if(s.entries, [&](const auto& e) { return e->id == worker_id && !e->is_static; });
}

std::size_t WorkerPool::total_slots() const {
  const State& s = *state_;
  std::lock_guard lock(s.mu);
  const auto now = Clock::now();
  std::size_t n = 0;
  for (const auto& e : s.entries) {
    if (s.available(*e, now)) n += e->threads;
  }
  return n;
}

std::vector<WorkerSnapshot> WorkerPool::workers() const {
  const State& s = *state_;
  std::lock_guard lock(s.mu);
  const auto now = Clock::now();
  std::vector<WorkerSnapshot> out;
  for (const auto& e : s.entries) {
    out.push_back({e->id, e->address, e->is_static, s.available(*e, now), e->threads, e->busy, e->done, e->failures,
                   e->last_error});
  }
  return out;
}

std::size_t WorkerPool::waiting() const {
  const State& s = *state_;
  std::lock_guard lock(s.mu);
  std::size_t n = 0;
  for (const auto& [user, queue] : s.queues) n += queue.size();
  return n;
}

Result<WorkerPool::Lease> WorkerPool::acquire(const std::string& user, const std::set<std::string>& tried,
                                              const std::function<bool()>& keep_going) {
  State& s = *state_;
  auto w = std::make_shared<State::Waiter>();
  w->user = user;
  w->tried = &tried;
  std::unique_lock lock(s.mu);
  s.queues[user].push_back(w);
  for (;;) {
    s.assign(Clock::now());
    if (!w->granted && !s.stopping) {
      lock.unlock();
      const bool go = !keep_going || keep_going();
      lock.lock();
      if (!go && !w->granted) {
        s.remove_waiter(w);
        return cancelled("stopped while waiting for a worker");
      }
    }
    if (w->granted) {
      Lease lease;
      lease.pool_ = this;
      lease.entry_ = std::move(w->granted);
      return lease;
    }
    if (s.stopping) {
      s.remove_waiter(w);
      return cancelled("the coordinator is shutting down");
    }
    s.cv.wait_for(lock, kWaitPoll);
  }
}

WorkerPool::Lease::Lease(Lease&& other) noexcept : pool_(other.pool_), entry_(std::move(other.entry_)) {
  other.pool_ = nullptr;
}

WorkerPool::Lease& WorkerPool::Lease::operator=(Lease&& other) noexcept {
  if (this != &other) {
    release();
    pool_ = other.pool_;
    entry_ = std::move(other.entry_);
    other.pool_ = nullptr;
  }
  return *this;
}

WorkerPool::Lease::~Lease() { release(); }

const std::string& WorkerPool::Lease::address() const { return entry_->address; }

void WorkerPool::Lease::release(std::string_view error) {
  if (!pool_ || !entry_) return;
  State& s = *pool_->state_;
  {
    std::lock_guard lock(s.mu);
    --entry_->busy;
    if (error.empty()) {
      ++entry_->done;
    } else {
      ++entry_->failures;
      entry_->last_error = std::string(error);
      entry_->out_until = Clock::now() + seconds(s.options.failure_backoff_s);
      s.log_transitions(Clock::now());
    }
    s.assign(Clock::now());
    s.cv.notify_all();
  }
  pool_ = nullptr;
  entry_.reset();
}

WorkerPool::CallGuard::CallGuard(WorkerPool& pool, void* client_context, const std::function<bool()>* keep_going)
    : pool_(pool) {
  State& s = *pool_.state_;
  std::lock_guard lock(s.mu);
  id_ = ++s.next_call;
  auto* context = static_cast<grpc::ClientContext*>(client_context);
  s.calls.emplace(id_, State::Call{context, keep_going});
  if (s.stopping) context->TryCancel();
}

WorkerPool::CallGuard::~CallGuard() {
  State& s = *pool_.state_;
  std::lock_guard lock(s.mu);
  s.calls.erase(id_);
}

// ---------------------------------------------------------------- registry service

namespace {

class WorkerRegistryImpl final : public v1::WorkerRegistry::Service {
 public:
  explicit WorkerRegistryImpl(std::shared_ptr<WorkerPool> pool) : pool_(std::move(pool)) {}

  grpc::Status RegisterWorker(grpc::ServerContext* context, const v1::RegisterWorkerRequest* request,
                              v1::RegisterWorkerResponse* response) override {
    if (grpc::Status st = check(*context); !st.ok()) return st;
    Result<WorkerPool::Registration> r =
        pool_->register_worker(request->address(), request->threads(), request->version());
    if (!r.ok()) {
      spdlog::warn("RegisterWorker from {}: {}", context->peer(), r.status().message());
      const auto code = r.status().code() == StatusCode::kUnsupported ? grpc::StatusCode::FAILED_PRECONDITION
                                                                       : grpc::StatusCode::INVALID_ARGUMENT;
      return {code, r.status().message()};
    }
    response->set_worker_id(r->worker_id);
    response->set_heartbeat_interval_ms(r->heartbeat_interval_ms);
    return grpc::Status::OK;
  }

  grpc::Status Heartbeat(grpc::ServerContext* context, const v1::HeartbeatRequest* request,
                         v1::HeartbeatResponse* response) override {
    if (grpc::Status st = check(*context); !st.ok()) return st;
    response->set_known(pool_->heartbeat(request->worker_id(), request->busy_leaves()));
    return grpc::Status::OK;
  }

  grpc::Status LeaveWorker(grpc::ServerContext* context, const v1::LeaveWorkerRequest* request,
                           v1::LeaveWorkerResponse*) override {
    if (grpc::Status st = check(*context); !st.ok()) return st;
    pool_->leave(request->worker_id());
    return grpc::Status::OK;
  }

 private:
  grpc::Status check(const grpc::ServerContext& context) const {
    grpc::Status st = worker::check_cluster_token(context, pool_->options().cluster_token);
    if (!st.ok()) spdlog::warn("WorkerRegistry call from {}: {}", context.peer(), st.error_message());
    return st;
  }
  std::shared_ptr<WorkerPool> pool_;
};

}  // namespace

// ---------------------------------------------------------------- remote kernel

/// The encoded sizing field and its digest, made once per field. Keyed on the
/// field's address and shape: the kernels of one job share it, and the job's
/// field lives (unchanged) while the job meshes.
struct RemoteLeafDispatch::SizingBlob {
  struct Encoded {
    std::shared_ptr<const std::string> bytes;
    std::uint64_t digest = 0;
  };

  Encoded get(const SizingField& sizing, Counters& counters) {
    std::lock_guard lock(mu);
    const std::array<std::size_t, 3> shape{sizing.background_points(), sizing.boundary_points(),
                                           std::size_t{sizing.uniform()}};
    if (key != &sizing || key_shape != shape || !encoded.bytes) {
      auto bytes = std::make_shared<const std::string>(sizing.encode());
      encoded = Encoded{bytes, worker::content_digest(*bytes)};
      key = &sizing;
      key_shape = shape;
      ++counters.sizing_encodes;
    }
    return encoded;
  }

  std::mutex mu;
  const SizingField* key = nullptr;
  std::array<std::size_t, 3> key_shape{};
  Encoded encoded;
};

namespace {

class RemoteKernel final : public LeafKernel {
 public:
  RemoteKernel(std::shared_ptr<WorkerPool> pool, LeafJob job, std::unique_ptr<LeafKernel> local,
               std::shared_ptr<RemoteLeafDispatch::Counters> counters,
               std::shared_ptr<RemoteLeafDispatch::SizingBlob> blob)
      : pool_(std::move(pool)),
        job_(std::move(job)),
        local_(std::move(local)),
        counters_(std::move(counters)),
        blob_(std::move(blob)) {}

  std::string_view name() const override { return local_->name(); }
  bool needs_manifold_hull() const override { return local_->needs_manifold_hull(); }

  Result<LeafTaskOutput> run(const LeafTaskInput& in, const SizingField& sizing) const override {
    const RemoteLeafDispatch::SizingBlob::Encoded blob = blob_->get(sizing, *counters_);
    const std::string input = in.encode();
    const std::uint64_t max_output = std::min(kMaxOutputBytes, leaf_output_byte_limit(in, sizing));
    const std::uint64_t seq = ++seq_;
    std::set<std::string> tried;
    std::vector<std::string> errors;
    const int max_attempts = pool_->options().max_attempts;
    constexpr int kMaxUnreachable = 64;  // workers skipped as unreachable, per leaf
    int unreachable = 0;
    for (int attempt = 1; attempt <= max_attempts; ++attempt) {
      if (pool_->total_slots() == 0 && !warned_idle_.exchange(true)) {
        spdlog::warn("job {}: no worker available; its leaves wait for one", job_.job_id);
      }
      Result<WorkerPool::Lease> acquired = pool_->acquire(job_.user, tried, job_.keep_going);
      if (!acquired.ok()) {
        return Status(acquired.status().code(),
                      fmt::format("job {} leaf {}: {}", job_.job_id, in.leaf, acquired.status().message()));
      }
      WorkerPool::Lease lease = std::move(acquired).value();
      const std::string address = lease.address();
      tried.insert(address);
      v1::LeafTaskHeader header;
      header.set_task_id(fmt::format("{}/t{}/leaf{}/a{}", job_.job_id, seq, in.leaf, attempt));
      header.set_job_id(job_.job_id);
      header.set_kernel(std::string(local_->name()));
      header.set_input_bytes(input.size());
      header.set_sizing_digest(blob.digest);
      ++counters_->attempts;
      Attempt a = call(lease.entry(), header, input, nullptr, max_output);
      if (a.outcome == Outcome::kSizingUnknown) {
        ++counters_->sizing_resends;
        spdlog::debug("job {} leaf {}: worker {} lacks the sizing field, sending it", job_.job_id, in.leaf, address);
        header.set_sizing_bytes(blob.bytes->size());
        a = call(lease.entry(), header, input, blob.bytes.get(), max_output);
        if (a.outcome == Outcome::kSizingUnknown) a.outcome = Outcome::kRetry;
      }
      switch (a.outcome) {
        case Outcome::kOk: {
          Result<LeafTaskOutput> out = LeafTaskOutput::decode(a.bytes);
          Status valid = out.ok() ? validate_leaf_output(in, *out) : out.status();
          if (valid.ok()) {
            lease.release();
            ++counters_->accepted;
            spdlog::debug("job {} leaf {}: result from {} accepted (attempt {})", job_.job_id, in.leaf, address,
                          attempt);
            return out;
          }
          a.error = fmt::format("{} result: {}", out.ok() ? "invalid" : "undecodable", valid.message());
          break;
        }
        case Outcome::kKernelError:
          return Status(a.status.code(), fmt::format("job {} leaf {} (worker {}): {}", job_.job_id, in.leaf, address,
                                                     a.status.message()));
        case Outcome::kFatal:
          return Status(a.status.code(), fmt::format("job {} leaf {}: worker {} refused the task: {}", job_.job_id,
                                                     in.leaf, address, a.status.message()));
        case Outcome::kRetry:
        case Outcome::kUnreachable:
        case Outcome::kSizingUnknown: break;
      }
      if (job_.keep_going && !job_.keep_going()) {
        lease.release();
        return cancelled(fmt::format("job {} stopped (leaf {} was on worker {})", job_.job_id, in.leaf, address));
      }
      ++counters_->retried;
      spdlog::warn("job {} leaf {}: attempt {} on worker {} failed: {}{}", job_.job_id, in.leaf, attempt, address,
                   a.error,
                   attempt < max_attempts || a.outcome == Outcome::kUnreachable ? "; giving the leaf to another worker"
                                                                                 : "");
      errors.push_back(fmt::format("{} ({})", address, a.error));
      lease.release(a.error);
      if (a.outcome == Outcome::kUnreachable && unreachable++ < kMaxUnreachable) --attempt;
    }
    return io_error(fmt::format("job {} leaf {}: no valid result after {} attempts; workers tried: {}", job_.job_id,
                                in.leaf, max_attempts, fmt::join(errors, "; ")));
  }

 private:
  // kUnreachable: the channel never connected (the worker is gone, or not yet
  // known to be): another worker is tried without spending one of the leaf's
  // attempts, which bound the workers that received the task and failed.
  enum class Outcome { kOk, kSizingUnknown, kRetry, kUnreachable, kFatal, kKernelError };
  struct Attempt {
    Outcome outcome = Outcome::kRetry;
    std::string bytes;  ///< kOk: the encoded output
    Status status;      ///< kKernelError, kFatal
    std::string error;  ///< kRetry: what went wrong
  };

  /// One attempt; a result announced above max_output bytes is refused unread.
  Attempt call(WorkerPool::Entry& entry, const v1::LeafTaskHeader& header, std::string_view input,
               const std::string* sizing, std::uint64_t max_output) const {
    grpc::ClientContext context;
    worker::add_cluster_token(context, pool_->options().cluster_token);
    context.set_deadline(deadline_in(pool_->options().leaf_deadline_s));
    WorkerPool::CallGuard guard(*pool_, &context, &job_.keep_going);
    auto stream = entry.stub->RefineLeaf(&context);
    v1::RefineLeafRequest request;
    *request.mutable_header() = header;
    bool writing = stream->Write(request);
    if (sizing != nullptr) {
      for (std::size_t at = 0; writing && at < sizing->size(); at += worker::kChunkBytes) {
        request.set_sizing(sizing->substr(at, worker::kChunkBytes));
        writing = stream->Write(request);
      }
    }
    for (std::size_t at = 0; writing && at < input.size(); at += worker::kChunkBytes) {
      request.set_input(std::string(input.substr(at, worker::kChunkBytes)));
      writing = stream->Write(request);
    }
    if (writing) stream->WritesDone();

    Attempt a;
    v1::RefineLeafResponse response;
    v1::LeafResultHeader result;
    bool have_header = false;
    std::string protocol_error;
    while (protocol_error.empty() && stream->Read(&response)) {
      if (!have_header) {
        if (!response.has_header()) {
          protocol_error = "the answer does not start with a result header";
        } else if (response.header().output_bytes() > max_output) {
          protocol_error = fmt::format("result of {} bytes announced, over the {} this leaf can hold",
                                       response.header().output_bytes(), max_output);
        }
        result = response.header();
        have_header = true;
      } else if (!response.has_output() || a.bytes.size() + response.output().size() > result.output_bytes()) {
        protocol_error = fmt::format("result chunk out of order or past the announced {} bytes", result.output_bytes());
      } else {
        a.bytes += response.output();
      }
    }
    if (!protocol_error.empty()) context.TryCancel();
    const grpc::Status st = stream->Finish();
    if (!protocol_error.empty()) {
      a.error = protocol_error;
    } else if (st.ok()) {
      if (!have_header) {
        a.error = "the answer ended without a result";
      } else if (result.has_error()) {
        a.outcome = Outcome::kKernelError;
        a.status = Status(worker::status_code_from_name(result.error().code()), result.error().message());
      } else if (a.bytes.size() != result.output_bytes()) {
        a.error = fmt::format("result cut after {} of {} bytes", a.bytes.size(), result.output_bytes());
      } else {
        a.outcome = Outcome::kOk;
      }
    } else if (st.error_code() == grpc::StatusCode::FAILED_PRECONDITION &&
               st.error_message().starts_with(worker::kSizingUnknown)) {
      a.outcome = Outcome::kSizingUnknown;
      a.error = describe(st);
    } else if (st.error_code() == grpc::StatusCode::INVALID_ARGUMENT) {
      a.outcome = Outcome::kFatal;
      a.status = invalid_input(describe(st));
    } else if (st.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
      a.outcome = Outcome::kFatal;
      a.status = resource_exhausted(describe(st));
    } else {
      a.error = describe(st);
      if (st.error_code() == grpc::StatusCode::UNAVAILABLE &&
          st.error_message().find("failed to connect") != std::string::npos) {
        a.outcome = Outcome::kUnreachable;
      }
    }
    return a;
  }

  std::shared_ptr<WorkerPool> pool_;
  LeafJob job_;
  std::unique_ptr<LeafKernel> local_;  ///< names the kernel, answers needs_manifold_hull
  std::shared_ptr<RemoteLeafDispatch::Counters> counters_;
  mutable std::atomic<std::uint64_t> seq_{0};
  mutable std::atomic<bool> warned_idle_{false};
  std::shared_ptr<RemoteLeafDispatch::SizingBlob> blob_;
};

}  // namespace

std::unique_ptr<grpc::Service> make_worker_registry_service(std::shared_ptr<WorkerPool> pool) {
  return std::make_unique<WorkerRegistryImpl>(std::move(pool));
}

RemoteLeafDispatch::RemoteLeafDispatch(std::shared_ptr<WorkerPool> pool)
    : pool_(std::move(pool)), counters_(std::make_shared<Counters>()) {}

Result<std::unique_ptr<LeafKernel>> RemoteLeafDispatch::kernel_for(const LeafJob& job) {
  PDR_ASSIGN_OR_RETURN(std::unique_ptr<LeafKernel> local, make_leaf_kernel(job.kernel));
  std::shared_ptr<SizingBlob> blob;
  {
    std::lock_guard lock(blobs_mu_);
    std::erase_if(blobs_, [](const auto& entry) { return entry.second.expired(); });
    std::weak_ptr<SizingBlob>& slot = blobs_[job.job_id];
    blob = slot.lock();
    if (!blob) {
      blob = std::make_shared<SizingBlob>();
      slot = blob;
    }
  }
  return std::unique_ptr<LeafKernel>(
      std::make_unique<RemoteKernel>(pool_, job, std::move(local), counters_, std::move(blob)));
}

std::size_t RemoteLeafDispatch::concurrency() const { return std::max<std::size_t>(pool_->total_slots(), 1); }

DispatchStats RemoteLeafDispatch::stats() const {
  return {counters_->attempts, counters_->accepted, counters_->retried, counters_->sizing_resends,
          counters_->sizing_encodes};
}

}  // namespace pdrmesh::server
