// SPDX-License-Identifier: AGPL-3.0-or-later
// The gRPC JobService adapter (synchronous API: one server thread per call).
#include "job_service.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <fstream>

#include "layers_proto.hpp"

namespace pdrmesh::server {
namespace {

v1::JobState to_proto(JobState s) {
  switch (s) {
    case JobState::kQueued: return v1::JOB_STATE_QUEUED;
    case JobState::kRunning: return v1::JOB_STATE_RUNNING;
    case JobState::kSucceeded: return v1::JOB_STATE_SUCCEEDED;
    case JobState::kFailed: return v1::JOB_STATE_FAILED;
    case JobState::kCancelled: return v1::JOB_STATE_CANCELLED;
  }
  return v1::JOB_STATE_UNSPECIFIED;
}

double elapsed_s(const JobRecord& j) {
  if (j.started_ms == 0) return 0;
  const std::int64_t end = j.finished_ms != 0 ? j.finished_ms : now_unix_ms();
  return static_cast<double>(end - j.started_ms) / 1000.0;
}

}  // namespace

grpc::Status to_grpc_status(const Status& status) {
  grpc::StatusCode code = grpc::StatusCode::INTERNAL;
  switch (status.code()) {
    case StatusCode::kOk: return grpc::Status::OK;
    case StatusCode::kInvalidInput:
    case StatusCode::kUnsupported: code = grpc::StatusCode::INVALID_ARGUMENT; break;
    case StatusCode::kNotFound: code = grpc::StatusCode::NOT_FOUND; break;
    case StatusCode::kResourceExhausted: code = grpc::StatusCode::RESOURCE_EXHAUSTED; break;
    case StatusCode::kDeadlineExceeded: code = grpc::StatusCode::DEADLINE_EXCEEDED; break;
    case StatusCode::kCancelled: code = grpc::StatusCode::CANCELLED; break;
    case StatusCode::kIoError:
    case StatusCode::kInternal: code = grpc::StatusCode::INTERNAL; break;
  }
  std::string message = status.message();
  if (message.size() > kMaxStatusMessage) {
    const std::size_t cut = message.size() - kMaxStatusMessage;
    message.resize(kMaxStatusMessage);
    message += fmt::format(" ... ({} more bytes)", cut);
  }
  return {code, message};
}

void to_proto(const JobRecord& job, v1::Job& out) {
  out.Clear();
  out.set_id(job.id);
  out.set_user(job.user);
  out.set_state(to_proto(job.state));
  out.set_phase(job.phase);
  out.set_progress(job.progress);
  if (auto o = JobOptions::from_json(job.options_json); o.ok()) to_proto(*o, *out.mutable_options());
  out.set_input_name(job.input_name);
  out.set_input_bytes(job.input_bytes);
  out.set_created_unix_ms(job.created_ms);
  out.set_started_unix_ms(job.started_ms);
  out.set_finished_unix_ms(job.finished_ms);
  out.set_error(job.error);
  out.set_tets(job.tets);
  out.set_points(job.points);
  out.set_leaves_done(job.leaves_done);
  out.set_leaves_total(job.leaves_total);
}

void to_proto(const JobOptions& o, v1::MeshOptions& out) {
  out.Clear();
  if (o.max_volume) out.set_max_volume(*o.max_volume);
  out.set_time_limit_s(o.time_limit_s);
  if (o.sizing.size) out.set_size(*o.sizing.size);
  if (o.sizing.hmin) out.set_hmin(*o.sizing.hmin);
  if (o.sizing.hmax) out.set_hmax(*o.sizing.hmax);
  out.set_growth(o.sizing.growth);
  if (o.depth >= 0) out.set_depth(o.depth);
  out.set_kernel(o.kernel);
  out.set_interface_round(o.interface_round);
  out.set_optimize(o.optimize);
  for (const auto& [id, name] : o.surface_names) (*out.mutable_surface_names())[id] = name;
  if (o.farfield) {
    out.set_farfield(o.farfield->distance);
    out.set_farfield_shape(std::string(to_string(o.farfield->shape)));
  }
  if (o.layers) pdrmesh::to_proto(*o.layers, *out.mutable_layers());
}

Result<JobOptions> from_proto(const v1::MeshOptions& in, JobOptions o) {
  if (in.has_max_volume()) o.max_volume = in.max_volume();
  if (in.has_time_limit_s()) o.time_limit_s = in.time_limit_s();
  if (in.has_size()) o.sizing.size = in.size();
  if (in.has_hmin()) o.sizing.hmin = in.hmin();
  if (in.has_hmax()) o.sizing.hmax = in.hmax();
  if (in.has_growth()) o.sizing.growth = in.growth();
  if (in.has_depth()) {
    if (in.depth() < 0) return invalid_input(fmt::format("job option depth must be 0..10 (or unset), got {}", in.depth()));
    o.depth = in.depth();
  }
  if (in.has_kernel()) o.kernel = in.kernel();
  if (in.has_interface_round()) o.interface_round = in.interface_round();
  if (in.has_optimize()) o.optimize = in.optimize();
  for (const auto& [id, name] : in.surface_names()) o.surface_names[id] = name;
  if (in.has_farfield_shape() && !in.has_farfield())
    return invalid_input("job option farfield_shape: only with farfield (the distance in body lengths)");
  if (in.has_farfield()) {
    o.farfield = FarfieldOptions{in.farfield(), FarfieldShape::kBox};
    if (in.has_farfield_shape()) {
      const auto shape = parse_farfield_shape(in.farfield_shape());
      if (!shape)
        return invalid_input(fmt::format("job option farfield_shape must be 'box' or 'sphere', got '{}'",
                                         in.farfield_shape()));
      o.farfield->shape = *shape;
    }
  }
  if (in.has_layers()) {
    PDR_ASSIGN_OR_RETURN(o.layers, pdrmesh::from_proto(in.layers()));
    // The tets' growth continues the layers' unless the job sets its own.
    if (!in.has_growth() && o.layers->growth_ratio > 1) o.sizing.growth = o.layers->growth_ratio;
  }
  PDR_TRY(o.validate());
  return o;
}

grpc::Status JobServiceImpl::authenticate(const grpc::ServerContext& context, std::string& user) const {
  const auto& md = context.client_metadata();
  const auto it = md.find("authorization");
  if (it == md.end()) return {grpc::StatusCode::UNAUTHENTICATED, "no 'authorization: Bearer <token>' metadata"};
  const auto token = bearer_token(std::string_view(it->second.data(), it->second.size()));
  const auto found = token ? tokens_.user_for(*token) : std::nullopt;
  if (!found) return {grpc::StatusCode::UNAUTHENTICATED, "unknown token"};
  user = *found;
  return grpc::Status::OK;
}

grpc::Status JobServiceImpl::open_stream(const std::string& user, StreamCounter::Slot& slot) {
  StreamCounter::Full why = StreamCounter::Full::kUser;
  slot = streams_.try_open(user, &why);
  if (slot) return grpc::Status::OK;
  if (why == StreamCounter::Full::kServer) {
    return {grpc::StatusCode::RESOURCE_EXHAUSTED,
            fmt::format("the server has {} streams (uploads, watches, downloads) open, its limit (three quarters "
                        "of --max-server-threads); try again later",
                        streams_.max_total())};
  }
  return {grpc::StatusCode::RESOURCE_EXHAUSTED,
          fmt::format("user {} has {} streams (uploads, watches, downloads) open, the limit (--max-open-streams); "
                      "close one first",
                      user, streams_.max_per_user())};
}

grpc::Status JobServiceImpl::SubmitJob(grpc::ServerContext* context, grpc::ServerReader<v1::SubmitRequest>* reader,
                                       v1::Job* response) {
  std::string user;
  if (auto s = authenticate(*context, user); !s.ok()) return s;
  StreamCounter::Slot slot;
  if (auto s = open_stream(user, slot); !s.ok()) return s;
  const double max_upload_s = manager_.config().limits.max_upload_s;
  v1::SubmitHeader header;
  JobOptions options;
  std::string bytes;
  {  // The upload limit covers the bytes' arrival; checking and estimating them is the coordinator's time.
    const CallWatchdog::Guard guard = watchdog_.watch(context, max_upload_s);
    v1::SubmitRequest msg;
    const auto too_slow = [&](std::uint64_t got, std::uint64_t announced) {
      return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED,
                          fmt::format("the upload took longer than {} s (--max-upload-seconds); {} of {} bytes arrived",
                                      max_upload_s, got, announced));
    };
    if (!reader->Read(&msg) || !msg.has_header()) {
      if (guard.fired()) return too_slow(0, 0);
      return {grpc::StatusCode::INVALID_ARGUMENT, "the first message must be the header (file name, size, options)"};
    }
    header = msg.header();
    if (auto s = manager_.admit(user, header.total_bytes()); !s.ok()) return to_grpc_status(s);
    JobOptions defaults;
    defaults.time_limit_s = manager_.config().default_time_limit_s;
    auto parsed = from_proto(header.options(), defaults);
    if (!parsed.ok()) return to_grpc_status(parsed.status());
    options = std::move(parsed).value();
    bytes.reserve(static_cast<std::size_t>(header.total_bytes()));  // admitted: within the upload limit
    while (reader->Read(&msg)) {
      if (!msg.has_chunk() && msg.has_header()) return {grpc::StatusCode::INVALID_ARGUMENT, "a second header"};
      if (bytes.size() + msg.chunk().size() > header.total_bytes()) {
        return {grpc::StatusCode::INVALID_ARGUMENT,
                fmt::format("more bytes than the {} announced in the header", header.total_bytes())};
      }
      bytes += msg.chunk();
    }
    if (guard.fired()) return too_slow(bytes.size(), header.total_bytes());
    if (context->IsCancelled()) return {grpc::StatusCode::CANCELLED, "the client cancelled the upload"};
    if (bytes.size() != header.total_bytes()) {
      return {grpc::StatusCode::INVALID_ARGUMENT,
              fmt::format("received {} bytes, the header announced {}", bytes.size(), header.total_bytes())};
    }
  }
  auto job = manager_.submit(user, header.file_name(), bytes, options);
  if (!job.ok()) return to_grpc_status(job.status());
  to_proto(*job, *response);
  return grpc::Status::OK;
}

grpc::Status JobServiceImpl::GetJob(grpc::ServerContext* context, const v1::GetJobRequest* request,
                                    v1::Job* response) {
  std::string user;
  if (auto s = authenticate(*context, user); !s.ok()) return s;
  auto job = manager_.get(user, request->job_id());
  if (!job.ok()) return to_grpc_status(job.status());
  to_proto(*job, *response);
  return grpc::Status::OK;
}

grpc::Status JobServiceImpl::WatchJob(grpc::ServerContext* context, const v1::WatchJobRequest* request,
                                      grpc::ServerWriter<v1::JobEvent>* writer) {
  std::string user;
  if (auto s = authenticate(*context, user); !s.ok()) return s;
  StreamCounter::Slot slot;
  if (auto s = open_stream(user, slot); !s.ok()) return s;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(max_watch_s_);
  std::string last_sent;
  for (;;) {
    const std::uint64_t seen = manager_.changes().version();
    auto job = manager_.get(user, request->job_id());
    if (!job.ok()) return to_grpc_status(job.status());
    v1::JobEvent event;
    to_proto(*job, *event.mutable_job());
    const std::string key = event.job().SerializeAsString();
    if (key != last_sent) {  // elapsed alone is no change
      event.set_elapsed_s(elapsed_s(*job));
      if (!writer->Write(event)) return {grpc::StatusCode::CANCELLED, "the client went away"};
      last_sent = key;
    }
    if (is_final(job->state)) return grpc::Status::OK;
    if (context->IsCancelled()) return {grpc::StatusCode::CANCELLED, "the client cancelled the watch"};
    if (stopping_) return {grpc::StatusCode::UNAVAILABLE, "the coordinator is shutting down; watch again"};
    if (std::chrono::steady_clock::now() > end) {
      return {grpc::StatusCode::DEADLINE_EXCEEDED, "watch streams last at most max_watch_s; watch again"};
    }
    manager_.changes().wait(seen, std::chrono::milliseconds(500));
  }
}

grpc::Status JobServiceImpl::ListJobs(grpc::ServerContext* context, const v1::ListJobsRequest* /*request*/,
                                      v1::ListJobsResponse* response) {
  std::string user;
  if (auto s = authenticate(*context, user); !s.ok()) return s;
  auto jobs = manager_.list(user);
  if (!jobs.ok()) return to_grpc_status(jobs.status());
  for (const JobRecord& j : *jobs) to_proto(j, *response->add_jobs());
  return grpc::Status::OK;
}

grpc::Status JobServiceImpl::CancelJob(grpc::ServerContext* context, const v1::CancelJobRequest* request,
                                       v1::Job* response) {
  std::string user;
  if (auto s = authenticate(*context, user); !s.ok()) return s;
  auto job = manager_.cancel(user, request->job_id());
  if (!job.ok()) return to_grpc_status(job.status());
  to_proto(*job, *response);
  return grpc::Status::OK;
}

grpc::Status JobServiceImpl::DeleteJob(grpc::ServerContext* context, const v1::DeleteJobRequest* request,
                                       v1::Job* response) {
  std::string user;
  if (auto s = authenticate(*context, user); !s.ok()) return s;
  auto job = manager_.remove(user, request->job_id());
  if (!job.ok()) return to_grpc_status(job.status());
  to_proto(*job, *response);
  return grpc::Status::OK;
}

grpc::Status JobServiceImpl::FetchResult(grpc::ServerContext* context, const v1::FetchRequest* request,
                                         grpc::ServerWriter<v1::ResultChunk>* writer) {
  std::string user;
  if (auto s = authenticate(*context, user); !s.ok()) return s;
  StreamCounter::Slot slot;
  if (auto s = open_stream(user, slot); !s.ok()) return s;
  auto job = manager_.get(user, request->job_id());
  if (!job.ok()) return to_grpc_status(job.status());
  if (job->state != JobState::kSucceeded) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            fmt::format("job {} is {}; only a succeeded job has a result", job->id, to_string(job->state))};
  }
  auto suffix = volume_suffix(request->format());
  if (!suffix.ok()) return to_grpc_status(suffix.status());
  auto path = manager_.result_file(user, request->job_id(), request->format());
  if (!path.ok()) return to_grpc_status(path.status());
  std::ifstream in(*path, std::ios::binary);
  std::error_code ec;
  const auto size = std::filesystem::file_size(*path, ec);
  if (!in || ec) return to_grpc_status(io_error(fmt::format("job {}: cannot open the result", job->id)));
  v1::ResultChunk chunk;
  chunk.mutable_header()->set_file_name(job->id + *suffix);
  chunk.mutable_header()->set_total_bytes(size);
  if (!writer->Write(chunk)) return {grpc::StatusCode::CANCELLED, "the client went away"};
  std::string buffer(kChunkBytes, '\0');
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    const auto n = static_cast<std::size_t>(in.gcount());
    if (n == 0) break;
    chunk.set_data(buffer.data(), n);
    if (!writer->Write(chunk)) return {grpc::StatusCode::CANCELLED, "the client went away"};
  }
  if (in.bad()) return to_grpc_status(io_error(fmt::format("job {}: reading the result failed", job->id)));
  return grpc::Status::OK;
}

}  // namespace pdrmesh::server
