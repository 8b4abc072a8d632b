// SPDX-License-Identifier: AGPL-3.0-or-later
// ServiceClient: the pdrmesh CLI's (and the tests') side of JobService. Every
// call carries the bearer token and a deadline; files travel in 1 MiB chunks.
// Errors are grpc::Status (this is the edge): local file problems come back as
// NOT_FOUND (cannot read the surface) or DATA_LOSS (cannot write the result).
#pragma once

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "pdrmesh/v1/pdrmesh.grpc.pb.h"

namespace pdrmesh::cli {

struct ClientConfig {
  std::string server;       ///< host:port
  std::string token;        ///< bearer token; empty: none is sent
  std::string tls_ca_file;  ///< PEM roots; empty: plaintext
  double timeout_s = 120;   ///< deadline of each call (watches: watch_timeout_s)
  double watch_timeout_s = 24 * 3600;
};

/// The volume format (suffix without the dot, e.g. "lb8.ugrid") named by the
/// end of `path`; empty when none matches.
std::string volume_format_of(const std::filesystem::path& path);

class ServiceClient {
 public:
  /// Fails (INVALID_ARGUMENT) only when the CA file cannot be read.
  static grpc::Status connect(const ClientConfig& config, std::unique_ptr<ServiceClient>& out);

  grpc::Status submit(const std::filesystem::path& surface, const v1::MeshOptions& options, v1::Job& job);
  grpc::Status get(std::string_view id, v1::Job& job);
  /// Calls `on_event` for each event; `last` is the final one. Ends when the job
  /// is final (OK) or the stream fails.
  grpc::Status watch(std::string_view id, const std::function<void(const v1::JobEvent&)>& on_event,
                     v1::Job& last);
  grpc::Status list(v1::ListJobsResponse& jobs);
  grpc::Status cancel(std::string_view id, v1::Job& job);
  /// DeleteJob: the record and files go; `job` is the job as it was.
  grpc::Status remove(std::string_view id, v1::Job& job);
  /// Writes the result in the format named by `out`'s suffix (via a temporary
  /// file renamed into place); a UGRID result's .mapbc (its boundary names)
  /// goes beside it (mapbc_path). CGNS and a polyMesh directory, which the
  /// coordinator does not serve, are written here from the job's VTU (names
  /// and regions included), as `pdrmesh mesh -o` writes them. `bytes`: the
  /// mesh file's size (a polyMesh's files together).
  grpc::Status fetch(std::string_view id, const std::filesystem::path& out, std::uint64_t* bytes = nullptr);

 private:
  /// A written-only format (CGNS, polyMesh): the VTU fetched beside `out`, read, written as `out`.
  grpc::Status fetch_converted(std::string_view id, const std::filesystem::path& out, std::uint64_t* bytes);
  /// One FetchResult call: the result in `format` into `out`.
  grpc::Status fetch_format(std::string_view id, const std::string& format, const std::filesystem::path& out,
                            std::uint64_t* bytes);
  ServiceClient(ClientConfig config, std::shared_ptr<grpc::Channel> channel);
  void prepare(grpc::ClientContext& context, double timeout_s) const;

  ClientConfig config_;
  std::unique_ptr<v1::JobService::Stub> stub_;
};

}  // namespace pdrmesh::cli
