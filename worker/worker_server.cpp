// SPDX-License-Identifier: AGPL-3.0-or-later
// The worker daemon: WorkerService handlers, the sizing cache, the leaf slots,
// registration and heartbeats, and draining (see worker_server.hpp).
#include "worker_server.hpp"

#include <fmt/format.h>
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <list>
#include <map>
#include <mutex>
#include <new>
#include <thread>

#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/leaf_task.hpp"
#include "pdrmesh/sizing.hpp"
#include "pdrmesh/v1/pdrmesh.grpc.pb.h"

namespace pdrmesh::worker {
namespace {

using Clock = std::chrono::steady_clock;
namespace v1 = pdrmesh::v1;

grpc::Status rpc_error(grpc::StatusCode code, std::string message) { return {code, std::move(message)}; }

}  // namespace

/// Decoded sizing fields by digest, least recently used first out. (Not in the
/// anonymous namespace: it is the type of a member of Worker::State.)
class SizingCache {
 public:
  explicit SizingCache(std::size_t capacity) : capacity_(std::max<std::size_t>(capacity, 1)) {}
  std::shared_ptr<const SizingField> find(std::uint64_t digest) {
    std::lock_guard lock(mu_);
    for (auto it = entries_.begin(); it != entries_.end(); ++it) {
      if (it->first == digest) {
        entries_.splice(entries_.begin(), entries_, it);
        return entries_.front().second;
      }
    }
    return nullptr;
  }
  void insert(std::uint64_t digest, std::shared_ptr<const SizingField> field) {
    std::lock_guard lock(mu_);
    entries_.remove_if([&](const auto& e) { return e.first == digest; });
    entries_.emplace_front(digest, std::move(field));
    while (entries_.size() > capacity_) entries_.pop_back();  // users hold their own reference
  }

 private:
  std::mutex mu_;
  std::size_t capacity_;
  std::list<std::pair<std::uint64_t, std::shared_ptr<const SizingField>>> entries_;
};

struct Worker::State {
  WorkerOptions options;
  std::string listen_bound, advertise;
  int port = 0;
  unsigned threads = 1;
  SizingCache cache{4};

  // Leaf slots and calls in flight.
  std::mutex mu;
  std::condition_variable cv;
  unsigned running = 0;  ///< leaves in a kernel
  unsigned active = 0;   ///< RefineLeaf calls past the token check
  std::atomic<bool> draining{false};

  std::mutex kernels_mu;
  std::map<std::string, std::unique_ptr<LeafKernel>, std::less<>> kernels;

  std::atomic<std::uint64_t> leaves_done{0}, leaves_failed{0}, sizing_misses{0}, sizing_received{0};

  // Registration.
  std::thread registrar;
  std::mutex reg_mu;
  std::condition_variable reg_cv;
  bool reg_stop = false;
  std::string worker_id;  ///< under reg_mu; empty: not registered
  std::unique_ptr<v1::WorkerRegistry::Stub> registry;

  std::unique_ptr<grpc::Service> service;
  std::unique_ptr<grpc::Server> server;
  bool drained = false;

  explicit State(WorkerOptions o) : options(std::move(o)), cache(options.sizing_cache_entries) {}

  Result<const LeafKernel*> kernel(std::string_view name) {
    std::lock_guard lock(kernels_mu);
    if (auto it = kernels.find(name); it != kernels.end()) return it->second.get();
    PDR_ASSIGN_OR_RETURN(std::unique_ptr<LeafKernel> k, make_leaf_kernel(name));
    const LeafKernel* p = k.get();
    kernels.emplace(std::string(name), std::move(k));
    return p;
  }

  /// Waits for a free slot; false when the call was cancelled or the worker drains.
  bool acquire(const grpc::ServerContext& context) {
    std::unique_lock lock(mu);
    while (running >= threads) {
      if (draining || context.IsCancelled()) return false;
      cv.wait_for(lock, std::chrono::milliseconds(50));
    }
    if (draining) return false;
    ++running;
    return true;
  }
  void release() {
    std::lock_guard lock(mu);
    --running;
    cv.notify_all();
  }
  unsigned busy() {
    std::lock_guard lock(mu);
    return running;
  }

  void registration_loop();
  void leave();
};

namespace {

class ActiveCall {
 public:
  explicit ActiveCall(Worker::State& s) : s_(s) {
    std::lock_guard lock(s_.mu);
    ++s_.active;
  }
  ~ActiveCall() {
    std::lock_guard lock(s_.mu);
    --s_.active;
    s_.cv.notify_all();
  }
  ActiveCall(const ActiveCall&) = delete;
  ActiveCall& operator=(const ActiveCall&) = delete;

 private:
  Worker::State& s_;
};

/// TEST ONLY (WorkerOptions::test_leaf_bad_alloc): a kernel that runs out of memory.
class BadAllocKernel final : public LeafKernel {
 public:
  Result<LeafTaskOutput> run(const LeafTaskInput&, const SizingField&) const override { throw std::bad_alloc(); }
  std::string_view name() const override { return "test-bad-alloc"; }
};

class WorkerServiceImpl final : public v1::WorkerService::Service {
 public:
  explicit WorkerServiceImpl(Worker::State& s) : s_(s) {}

  grpc::Status GetWorkerInfo(grpc::ServerContext* context, const v1::GetWorkerInfoRequest*,
                             v1::WorkerInfo* info) override {
    if (grpc::Status st = check_cluster_token(*context, s_.options.cluster_token); !st.ok()) return st;
    info->set_threads(s_.threads);
    info->set_version(std::string(pdrmesh_version()));
    info->set_busy_leaves(s_.busy());
    info->set_draining(s_.draining);
    return grpc::Status::OK;
  }

  /// An allocation failure anywhere in a call (reading the task, the kernel,
  /// encoding the result) answers that call, never takes the worker down.
  grpc::Status RefineLeaf(grpc::ServerContext* context,
                          grpc::ServerReaderWriter<v1::RefineLeafResponse, v1::RefineLeafRequest>* stream) override {
    try {
      return refine_leaf(context, stream);
    } catch (const std::bad_alloc&) {
      spdlog::error("RefineLeaf: out of memory");
      return rpc_error(grpc::StatusCode::RESOURCE_EXHAUSTED, "out of memory while refining a leaf on this worker");
    } catch (const std::exception& e) {
      spdlog::error("RefineLeaf: {}", e.what());
      return rpc_error(grpc::StatusCode::INTERNAL, fmt::format("unexpected error on this worker: {}", e.what()));
    }
  }

 private:
  grpc::Status refine_leaf(grpc::ServerContext* context,
                           grpc::ServerReaderWriter<v1::RefineLeafResponse, v1::RefineLeafRequest>* stream) {
    if (grpc::Status st = check_cluster_token(*context, s_.options.cluster_token); !st.ok()) {
      spdlog::warn("RefineLeaf from {}: {}", context->peer(), st.error_message());
      return st;
    }
    ActiveCall active(s_);
    if (s_.draining) return rpc_error(grpc::StatusCode::UNAVAILABLE, "worker draining: send the leaf elsewhere");
    v1::RefineLeafRequest request;
    if (!stream->Read(&request) || !request.has_header()) {
      return rpc_error(grpc::StatusCode::INVALID_ARGUMENT, "RefineLeaf: the first message must be the task header");
    }
    const v1::LeafTaskHeader header = request.header();
    const std::string tag = fmt::format("job {} task {}", header.job_id(), header.task_id());
    if (header.input_bytes() == 0) {
      return rpc_error(grpc::StatusCode::INVALID_ARGUMENT, fmt::format("{}: no input (input_bytes is 0)", tag));
    }
    if (header.input_bytes() > s_.options.max_input_bytes) {
      spdlog::warn("{}: task of {} bytes rejected (max {})", tag, header.input_bytes(), s_.options.max_input_bytes);
      return rpc_error(grpc::StatusCode::RESOURCE_EXHAUSTED,
                       fmt::format("{}: leaf task of {} bytes is over this worker's limit of {} bytes", tag,
                                   header.input_bytes(), s_.options.max_input_bytes));
    }
    if (header.sizing_bytes() > s_.options.max_sizing_bytes) {
      return rpc_error(grpc::StatusCode::RESOURCE_EXHAUSTED,
                       fmt::format("{}: sizing field of {} bytes is over this worker's limit of {} bytes", tag,
                                   header.sizing_bytes(), s_.options.max_sizing_bytes));
    }
    Result<const LeafKernel*> kernel = s_.kernel(header.kernel());
    if (!kernel.ok()) {
      return rpc_error(grpc::StatusCode::INVALID_ARGUMENT, fmt::format("{}: {}", tag, kernel.status().message()));
    }
    std::shared_ptr<const SizingField> sizing;
    if (header.sizing_bytes() == 0) {
      sizing = s_.cache.find(header.sizing_digest());
      if (!sizing) {
        ++s_.sizing_misses;
        spdlog::debug("{}: sizing {:016x} not cached, asking for it", tag, header.sizing_digest());
        return rpc_error(grpc::StatusCode::FAILED_PRECONDITION,
                         fmt::format("{}: no sizing field with digest {:016x} on this worker ({}); send it",
                                     kSizingUnknown, header.sizing_digest(), tag));
      }
    }

    // The sizing field (when sent), then the input; sizes exactly as declared.
    std::string sizing_bytes, input;
    while (stream->Read(&request)) {
      if (request.has_sizing()) {
        if (!input.empty() || sizing_bytes.size() + request.sizing().size() > header.sizing_bytes()) {
          return rpc_error(grpc::StatusCode::INVALID_ARGUMENT,
                           fmt::format("{}: sizing chunk out of order or past the declared {} bytes", tag,
                                       header.sizing_bytes()));
        }
        sizing_bytes += request.sizing();
      } else if (request.has_input()) {
        if (sizing_bytes.size() != header.sizing_bytes() ||
            input.size() + request.input().size() > header.input_bytes()) {
          return rpc_error(grpc::StatusCode::INVALID_ARGUMENT,
                           fmt::format("{}: input chunk before the whole sizing field or past the declared {} bytes",
                                       tag, header.input_bytes()));
        }
        input += request.input();
      } else {
        return rpc_error(grpc::StatusCode::INVALID_ARGUMENT, fmt::format("{}: a second task header", tag));
      }
    }
    if (context->IsCancelled()) return rpc_error(grpc::StatusCode::CANCELLED, fmt::format("{}: cancelled", tag));
    if (input.size() != header.input_bytes()) {
      return rpc_error(grpc::StatusCode::INVALID_ARGUMENT, fmt::format("{}: stream ended after {} of {} input bytes",
                                                                       tag, input.size(), header.input_bytes()));
    }
    if (header.sizing_bytes() > 0) {
      if (const std::uint64_t d = content_digest(sizing_bytes); d != header.sizing_digest()) {
        return rpc_error(grpc::StatusCode::INVALID_ARGUMENT,
                         fmt::format("{}: sizing field digest {:016x}, header says {:016x}", tag, d,
                                     header.sizing_digest()));
      }
      Result<SizingField> field = SizingField::decode(sizing_bytes);
      if (!field.ok()) {
        return rpc_error(grpc::StatusCode::INVALID_ARGUMENT,
                         fmt::format("{}: sizing field: {}", tag, field.status().message()));
      }
      sizing = std::make_shared<const SizingField>(std::move(*field));
      s_.cache.insert(header.sizing_digest(), sizing);
      ++s_.sizing_received;
    }
    Result<LeafTaskInput> in = LeafTaskInput::decode(input);
    if (!in.ok()) {
      return rpc_error(grpc::StatusCode::INVALID_ARGUMENT, fmt::format("{}: input: {}", tag, in.status().message()));
    }

    if (!s_.acquire(*context)) {
      if (s_.draining) return rpc_error(grpc::StatusCode::UNAVAILABLE, "worker draining: send the leaf elsewhere");
      return rpc_error(grpc::StatusCode::CANCELLED, fmt::format("{}: cancelled while waiting", tag));
    }
    if (s_.options.test_leaf_delay.count() > 0) std::this_thread::sleep_for(s_.options.test_leaf_delay);
    const auto t0 = Clock::now();
    Result<LeafTaskOutput> out = s_.options.test_leaf_bad_alloc ? run_leaf_kernel(BadAllocKernel{}, *in, *sizing)
                                                                 : run_leaf_kernel(**kernel, *in, *sizing);
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    s_.release();

    v1::RefineLeafResponse response;
    v1::LeafResultHeader* rh = response.mutable_header();
    rh->set_task_id(header.task_id());
    rh->set_seconds(seconds);
    std::string encoded;
    if (out.ok()) {
      encoded = out->encode();
      rh->set_output_bytes(encoded.size());
      spdlog::debug("{} leaf {} ({} kernel): {} tets in, {} out, {:.3f} s", tag, in->leaf, header.kernel(),
                    in->tets.size(), out->tets.size(), seconds);
    } else {
      rh->mutable_error()->set_code(std::string(to_string(out.status().code())));
      rh->mutable_error()->set_message(out.status().message());
      spdlog::warn("{} leaf {}: kernel failed: {}", tag, in->leaf, out.status().to_string());
    }
    if (!stream->Write(response)) return rpc_error(grpc::StatusCode::CANCELLED, fmt::format("{}: caller gone", tag));
    for (std::size_t at = 0; at < encoded.size(); at += kChunkBytes) {
      response.Clear();
      response.set_output(encoded.substr(at, kChunkBytes));
      if (!stream->Write(response)) return rpc_error(grpc::StatusCode::CANCELLED, fmt::format("{}: caller gone", tag));
    }
    ++(out.ok() ? s_.leaves_done : s_.leaves_failed);
    return grpc::Status::OK;
  }

  Worker::State& s_;
};

}  // namespace

void Worker::State::registration_loop() {
  bool warned = false;  // one warning per streak of failures
  auto interval = options.register_retry;
  for (;;) {
    std::string id;
    {
      std::lock_guard lock(reg_mu);
      if (reg_stop) return;
      id = worker_id;
    }
    std::chrono::milliseconds wait = interval;
    grpc::ClientContext context;
    add_cluster_token(context, options.cluster_token);
    context.set_deadline(std::chrono::system_clock::now() + std::max(interval, std::chrono::milliseconds(2000)));
    if (id.empty()) {
      v1::RegisterWorkerRequest request;
      request.set_address(advertise);
      request.set_threads(threads);
      request.set_version(std::string(pdrmesh_version()));
      v1::RegisterWorkerResponse response;
      const grpc::Status st = registry->RegisterWorker(&context, request, &response);
      if (st.ok()) {
        std::lock_guard lock(reg_mu);
        worker_id = response.worker_id();
        interval = std::chrono::milliseconds(std::max<std::uint32_t>(response.heartbeat_interval_ms(), 50));
        wait = interval;
        warned = false;
        spdlog::info("registered with the coordinator {} as {} ({} threads, heartbeat every {} ms)",
                     options.coordinator_address, worker_id, threads, interval.count());
      } else {
        if (!warned) {
          spdlog::warn("cannot register with the coordinator {}: {} (retrying)", options.coordinator_address,
                       st.error_message());
        }
        warned = true;
        wait = options.register_retry;
      }
    } else {
      v1::HeartbeatRequest request;
      request.set_worker_id(id);
      request.set_busy_leaves(busy());
      v1::HeartbeatResponse response;
      const grpc::Status st = registry->Heartbeat(&context, request, &response);
      if (st.ok() && !response.known()) {
        spdlog::info("the coordinator forgot worker {}: registering again", id);
        std::lock_guard lock(reg_mu);
        worker_id.clear();
        continue;
      }
      if (!st.ok() && !warned) spdlog::warn("heartbeat to {} failed: {}", options.coordinator_address, st.error_message());
      warned = !st.ok();
    }
    std::unique_lock lock(reg_mu);
    reg_cv.wait_for(lock, wait, [&] { return reg_stop; });
  }
}

void Worker::State::leave() {
  std::string id;
  {
    std::lock_guard lock(reg_mu);
    reg_stop = true;
    id = worker_id;
    worker_id.clear();
  }
  reg_cv.notify_all();
  if (registrar.joinable()) registrar.join();
  if (id.empty() || !registry) return;
  grpc::ClientContext context;
  add_cluster_token(context, options.cluster_token);
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(2));
  v1::LeaveWorkerRequest request;
  request.set_worker_id(id);
  v1::LeaveWorkerResponse response;
  if (const grpc::Status st = registry->LeaveWorker(&context, request, &response); !st.ok()) {
    spdlog::warn("could not tell the coordinator that worker {} leaves: {}", id, st.error_message());
  } else {
    spdlog::info("left the coordinator {} (worker {})", options.coordinator_address, id);
  }
}

Result<std::unique_ptr<Worker>> Worker::Start(WorkerOptions options) {
  if (options.cluster_token.empty()) return invalid_input("no cluster token given");
  PDR_TRY(options.tls.check("for the worker"));
  const bool tls = options.tls.enabled();
  if (!tls && !options.allow_insecure_remote) {
    for (const std::string& a : {options.listen_address, options.coordinator_address}) {
      if (!a.empty() && !is_loopback_address(a)) {
        return invalid_input(fmt::format("refusing to send the cluster token in clear text to or from {}: give "
                                         "--tls-cert/--tls-key/--tls-ca, or --allow-insecure",
                                         a));
      }
    }
  }
  std::unique_ptr<Worker> w(new Worker());
  w->state_ = std::make_shared<State>(std::move(options));
  State& s = *w->state_;
  s.threads = s.options.threads > 0 ? s.options.threads : std::max(1u, std::thread::hardware_concurrency());
  PDR_ASSIGN_OR_RETURN(const auto creds, server_credentials(s.options.tls));

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  s.service = std::make_unique<WorkerServiceImpl>(s);
  grpc::ServerBuilder builder;
  builder.AddListeningPort(s.options.listen_address, creds, &s.port);
  builder.RegisterService(s.service.get());
  s.server = builder.BuildAndStart();
  if (!s.server || s.port == 0) {
    return io_error(fmt::format("cannot listen on {} (address in use or invalid?)", s.options.listen_address));
  }
  s.server->GetHealthCheckService()->SetServingStatus(true);
  s.listen_bound = with_port(s.options.listen_address, s.port);
  s.advertise = s.options.advertise_address.empty() ? s.listen_bound : s.options.advertise_address;
  spdlog::info("pdrmesh-worker serving on {} ({} threads, {}), advertised as {}", s.listen_bound, s.threads,
               tls ? "mutual TLS" : "plaintext", s.advertise);
  if (!s.options.coordinator_address.empty()) {
    if (s.advertise.starts_with("0.0.0.0:") || s.advertise.starts_with("[::]:")) {
      spdlog::warn("registering as {}, which the coordinator cannot dial: give --advertise HOST:PORT", s.advertise);
    }
    PDR_ASSIGN_OR_RETURN(const auto channel_creds, channel_credentials(s.options.tls));
    s.registry = v1::WorkerRegistry::NewStub(make_channel(s.options.coordinator_address, channel_creds));
    s.registrar = std::thread([&s] { s.registration_loop(); });
  }
  return w;
}

Worker::~Worker() {
  if (state_) Drain(0);
}

int Worker::port() const { return state_->port; }
std::string Worker::listen_address() const { return state_->listen_bound; }
std::string Worker::advertise_address() const { return state_->advertise; }
unsigned Worker::threads() const { return state_->threads; }

WorkerStats Worker::stats() const {
  WorkerStats st;
  st.leaves_done = state_->leaves_done;
  st.leaves_failed = state_->leaves_failed;
  st.sizing_misses = state_->sizing_misses;
  st.sizing_received = state_->sizing_received;
  st.busy = state_->busy();
  std::lock_guard lock(state_->reg_mu);
  st.registered = !state_->worker_id.empty();
  return st;
}

bool Worker::Drain(double timeout_s) {
  State& s = *state_;
  if (s.drained || !s.server) return true;
  s.drained = true;
  s.draining = true;
  s.server->GetHealthCheckService()->SetServingStatus(false);
  s.cv.notify_all();  // calls waiting for a slot answer UNAVAILABLE
  s.leave();
  bool finished = false;
  {
    std::unique_lock lock(s.mu);
    finished = s.cv.wait_for(lock, std::chrono::duration<double>(std::max(timeout_s, 0.0)),
                             [&] { return s.active == 0; });
    if (!finished) {
      spdlog::warn("drain timeout after {} s: cutting off {} running leaves", timeout_s, s.running);
    }
  }
  s.server->Shutdown(std::chrono::system_clock::now() + std::chrono::milliseconds(200));
  s.server->Wait();
  spdlog::info("pdrmesh-worker stopped");
  return finished;
}

}  // namespace pdrmesh::worker
