// SPDX-License-Identifier: AGPL-3.0-or-later
// What the worker daemon and the coordinator's worker pool share about the
// worker-facing protocol (proto/pdrmesh/v1/pdrmesh.proto, WorkerService and
// WorkerRegistry): chunk size and bounds, the sizing field's content digest,
// the cluster token (file, metadata, check) and the credentials of both
// directions (plaintext or mutual TLS).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

#include "pdrmesh/digest.hpp"
#include "pdrmesh/status.hpp"

namespace grpc {
class Channel;
class ChannelCredentials;
class ClientContext;
class ServerContext;
class ServerCredentials;
class Status;
}  // namespace grpc

namespace pdrmesh::worker {

/// Largest chunk of any payload (task, sizing field, result).
inline constexpr std::size_t kChunkBytes = std::size_t{1} << 20;
/// A worker's default bounds on what it accepts.
inline constexpr std::uint64_t kDefaultMaxInputBytes = std::uint64_t{256} << 20;
inline constexpr std::uint64_t kDefaultMaxSizingBytes = std::uint64_t{1} << 30;
/// Prefix of the FAILED_PRECONDITION message a worker sends when it lacks the sizing field.
inline constexpr std::string_view kSizingUnknown = "sizing unknown";

/// The pdrmesh version both sides compare (PROJECT_VERSION).
std::string_view pdrmesh_version();

/// The sizing field's digest on the wire (pdrmesh/digest.hpp).
using pdrmesh::content_digest;

/// The StatusCode whose to_string() is `name` (LeafError.code on the wire);
/// kInternal for an unknown name.
StatusCode status_code_from_name(std::string_view name);

/// The cluster secret: the file's first line without surrounding blanks;
/// invalid_input when it is empty or shorter than 16 characters, not_found
/// when the file cannot be read.
Result<std::string> read_cluster_token(const std::filesystem::path& path);

/// Adds `authorization: Bearer <token>` to an outgoing call.
void add_cluster_token(grpc::ClientContext& context, std::string_view token);

/// OK when the call carries `authorization: Bearer <token>` (compared in time
/// independent of where the first difference is); UNAUTHENTICATED otherwise.
grpc::Status check_cluster_token(const grpc::ServerContext& context, std::string_view token);

/// True for 127.0.0.0/8, localhost, [::1] and unix: addresses.
bool is_loopback_address(std::string_view address);

/// PEM files of mutual TLS: our certificate chain and key, and the CA that
/// signs the peers' certificates. All three or none.
struct TlsFiles {
  std::filesystem::path cert, key, ca;
  /// Client side: the name the peer's certificate must carry, instead of the
  /// host dialled (workers on Kubernetes are dialled by pod IP and share one
  /// certificate issued for a fixed name). Empty: the host dialled.
  std::string server_name;
  bool enabled() const { return !cert.empty(); }
  /// invalid_input unless all three or none are given.
  Status check(std::string_view what) const;
};

/// Server side: plaintext without TLS; with it, our cert and key, and peers
/// must present a certificate signed by the CA.
Result<std::shared_ptr<grpc::ServerCredentials>> server_credentials(const TlsFiles& tls);
/// Client side: plaintext without TLS; with it, the peer must be signed by the
/// CA and we present our cert and key.
Result<std::shared_ptr<grpc::ChannelCredentials>> channel_credentials(const TlsFiles& tls);
/// A channel with short reconnect backoff (a restarted peer is found within ~2 s);
/// with a TLS `server_name`, the peer's certificate is checked against it.
std::shared_ptr<grpc::Channel> make_channel(const std::string& address,
                                            const std::shared_ptr<grpc::ChannelCredentials>& credentials,
                                            const std::string& server_name = {});

/// "host:port" of a listen address with the port a server bound ("0.0.0.0:0", 4711 -> "0.0.0.0:4711").
std::string with_port(std::string_view listen_address, int port);

}  // namespace pdrmesh::worker
