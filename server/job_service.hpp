// SPDX-License-Identifier: AGPL-3.0-or-later
// The gRPC JobService: decode the request, authenticate, call JobManager,
// encode the answer. Every pdrmesh::Status becomes a grpc::Status in one
// function (to_grpc_status).
#pragma once

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <string>

#include "call_limits.hpp"
#include "job_manager.hpp"
#include "pdrmesh/v1/pdrmesh.grpc.pb.h"
#include "tokens.hpp"

namespace pdrmesh::server {

/// The longest message a client sees; longer ones are cut and say so.
inline constexpr std::size_t kMaxStatusMessage = 2000;
/// Size of the file chunks sent to clients.
inline constexpr std::size_t kChunkBytes = 1 << 20;

/// invalid_input/unsupported -> INVALID_ARGUMENT, not_found -> NOT_FOUND,
/// resource_exhausted -> RESOURCE_EXHAUSTED, deadline_exceeded ->
/// DEADLINE_EXCEEDED, io_error/internal -> INTERNAL; the message truncated to
/// kMaxStatusMessage bytes.
grpc::Status to_grpc_status(const Status& status);

void to_proto(const JobRecord& job, v1::Job& out);
void to_proto(const JobOptions& options, v1::MeshOptions& out);
/// The job options a client asked for, over `defaults` (the coordinator's time
/// limit); invalid_input naming the first option out of range.
Result<JobOptions> from_proto(const v1::MeshOptions& in, JobOptions defaults);

class JobServiceImpl final : public v1::JobService::Service {
 public:
  /// max_streams: streaming calls of all users together (stream_limit_for_threads).
  JobServiceImpl(JobManager& manager, const TokenTable& tokens, const std::atomic<bool>& stopping,
                 double max_watch_s, int max_streams)
      : manager_(manager),
        tokens_(tokens),
        stopping_(stopping),
        max_watch_s_(max_watch_s),
        streams_(manager.config().limits.max_open_streams, max_streams) {}

  grpc::Status SubmitJob(grpc::ServerContext* context, grpc::ServerReader<v1::SubmitRequest>* reader,
                         v1::Job* response) override;
  grpc::Status GetJob(grpc::ServerContext* context, const v1::GetJobRequest* request, v1::Job* response) override;
  grpc::Status WatchJob(grpc::ServerContext* context, const v1::WatchJobRequest* request,
                        grpc::ServerWriter<v1::JobEvent>* writer) override;
  grpc::Status ListJobs(grpc::ServerContext* context, const v1::ListJobsRequest* request,
                        v1::ListJobsResponse* response) override;
  grpc::Status CancelJob(grpc::ServerContext* context, const v1::CancelJobRequest* request,
                         v1::Job* response) override;
  grpc::Status DeleteJob(grpc::ServerContext* context, const v1::DeleteJobRequest* request,
                         v1::Job* response) override;
  grpc::Status FetchResult(grpc::ServerContext* context, const v1::FetchRequest* request,
                           grpc::ServerWriter<v1::ResultChunk>* writer) override;

 private:
  /// The caller's user name, or UNAUTHENTICATED.
  grpc::Status authenticate(const grpc::ServerContext& context, std::string& user) const;
  /// A stream slot of `user`, or RESOURCE_EXHAUSTED naming the limit.
  grpc::Status open_stream(const std::string& user, StreamCounter::Slot& slot);

  JobManager& manager_;
  const TokenTable& tokens_;
  const std::atomic<bool>& stopping_;
  double max_watch_s_;
  CallWatchdog watchdog_;
  StreamCounter streams_;
};

}  // namespace pdrmesh::server
