// SPDX-License-Identifier: AGPL-3.0-or-later
// Shared pieces of the worker-facing protocol (see leaf_rpc.hpp).
#include "leaf_rpc.hpp"

#include <fmt/format.h>
#include <grpcpp/grpcpp.h>

#include <fstream>
#include <iterator>

namespace pdrmesh::worker {
namespace {

Result<std::string> read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return not_found(fmt::format("{}: cannot open", path.string()));
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

bool same_secret(std::string_view a, std::string_view b) {
  // Time depends on the lengths only, not on where the first difference is.
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  const std::size_t n = a.size() < b.size() ? a.size() : b.size();
  for (std::size_t i = 0; i < n; ++i) diff = static_cast<unsigned char>(diff | (a[i] ^ b[i]));
  return diff == 0;
}

}  // namespace

std::string_view pdrmesh_version() { return PDRMESH_VERSION; }

StatusCode status_code_from_name(std::string_view name) {
  for (int c = static_cast<int>(StatusCode::kInvalidInput); c <= static_cast<int>(StatusCode::kInternal); ++c) {
    if (to_string(static_cast<StatusCode>(c)) == name) return static_cast<StatusCode>(c);
  }
  return StatusCode::kInternal;
}

Result<std::string> read_cluster_token(const std::filesystem::path& path) {
  PDR_ASSIGN_OR_RETURN(std::string text, read_file(path));
  const std::size_t eol = text.find('\n');
  std::string_view line = std::string_view(text).substr(0, eol);
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.remove_suffix(1);
  while (!line.empty() && (line.front() == ' ' || line.front() == '\t')) line.remove_prefix(1);
  if (line.size() < 16) {
    return invalid_input(fmt::format("{}: the cluster token must be one line of at least 16 characters (got {})",
                                     path.string(), line.size()));
  }
  return std::string(line);
}

void add_cluster_token(grpc::ClientContext& context, std::string_view token) {
  context.AddMetadata("authorization", fmt::format("Bearer {}", token));
}

grpc::Status check_cluster_token(const grpc::ServerContext& context, std::string_view token) {
  const auto& md = context.client_metadata();
  const auto it = md.find("authorization");
  if (it == md.end()) {
    return {grpc::StatusCode::UNAUTHENTICATED, "no cluster token (authorization: Bearer <token> metadata)"};
  }
  const std::string_view value(it->second.data(), it->second.size());
  constexpr std::string_view kBearer = "Bearer ";
  if (value.substr(0, kBearer.size()) != kBearer || !same_secret(value.substr(kBearer.size()), token)) {
    return {grpc::StatusCode::UNAUTHENTICATED, "wrong cluster token"};
  }
  return grpc::Status::OK;
}

bool is_loopback_address(std::string_view address) {
  if (address.substr(0, 5) == "unix:") return true;
  const auto colon = address.rfind(':');
  const std::string_view host = address.substr(0, colon);
  return host == "localhost" || host == "[::1]" || host.substr(0, 4) == "127.";
}

Status TlsFiles::check(std::string_view what) const {
  const int given = int{!cert.empty()} + int{!key.empty()} + int{!ca.empty()};
  if (given != 0 && given != 3) {
    return invalid_input(fmt::format("mutual TLS {} needs a certificate, a key and a CA file (got {} of 3)", what, given));
  }
  return {};
}

Result<std::shared_ptr<grpc::ServerCredentials>> server_credentials(const TlsFiles& tls) {
  if (!tls.enabled()) return grpc::InsecureServerCredentials();
  PDR_TRY(tls.check("on a server"));
  PDR_ASSIGN_OR_RETURN(std::string cert, read_file(tls.cert));
  PDR_ASSIGN_OR_RETURN(std::string key, read_file(tls.key));
  PDR_ASSIGN_OR_RETURN(std::string ca, read_file(tls.ca));
  grpc::SslServerCredentialsOptions ssl(GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
  ssl.pem_root_certs = std::move(ca);
  ssl.pem_key_cert_pairs.push_back({std::move(key), std::move(cert)});
  return grpc::SslServerCredentials(ssl);
}

Result<std::shared_ptr<grpc::ChannelCredentials>> channel_credentials(const TlsFiles& tls) {
  if (!tls.enabled()) return grpc::InsecureChannelCredentials();
  PDR_TRY(tls.check("on a client"));
  grpc::SslCredentialsOptions ssl;
  PDR_ASSIGN_OR_RETURN(ssl.pem_cert_chain, read_file(tls.cert));
  PDR_ASSIGN_OR_RETURN(ssl.pem_private_key, read_file(tls.key));
  PDR_ASSIGN_OR_RETURN(ssl.pem_root_certs, read_file(tls.ca));
  return grpc::SslCredentials(ssl);
}

std::shared_ptr<grpc::Channel> make_channel(const std::string& address,
                                            const std::shared_ptr<grpc::ChannelCredentials>& credentials,
                                            const std::string& server_name) {
  grpc::ChannelArguments args;
  if (!server_name.empty()) args.SetSslTargetNameOverride(server_name);
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 200);
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 200);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 2000);
  return grpc::CreateCustomChannel(address, credentials, args);
}

std::string with_port(std::string_view listen_address, int port) {
  const auto colon = listen_address.rfind(':');
  return fmt::format("{}:{}", listen_address.substr(0, colon), port);
}

}  // namespace pdrmesh::worker
