// SPDX-License-Identifier: AGPL-3.0-or-later
// Workers: the pdrmesh-worker daemon as a real process on 127.0.0.1 (leaf
// bytes, the sizing-digest protocol, the cluster token, size bounds, health,
// draining), the WorkerPool (registration, fair slots) and RemoteLeafDispatch
// driving mesh_parallel with two worker processes, with and without faults
// (kill -9, SIGSTOP past the leaf deadline): the same bytes as the in-process
// kernel, every leaf accepted once.
//
// To catch a worker in the middle of a job the fault tests start it with the
// TEST-ONLY environment variable PDRMESH_WORKER_TEST_LEAF_DELAY_MS (each leaf
// waits that long first; see WorkerOptions::test_leaf_delay).
#include <gtest/gtest.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <oneapi/tbb/global_control.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <csignal>
#include <cstring>
#include <fstream>
#include <future>
#include <mutex>
#include <thread>

#include "leaf_rpc.hpp"
#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/v1/pdrmesh.grpc.pb.h"
#include "pdrmesh/validate.hpp"
#include "coordinator.hpp"
#include "process.hpp"
#include "certificates.hpp"
#include "temp_dir.hpp"
#include "worker_pool.hpp"
#include "worker_server.hpp"

namespace pdrmesh::server {
namespace {

using namespace std::chrono_literals;
const std::filesystem::path kSphere = std::filesystem::path(PDRMESH_CORPUS_DIR) / "sphere966.stl";
constexpr std::string_view kToken = "test-cluster-token-0123456789";

/// Wraps a make_leaf_kernel kernel and records the calls (and the first leaf with tets).
class RecordingKernel final : public LeafKernel {
 public:
  explicit RecordingKernel(std::string_view name) : inner_(make_leaf_kernel(name).value()) {}
  Result<LeafTaskOutput> run(const LeafTaskInput& in, const SizingField& sizing) const override {
    {
      std::lock_guard lock(mu_);
      ++calls_;
      if (sample_sizing_.empty() && in.tets.size() > 20) {
        sample_input_ = in.encode();
        sample_sizing_ = sizing.encode();
      }
    }
    return inner_->run(in, sizing);
  }
  std::string_view name() const override { return inner_->name(); }
  mutable std::mutex mu_;
  mutable std::size_t calls_ = 0;
  mutable std::string sample_input_, sample_sizing_;

 private:
  std::unique_ptr<LeafKernel> inner_;
};

/// The in-process run every remote run must match, made once.
struct Reference {
  SurfaceMesh surface;
  ParallelOptions options;
  VolumeMesh mesh;
  std::size_t leaf_tasks = 0;    ///< kernel run() calls: refinement and optimization tasks
  std::string input, sizing;     ///< one leaf task (encoded) and the job's sizing field
  std::string output;            ///< run_leaf_task of it, in process
};

const Reference& reference() {
  static const Reference* ref = [] {
    auto* r = new Reference();
    r->surface = read_surface(kSphere).value();
    r->options.pdr.depth = 2;
    r->options.pdr.workers = 2;
    RecordingKernel kernel("native"), optimizer("optimize"), last("optimize-final");
    Result<ParallelResult> res = mesh_parallel(r->surface, r->options, &kernel, &optimizer, &last);
    if (!res.ok()) {
      ADD_FAILURE() << res.status().to_string();
      return r;
    }
    r->mesh = std::move(res->mesh);
    if (optimizer.calls_ + last.calls_ == 0) ADD_FAILURE() << "the reference job ran no optimization task";
    r->leaf_tasks = kernel.calls_ + optimizer.calls_ + last.calls_;
    r->input = kernel.sample_input_;
    r->sizing = kernel.sample_sizing_;
    auto native = make_leaf_kernel("native").value();
    r->output = run_leaf_task(*native, r->input, SizingField::decode(r->sizing).value()).value();
    return r;
  }();
  return *ref;
}

template <class T>
bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

void expect_same_mesh(const VolumeMesh& a, const VolumeMesh& b) {
  EXPECT_TRUE(same_bytes(a.points, b.points)) << a.points.size() << " vs " << b.points.size() << " points";
  EXPECT_TRUE(same_bytes(a.tets, b.tets)) << a.tets.size() << " vs " << b.tets.size() << " tets";
  EXPECT_TRUE(same_bytes(a.boundary, b.boundary));
  EXPECT_TRUE(same_bytes(a.boundary_ids, b.boundary_ids));
  EXPECT_TRUE(same_bytes(a.tet_regions, b.tet_regions));
}

/// grpc.health.v1.Health/Check for the whole server: 1 SERVING, 2 NOT_SERVING, -1 no answer.
int health(const std::string& address) {
  grpc::GenericStub stub(grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + 5s);
  grpc::Slice empty("");
  grpc::ByteBuffer request(&empty, 1), response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                 [&](grpc::Status s) { done.set_value(std::move(s)); });
  if (!done.get_future().get().ok()) return -1;
  std::vector<grpc::Slice> slices;
  if (!response.Dump(&slices).ok()) return -1;
  std::string bytes;
  for (const auto& s : slices) bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  return bytes.size() == 2 && bytes[0] == 0x08 ? bytes[1] : 0;  // field 1, varint
}

/// The raw answer of server reflection to "list services" (v1alpha); empty when there is none.
std::string reflection_list(const std::string& address) {
  grpc::GenericStub stub(grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + 5s);
  grpc::CompletionQueue cq;
  auto call = stub.PrepareCall(&context, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", &cq);
  void* tag = nullptr;
  bool ok = false;
  const auto step = [&](std::intptr_t t) { return cq.Next(&tag, &ok) && tag == reinterpret_cast<void*>(t) && ok; };
  call->StartCall(reinterpret_cast<void*>(1));
  std::string bytes;
  if (step(1)) {
    grpc::Slice list(std::string("\x3a\x00", 2));  // field 7 list_services = ""
    grpc::ByteBuffer request(&list, 1), response;
    call->Write(request, reinterpret_cast<void*>(2));
    if (step(2)) {
      call->Read(&response, reinterpret_cast<void*>(3));
      if (step(3)) {
        std::vector<grpc::Slice> slices;
        if (response.Dump(&slices).ok()) {
          for (const auto& sl : slices) bytes.append(reinterpret_cast<const char*>(sl.begin()), sl.size());
        }
      }
    }
  }
  context.TryCancel();
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(4));
  cq.Shutdown();
  while (cq.Next(&tag, &ok)) {
  }
  return bytes;
}

/// Polls `done` every 20 ms for at most `limit` (a bound reached only on failure).
template <class F>
bool eventually(F done, std::chrono::milliseconds limit = 20s) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(20ms);
  }
  return true;
}

struct RawResult {
  grpc::Status status;
  v1::LeafResultHeader header;
  std::string output;
};

/// A misbehaving worker (in this process): answers every leaf in one bad way.
class FakeWorker final : public v1::WorkerService::Service {
 public:
  /// kOversized announces 2 GiB (under the absolute 4 GiB cap, far over what the leaf can hold).
  enum class Mode { kGarbage, kInvalidMesh, kCutStream, kKernelError, kOversized };
  FakeWorker(Mode mode, unsigned threads) : mode_(mode), threads_(threads) {
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(this);
    server_ = builder.BuildAndStart();
  }
  ~FakeWorker() override { server_->Shutdown(std::chrono::system_clock::now()); }
  std::string address() const { return fmt::format("127.0.0.1:{}", port_); }

  grpc::Status GetWorkerInfo(grpc::ServerContext*, const v1::GetWorkerInfoRequest*, v1::WorkerInfo* info) override {
    info->set_threads(threads_);
    info->set_version(std::string(worker::pdrmesh_version()));
    return grpc::Status::OK;
  }
  grpc::Status RefineLeaf(grpc::ServerContext*,
                          grpc::ServerReaderWriter<v1::RefineLeafResponse, v1::RefineLeafRequest>* stream) override {
    v1::RefineLeafRequest request;
    std::string input;
    while (stream->Read(&request)) input += request.input();
    std::string out = "not a leaf result";
    if (mode_ == Mode::kInvalidMesh || mode_ == Mode::kCutStream) {
      LeafTaskOutput empty;  // decodes, but its hull is not the leaf's
      const LeafTaskInput in = LeafTaskInput::decode(input).value();
      empty.leaf = in.leaf;
      empty.input_points = static_cast<std::uint32_t>(in.points.size());
      out = empty.encode();
    }
    v1::RefineLeafResponse response;
    response.mutable_header()->set_output_bytes(mode_ == Mode::kOversized ? std::uint64_t{1} << 31 : out.size());
    if (mode_ == Mode::kKernelError) {
      response.mutable_header()->mutable_error()->set_code(std::string(to_string(StatusCode::kInvalidInput)));
      response.mutable_header()->mutable_error()->set_message("this leaf cannot be refined");
    }
    stream->Write(response);
    if (mode_ == Mode::kKernelError) return grpc::Status::OK;
    response.Clear();
    response.set_output(mode_ == Mode::kCutStream ? out.substr(0, out.size() / 2) : out);
    stream->Write(response);
    return grpc::Status::OK;
  }

 private:
  Mode mode_;
  unsigned threads_;
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
};

class Workers : public ::testing::Test {
 protected:
  void SetUp() override {
    spdlog::set_level(spdlog::level::warn);
    std::ofstream(dir_.path() / "cluster-token") << kToken << "\n";
  }

  /// A pdrmesh-worker process; its address ("" when it did not start).
  std::string start_worker(std::unique_ptr<test::Process>& p, std::vector<std::string> extra = {},
                           std::vector<std::string> env = {}) {
    std::vector<std::string> args{"--listen", "127.0.0.1:0", "--cluster-token-file",
                                  (dir_.path() / "cluster-token").string(), "--log-level", "debug"};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto log = dir_.path() / fmt::format("worker{}.log", ++workers_started_);
    p = std::make_unique<test::Process>(PDRMESH_WORKER_BIN, args, env, log);
    auto line = p->wait_line("listening on ", 30s);
    EXPECT_TRUE(line.has_value()) << "worker did not start; see " << log;
    return line.value_or("");
  }

  static std::unique_ptr<v1::WorkerService::Stub> stub(const std::string& address) {
    return v1::WorkerService::NewStub(grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  }

  /// One RefineLeaf call with the given header and payloads.
  static RawResult refine(v1::WorkerService::Stub& stub, const v1::LeafTaskHeader& header, std::string_view sizing,
                          std::string_view input, std::string_view token = kToken) {
    grpc::ClientContext context;
    if (!token.empty()) worker::add_cluster_token(context, token);
    context.set_deadline(std::chrono::system_clock::now() + 60s);
    auto stream = stub.RefineLeaf(&context);
    v1::RefineLeafRequest request;
    *request.mutable_header() = header;
    bool ok = stream->Write(request);
    for (std::size_t at = 0; ok && at < sizing.size(); at += worker::kChunkBytes) {
      request.set_sizing(std::string(sizing.substr(at, worker::kChunkBytes)));
      ok = stream->Write(request);
    }
    for (std::size_t at = 0; ok && at < input.size(); at += worker::kChunkBytes) {
      request.set_input(std::string(input.substr(at, worker::kChunkBytes)));
      ok = stream->Write(request);
    }
    if (ok) stream->WritesDone();
    RawResult r;
    v1::RefineLeafResponse response;
    while (stream->Read(&response)) {
      if (response.has_header()) r.header = response.header();
      r.output += response.output();
    }
    r.status = stream->Finish();
    return r;
  }

  static v1::LeafTaskHeader header_for(const Reference& ref, bool with_sizing) {
    v1::LeafTaskHeader h;
    h.set_task_id("test/t1/a1");
    h.set_job_id("test");
    h.set_kernel("native");
    h.set_input_bytes(ref.input.size());
    h.set_sizing_digest(worker::content_digest(ref.sizing));
    h.set_sizing_bytes(with_sizing ? ref.sizing.size() : 0);
    return h;
  }

  WorkerPoolOptions pool_options(std::vector<std::string> workers = {}) const {
    WorkerPoolOptions o;
    o.static_workers = std::move(workers);
    o.cluster_token = std::string(kToken);
    o.heartbeat_interval_s = 0.2;
    // Short: a healthy worker whose leaf overran a deadline on a loaded machine comes back soon
    // (a dead or stopped one stays out anyway: it answers no probe or heartbeat).
    o.failure_backoff_s = 2;
    o.leaf_deadline_s = 60;
    return o;
  }

  /// A registry server for `pool` on 127.0.0.1; its address.
  std::string serve_registry(const std::shared_ptr<WorkerPool>& pool, int port = 0) {
    registry_service_ = make_worker_registry_service(pool);
    grpc::ServerBuilder builder;
    int bound = 0;
    builder.AddListeningPort(fmt::format("127.0.0.1:{}", port), grpc::InsecureServerCredentials(), &bound);
    builder.RegisterService(registry_service_.get());
    registry_ = builder.BuildAndStart();
    EXPECT_GT(bound, 0);
    return fmt::format("127.0.0.1:{}", bound);
  }

  /// mesh_parallel of the reference surface through the dispatch.
  static Result<ParallelResult> mesh_remote(RemoteLeafDispatch& dispatch, std::atomic<bool>* keep_going = nullptr) {
    const Reference& ref = reference();
    // Every kind of leaf task goes to the workers, as the coordinator sends them.
    LeafJob job{"job1", "alice", "native", [keep_going] { return keep_going == nullptr || keep_going->load(); }};
    PDR_ASSIGN_OR_RETURN(std::unique_ptr<LeafKernel> kernel, dispatch.kernel_for(job));
    job.kernel = "optimize";
    PDR_ASSIGN_OR_RETURN(std::unique_ptr<LeafKernel> optimizer, dispatch.kernel_for(job));
    job.kernel = "optimize-final";
    PDR_ASSIGN_OR_RETURN(std::unique_ptr<LeafKernel> last, dispatch.kernel_for(job));
    ParallelOptions o = ref.options;
    o.pdr.workers = dispatch.concurrency();
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 64);
    return mesh_parallel(ref.surface, o, kernel.get(), optimizer.get(), last.get());
  }

  test::TempDir dir_;
  int workers_started_ = 0;
  std::unique_ptr<grpc::Service> registry_service_;
  std::unique_ptr<grpc::Server> registry_;
};

TEST_F(Workers, RefinesALeafByteIdenticallyToTheLocalKernel) {
  const Reference& ref = reference();
  ASSERT_FALSE(ref.input.empty());
  std::unique_ptr<test::Process> w;
  const std::string address = start_worker(w, {"--threads", "2"});
  auto s = stub(address);
  const RawResult r = refine(*s, header_for(ref, true), ref.sizing, ref.input);
  ASSERT_TRUE(r.status.ok()) << r.status.error_message();
  EXPECT_FALSE(r.header.has_error());
  EXPECT_EQ(r.header.task_id(), "test/t1/a1");
  EXPECT_EQ(r.header.output_bytes(), r.output.size());
  EXPECT_EQ(r.output, ref.output);
}

TEST_F(Workers, AsksForAnUnknownSizingFieldAndCachesItOnceSent) {
  const Reference& ref = reference();
  std::unique_ptr<test::Process> w;
  auto s = stub(start_worker(w, {"--threads", "1"}));
  RawResult r = refine(*s, header_for(ref, false), "", ref.input);
  EXPECT_EQ(r.status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_TRUE(r.status.error_message().starts_with(worker::kSizingUnknown)) << r.status.error_message();
  r = refine(*s, header_for(ref, true), ref.sizing, ref.input);  // the resend
  ASSERT_TRUE(r.status.ok()) << r.status.error_message();
  EXPECT_EQ(r.output, ref.output);
  r = refine(*s, header_for(ref, false), "", ref.input);  // now cached
  ASSERT_TRUE(r.status.ok()) << r.status.error_message();
  EXPECT_EQ(r.output, ref.output);
  // A sizing field that does not match its digest is refused.
  v1::LeafTaskHeader h = header_for(ref, true);
  h.set_sizing_digest(h.sizing_digest() ^ 1);
  r = refine(*s, h, ref.sizing, ref.input);
  EXPECT_EQ(r.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(r.status.error_message().find("digest"), std::string::npos) << r.status.error_message();
}

TEST_F(Workers, RejectsCallsWithoutTheClusterToken) {
  const Reference& ref = reference();
  std::unique_ptr<test::Process> w;
  const std::string address = start_worker(w, {"--threads", "1"});
  auto s = stub(address);
  for (const std::string_view token : {std::string_view(), std::string_view("test-cluster-token-0123456788")}) {
    const RawResult r = refine(*s, header_for(ref, true), ref.sizing, ref.input, token);
    EXPECT_EQ(r.status.error_code(), grpc::StatusCode::UNAUTHENTICATED) << r.status.error_message();
    EXPECT_TRUE(r.output.empty());
    grpc::ClientContext context;
    if (!token.empty()) worker::add_cluster_token(context, token);
    v1::WorkerInfo info;
    EXPECT_EQ(s->GetWorkerInfo(&context, {}, &info).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  }
  // The coordinator's registry checks it too.
  auto pool = WorkerPool::create(pool_options()).value();
  auto registry = v1::WorkerRegistry::NewStub(
      grpc::CreateChannel(serve_registry(pool), grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  worker::add_cluster_token(context, "wrong-token-wrong-token");
  v1::RegisterWorkerRequest request;
  request.set_address(address);
  request.set_threads(1);
  request.set_version(std::string(worker::pdrmesh_version()));
  v1::RegisterWorkerResponse response;
  EXPECT_EQ(registry->RegisterWorker(&context, request, &response).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(pool->total_slots(), 0U);
  // And the worker still serves a caller with the token.
  const RawResult r = refine(*s, header_for(ref, true), ref.sizing, ref.input);
  EXPECT_TRUE(r.status.ok()) << r.status.error_message();
}

TEST_F(Workers, RejectsOversizedOrMisdeclaredTasks) {
  const Reference& ref = reference();
  std::unique_ptr<test::Process> w;
  auto s = stub(start_worker(w, {"--threads", "1"}));
  v1::LeafTaskHeader h = header_for(ref, true);
  h.set_input_bytes(worker::kDefaultMaxInputBytes + 1);
  RawResult r = refine(*s, h, "", "");
  EXPECT_EQ(r.status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(r.status.error_message().find(std::to_string(worker::kDefaultMaxInputBytes)), std::string::npos)
      << r.status.error_message();
  // More input than declared, and less.
  h = header_for(ref, true);
  h.set_input_bytes(ref.input.size() - 1);
  r = refine(*s, h, ref.sizing, ref.input);
  EXPECT_EQ(r.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << r.status.error_message();
  h.set_input_bytes(ref.input.size() + 1);
  r = refine(*s, h, ref.sizing, ref.input);
  EXPECT_EQ(r.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << r.status.error_message();
  // An unknown kernel.
  h = header_for(ref, true);
  h.set_kernel("magic");
  r = refine(*s, h, ref.sizing, ref.input);
  EXPECT_EQ(r.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << r.status.error_message();
}

TEST_F(Workers, TwoWorkerProcessesGiveTheLocalBytes) {
  const Reference& ref = reference();
  std::unique_ptr<test::Process> w1, w2;
  const std::string a1 = start_worker(w1, {"--threads", "2"});
  const std::string a2 = start_worker(w2, {"--threads", "1"});
  EXPECT_EQ(health(a1), 1);
  EXPECT_NE(reflection_list(a1).find("pdrmesh.v1.WorkerService"), std::string::npos);
  auto pool = WorkerPool::create(pool_options({a1, a2})).value();
  EXPECT_EQ(pool->total_slots(), 3U);
  RemoteLeafDispatch dispatch(pool);
  EXPECT_EQ(dispatch.concurrency(), 3U);
  Result<ParallelResult> res = mesh_remote(dispatch);
  ASSERT_TRUE(res.ok()) << res.status().to_string();
  expect_same_mesh(res->mesh, ref.mesh);
  const ValidationReport report = validate_mesh(res->mesh, &ref.surface);
  EXPECT_TRUE(validation_status(report).ok()) << format_validation(report);
  const DispatchStats st = dispatch.stats();
  EXPECT_EQ(st.accepted, ref.leaf_tasks);
  EXPECT_EQ(st.attempts, ref.leaf_tasks);
  EXPECT_EQ(st.retried, 0U);
  EXPECT_GE(st.sizing_resends, 2U);  // each worker asked for the field at least once
  EXPECT_LE(st.sizing_resends, 3U);  // at most once per slot
  EXPECT_EQ(st.sizing_encodes, 1U);  // the job's two kernels share one encoding of its field
  std::uint64_t done = 0;
  for (const WorkerSnapshot& w : pool->workers()) {
    EXPECT_GT(w.leaves_done, 0U) << w.address << " got no leaf";
    done += w.leaves_done;
  }
  EXPECT_EQ(done, ref.leaf_tasks);
}

TEST_F(Workers, KillNineOfAWorkerMidJobKeepsTheBytes) {
  const Reference& ref = reference();
  std::unique_ptr<test::Process> victim, survivor;
  const std::string av = start_worker(victim, {"--threads", "1"}, {"PDRMESH_WORKER_TEST_LEAF_DELAY_MS=150"});
  const std::string as = start_worker(survivor, {"--threads", "2"});
  auto pool = WorkerPool::create(pool_options({av, as})).value();
  RemoteLeafDispatch dispatch(pool);
  auto job = std::async(std::launch::async, [&] { return mesh_remote(dispatch); });
  // Mid-job: some leaves accepted, and the victim holding one.
  const auto victim_busy = [&] {
    for (const WorkerSnapshot& w : pool->workers()) {
      if (w.address == av) return w.busy > 0 && w.leaves_done > 0;
    }
    return false;
  };
  ASSERT_TRUE(eventually(victim_busy));
  victim->signal(SIGKILL);
  Result<ParallelResult> res = job.get();
  ASSERT_TRUE(res.ok()) << res.status().to_string();
  expect_same_mesh(res->mesh, ref.mesh);
  const DispatchStats st = dispatch.stats();
  EXPECT_EQ(st.accepted, ref.leaf_tasks);  // no leaf accepted twice, none lost
  EXPECT_GE(st.retried, 1U);               // the victim's leaf went elsewhere
  EXPECT_EQ(st.attempts, st.accepted + st.retried);
}

TEST_F(Workers, AStoppedWorkerPastItsDeadlineLosesItsLeafToAnother) {
  const Reference& ref = reference();
  WorkerPoolOptions o = pool_options();
  o.leaf_deadline_s = 3;
  auto pool = WorkerPool::create(o).value();
  const std::string registry = serve_registry(pool);
  std::unique_ptr<test::Process> victim, survivor;
  start_worker(victim, {"--threads", "1", "--coordinator", registry}, {"PDRMESH_WORKER_TEST_LEAF_DELAY_MS=150"});
  start_worker(survivor, {"--threads", "2", "--coordinator", registry});
  ASSERT_TRUE(eventually([&] { return pool->total_slots() == 3; }));
  std::string av;
  for (const WorkerSnapshot& w : pool->workers()) {
    if (w.threads == 1) av = w.address;
  }
  RemoteLeafDispatch dispatch(pool);
  auto job = std::async(std::launch::async, [&] { return mesh_remote(dispatch); });
  ASSERT_TRUE(eventually([&] {
    for (const WorkerSnapshot& w : pool->workers()) {
      if (w.address == av) return w.busy > 0 && w.leaves_done > 0;
    }
    return false;
  }));
  victim->signal(SIGSTOP);
  Result<ParallelResult> res = job.get();
  victim->signal(SIGCONT);
  ASSERT_TRUE(res.ok()) << res.status().to_string();
  expect_same_mesh(res->mesh, ref.mesh);
  const DispatchStats st = dispatch.stats();
  EXPECT_EQ(st.accepted, ref.leaf_tasks);
  EXPECT_GE(st.retried, 1U);
  EXPECT_EQ(st.attempts, st.accepted + st.retried);
  // Resumed, the worker hears it was forgotten and registers again.
  EXPECT_TRUE(eventually([&] { return pool->total_slots() == 3; }));
}

TEST_F(Workers, RegistersAgainWhenTheCoordinatorForgetsIt) {
  auto pool = WorkerPool::create(pool_options()).value();
  const std::string registry = serve_registry(pool);
  std::unique_ptr<test::Process> w;
  const std::string address = start_worker(w, {"--threads", "3", "--coordinator", registry});
  ASSERT_TRUE(eventually([&] { return pool->total_slots() == 3; }));
  const std::string first_id = pool->workers().at(0).id;
  // A restarted coordinator: a new pool on the same port knows nobody.
  registry_->Shutdown();
  registry_.reset();
  pool->stop();
  auto pool2 = WorkerPool::create(pool_options()).value();
  serve_registry(pool2, std::stoi(registry.substr(registry.rfind(':') + 1)));
  ASSERT_TRUE(eventually([&] { return pool2->total_slots() == 3; }));
  const auto ws = pool2->workers();
  ASSERT_EQ(ws.size(), 1U);
  EXPECT_EQ(ws[0].address, address);
  EXPECT_NE(ws[0].id, first_id);
}

TEST_F(Workers, DrainsOnSigtermFinishingItsLeaf) {
  const Reference& ref = reference();
  auto pool = WorkerPool::create(pool_options()).value();
  const std::string registry = serve_registry(pool);
  std::unique_ptr<test::Process> w;
  const std::string address = start_worker(w, {"--threads", "1", "--coordinator", registry, "--drain-timeout", "20"},
                                            {"PDRMESH_WORKER_TEST_LEAF_DELAY_MS=1000"});
  ASSERT_TRUE(eventually([&] { return pool->total_slots() == 1; }));
  EXPECT_EQ(health(address), 1);
  auto s = stub(address);
  auto leaf = std::async(std::launch::async, [&] { return refine(*s, header_for(ref, true), ref.sizing, ref.input); });
  // Once the leaf runs (the worker reports it busy), SIGTERM.
  ASSERT_TRUE(eventually([&] {
    grpc::ClientContext context;
    worker::add_cluster_token(context, kToken);
    v1::WorkerInfo info;
    return s->GetWorkerInfo(&context, {}, &info).ok() && info.busy_leaves() == 1;
  }));
  w->signal(SIGTERM);
  EXPECT_TRUE(eventually([&] { return pool->workers().empty(); }));  // it told the coordinator it leaves
  EXPECT_EQ(health(address), 2);                                      // NOT_SERVING while it drains
  const RawResult refused = refine(*s, header_for(ref, true), ref.sizing, ref.input);
  EXPECT_EQ(refused.status.error_code(), grpc::StatusCode::UNAVAILABLE) << refused.status.error_message();
  const RawResult r = leaf.get();
  ASSERT_TRUE(r.status.ok()) << r.status.error_message();
  EXPECT_EQ(r.output, ref.output);
  EXPECT_EQ(w->wait(), 0);
}

TEST_F(Workers, SlotsGoRoundRobinOverUsersThenFifo) {
  worker::WorkerOptions wo;
  wo.threads = 1;
  wo.cluster_token = std::string(kToken);
  auto w = worker::Worker::Start(wo).value();
  auto pool = WorkerPool::create(pool_options({w->listen_address()})).value();
  ASSERT_EQ(pool->total_slots(), 1U);
  const std::set<std::string> none;
  WorkerPool::Lease held = pool->acquire("carol", none, {}).value();
  std::mutex mu;
  std::vector<std::string> order;
  std::vector<std::thread> waiters;
  for (const std::string name : {"alice1", "alice2", "alice3", "bob1"}) {
    waiters.emplace_back([&, name] {
      WorkerPool::Lease l = pool->acquire(name.substr(0, name.size() - 1), none, {}).value();
      std::lock_guard lock(mu);
      order.push_back(name);
    });  // released at once: the next waiter gets the slot
    ASSERT_TRUE(eventually([&] { return pool->waiting() == waiters.size(); }));
  }
  held.release();
  for (auto& t : waiters) t.join();
  EXPECT_EQ(order, (std::vector<std::string>{"alice1", "bob1", "alice2", "alice3"}));
}

TEST_F(Workers, AWaitingLeafGivesUpWhenItsJobStops) {
  auto pool = WorkerPool::create(pool_options()).value();  // no workers at all
  RemoteLeafDispatch dispatch(pool);
  EXPECT_EQ(dispatch.concurrency(), 1U);
  std::atomic<bool> keep_going{true};
  auto job = std::async(std::launch::async, [&] { return mesh_remote(dispatch, &keep_going); });
  ASSERT_TRUE(eventually([&] { return pool->waiting() > 0; }));
  keep_going = false;
  Result<ParallelResult> res = job.get();
  ASSERT_FALSE(res.ok());
  EXPECT_EQ(res.status().code(), StatusCode::kCancelled) << res.status().to_string();
}

TEST_F(Workers, BadResultsGoToAnotherWorkerAndKernelErrorsDoNot) {
  const Reference& ref = reference();
  const LeafTaskInput in = LeafTaskInput::decode(ref.input).value();
  const SizingField sizing = SizingField::decode(ref.sizing).value();
  const LeafJob job{"job1", "alice", "native", [] { return true; }};
  std::unique_ptr<test::Process> good;
  const std::string good_address = start_worker(good, {"--threads", "1"});
  using Mode = FakeWorker::Mode;
  for (const Mode mode : {Mode::kGarbage, Mode::kInvalidMesh, Mode::kCutStream, Mode::kOversized}) {
    FakeWorker bad(mode, 8);  // the most free slots: tried first
    WorkerPoolOptions o = pool_options({bad.address(), good_address});
    o.failure_backoff_s = 60;
    auto pool = WorkerPool::create(o).value();
    RemoteLeafDispatch dispatch(pool);
    Result<LeafTaskOutput> out = dispatch.kernel_for(job).value()->run(in, sizing);
    ASSERT_TRUE(out.ok()) << out.status().to_string();
    EXPECT_EQ(out->encode(), ref.output);
    EXPECT_EQ(dispatch.stats().retried, 1U);
    EXPECT_EQ(dispatch.stats().accepted, 1U);
    for (const WorkerSnapshot& w : pool->workers()) {
      if (w.address != bad.address()) continue;
      EXPECT_FALSE(w.available);  // left out for a while
      EXPECT_EQ(w.failures, 1U);
      EXPECT_NE(w.last_error.find("result"), std::string::npos) << w.last_error;
      if (mode == Mode::kOversized) {
        EXPECT_NE(w.last_error.find("this leaf can hold"), std::string::npos) << w.last_error;
      }
    }
  }
  {  // Only bad workers: the attempts run out, and the error names the leaf and every worker tried.
    FakeWorker bad1(Mode::kGarbage, 1), bad2(Mode::kInvalidMesh, 1);
    WorkerPoolOptions o = pool_options({bad1.address(), bad2.address()});
    o.max_attempts = 2;
    auto pool = WorkerPool::create(o).value();
    RemoteLeafDispatch dispatch(pool);
    Result<LeafTaskOutput> out = dispatch.kernel_for(job).value()->run(in, sizing);
    ASSERT_FALSE(out.ok());
    const std::string& m = out.status().message();
    EXPECT_NE(m.find(fmt::format("leaf {}", in.leaf)), std::string::npos) << m;
    EXPECT_NE(m.find(bad1.address()), std::string::npos) << m;
    EXPECT_NE(m.find(bad2.address()), std::string::npos) << m;
  }
  {  // A kernel error is the leaf's own: the same on every worker, so no retry.
    FakeWorker failing(Mode::kKernelError, 8);
    auto pool = WorkerPool::create(pool_options({failing.address(), good_address})).value();
    RemoteLeafDispatch dispatch(pool);
    Result<LeafTaskOutput> out = dispatch.kernel_for(job).value()->run(in, sizing);
    ASSERT_FALSE(out.ok());
    EXPECT_EQ(out.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(out.status().message().find("this leaf cannot be refined"), std::string::npos);
    EXPECT_EQ(dispatch.stats().retried, 0U);
  }
}

TEST_F(Workers, ALeafOutOfMemoryFailsItsJobWithoutRetryingOrTakingTheWorkerOut) {
  std::unique_ptr<test::Process> w;
  const std::string address =
      start_worker(w, {"--threads", "2"}, {"PDRMESH_WORKER_TEST_LEAF_BAD_ALLOC=1"});
  auto pool = WorkerPool::create(pool_options({address})).value();
  RemoteLeafDispatch dispatch(pool);
  Result<ParallelResult> res = mesh_remote(dispatch);
  ASSERT_FALSE(res.ok());
  EXPECT_EQ(res.status().code(), StatusCode::kResourceExhausted) << res.status().to_string();
  const std::string& m = res.status().message();
  EXPECT_NE(m.find("out of memory while refining"), std::string::npos) << m;
  EXPECT_EQ(m.rfind("leaf ", 0), 0U) << m;  // the engine names the leaf first
  EXPECT_EQ(dispatch.stats().retried, 0U);
  // The worker lives on and stays in the pool.
  EXPECT_EQ(::kill(w->pid(), 0), 0);
  EXPECT_EQ(health(address), 1);
  const auto workers = pool->workers();
  ASSERT_EQ(workers.size(), 1U);
  EXPECT_TRUE(workers[0].available);
  EXPECT_EQ(workers[0].failures, 0U);
}

TEST_F(Workers, AJobWaitsForAWorkerToJoin) {
  const Reference& ref = reference();
  auto pool = WorkerPool::create(pool_options()).value();
  const std::string registry = serve_registry(pool);
  RemoteLeafDispatch dispatch(pool);
  auto job = std::async(std::launch::async, [&] { return mesh_remote(dispatch); });
  ASSERT_TRUE(eventually([&] { return pool->waiting() > 0; }));
  std::unique_ptr<test::Process> w;
  start_worker(w, {"--threads", "2", "--coordinator", registry});
  Result<ParallelResult> res = job.get();
  ASSERT_TRUE(res.ok()) << res.status().to_string();
  expect_same_mesh(res->mesh, ref.mesh);
  EXPECT_EQ(dispatch.stats().accepted, ref.leaf_tasks);
}

TEST_F(Workers, CoordinatorTakesRegistrationsOnItsWorkerPort) {
  std::ofstream(dir_.path() / "tokens") << "alice tok-alice\n";
  Options o;
  o.data_dir = dir_.path() / "data";
  o.tokens_file = dir_.path() / "tokens";
  o.worker_listen_address = "127.0.0.1:0";
  EXPECT_FALSE(Coordinator::BuildAndStart(o).ok());  // no cluster token
  o.cluster_token_file = dir_.path() / "cluster-token";
  auto c = Coordinator::BuildAndStart(o);
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  ASSERT_GT((*c)->worker_port(), 0);
  ASSERT_NE((*c)->remote_dispatch(), nullptr);
  const std::string registry = fmt::format("127.0.0.1:{}", (*c)->worker_port());
  EXPECT_EQ(health(registry), 1);
  EXPECT_NE(reflection_list(registry).find("pdrmesh.v1.WorkerRegistry"), std::string::npos);
  std::unique_ptr<test::Process> w;
  start_worker(w, {"--threads", "2", "--coordinator", registry});
  EXPECT_TRUE(eventually([&] { return (*c)->remote_dispatch()->concurrency() == 2; }));
  // Without any worker option the coordinator has no remote dispatch.
  Options plain;
  plain.data_dir = dir_.path() / "data2";
  plain.tokens_file = o.tokens_file;
  auto c2 = Coordinator::BuildAndStart(plain);
  ASSERT_TRUE(c2.ok()) << c2.status().to_string();
  EXPECT_EQ((*c2)->remote_dispatch(), nullptr);
  EXPECT_EQ((*c2)->worker_port(), 0);
}

TEST_F(Workers, MutualTlsBetweenCoordinatorAndWorker) {
  const Reference& ref = reference();
  if (!make_certificates(dir_.path(), "a") || !make_certificates(dir_.path(), "b")) GTEST_SKIP() << "no openssl";
  const auto tls = [&](const std::string& n, const std::string& ca) {
    return worker::TlsFiles{dir_.path() / (n + ".pem"), dir_.path() / (n + ".key"), dir_.path() / (ca + "-ca.pem"),
                            {}};
  };
  std::ofstream(dir_.path() / "tokens") << "alice tok-alice\n";
  Options o;
  o.data_dir = dir_.path() / "data";
  o.tokens_file = dir_.path() / "tokens";
  o.worker_listen_address = "127.0.0.1:0";
  o.cluster_token_file = dir_.path() / "cluster-token";
  const worker::TlsFiles a = tls("a", "a");
  o.worker_tls_cert_file = a.cert;
  o.worker_tls_key_file = a.key;
  EXPECT_FALSE(Coordinator::BuildAndStart(o).ok());  // two of three TLS files
  o.worker_tls_ca_file = a.ca;
  auto c = Coordinator::BuildAndStart(o);
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  // The worker registers over mutual TLS, and the coordinator dials it over mutual TLS.
  worker::WorkerOptions wo;
  wo.threads = 1;
  wo.cluster_token = std::string(kToken);
  wo.tls = a;
  wo.coordinator_address = fmt::format("127.0.0.1:{}", (*c)->worker_port());
  auto w = worker::Worker::Start(wo).value();
  ASSERT_TRUE(eventually([&] { return (*c)->remote_dispatch()->concurrency() == 1 && w->stats().registered; }));
  LeafJob job{"job1", "alice", "native", [] { return true; }};
  auto kernel = (*c)->remote_dispatch()->kernel_for(job).value();
  const SizingField sizing = SizingField::decode(ref.sizing).value();
  Result<LeafTaskOutput> out = kernel->run(LeafTaskInput::decode(ref.input).value(), sizing);
  ASSERT_TRUE(out.ok()) << out.status().to_string();
  EXPECT_EQ(out->encode(), ref.output);
  // A plaintext caller, and one whose certificate another CA signed, get nothing.
  for (const worker::TlsFiles& other : {worker::TlsFiles{}, tls("b", "a")}) {
    WorkerPoolOptions po = pool_options({w->listen_address()});
    po.tls = other;
    auto pool = WorkerPool::create(po).value();
    EXPECT_EQ(pool->total_slots(), 0U);
  }
  // A worker that trusts another CA cannot register.
  wo.tls = tls("a", "b");
  wo.coordinator_address = fmt::format("127.0.0.1:{}", (*c)->worker_port());
  auto stranger = worker::Worker::Start(wo).value();
  std::this_thread::sleep_for(300ms);  // a few registration attempts (a positive result would show at once)
  EXPECT_FALSE(stranger->stats().registered);
}

TEST_F(Workers, MutualTlsChecksAFixedWorkerNameWhenAsked) {
  // The worker's certificate names only "pdrmesh-worker" (as on Kubernetes,
  // where workers are dialled by pod IP): dialling 127.0.0.1 fails the name
  // check unless the pool checks that fixed name instead.
  if (!make_certificates(dir_.path(), "c") || !make_certificates(dir_.path(), "w", "DNS:pdrmesh-worker")) {
    GTEST_SKIP() << "no openssl";
  }
  const auto file = [&](const std::string& n) { return dir_.path() / n; };
  worker::WorkerOptions wo;
  wo.threads = 1;
  wo.cluster_token = std::string(kToken);
  wo.tls = {file("w.pem"), file("w.key"), file("c-ca.pem"), {}};  // trusts the coordinator's CA
  auto w = worker::Worker::Start(wo).value();
  WorkerPoolOptions po = pool_options({w->listen_address()});
  po.tls = {file("c.pem"), file("c.key"), file("w-ca.pem"), {}};
  EXPECT_EQ(WorkerPool::create(po).value()->total_slots(), 0U);  // 127.0.0.1 is not in the certificate
  po.tls.server_name = "pdrmesh-worker";
  auto pool = WorkerPool::create(po).value();
  ASSERT_TRUE(eventually([&] { return pool->total_slots() == 1; }));
}

}  // namespace
}  // namespace pdrmesh::server
