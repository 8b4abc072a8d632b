// SPDX-License-Identifier: AGPL-3.0-or-later
// ServiceClient: chunked upload and download, deadlines, the bearer token.
#include "service_client.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <fstream>
#include <iterator>

#include <unistd.h>

#include "pdrmesh/volume_io.hpp"

namespace pdrmesh::cli {
namespace {

constexpr std::size_t kChunkBytes = 1 << 20;

}  // namespace

std::string volume_format_of(const std::filesystem::path& path) {
  // Longest first: ".lb8.ugrid" before ".ugrid", ".meshb" before ".mesh".
  static constexpr std::array<std::string_view, 8> kSuffixes = {".lb8.ugrid", ".b8.ugrid", ".ugrid", ".meshb",
                                                                ".mesh",      ".vtu",      ".msh",   ".su2"};
  std::string name = path.filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
  for (std::string_view s : kSuffixes) {
    if (name.size() > s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0) {
      return std::string(s.substr(1));
    }
  }
  return {};
}

grpc::Status ServiceClient::connect(const ClientConfig& config, std::unique_ptr<ServiceClient>& out) {
  std::shared_ptr<grpc::ChannelCredentials> creds = grpc::InsecureChannelCredentials();
  if (!config.tls_ca_file.empty()) {
    std::ifstream in(config.tls_ca_file, std::ios::binary);
    if (!in) return {grpc::StatusCode::INVALID_ARGUMENT, config.tls_ca_file + ": cannot open the CA file"};
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    creds = grpc::SslCredentials(ssl);
  }
  out.reset(new ServiceClient(config, grpc::CreateChannel(config.server, creds)));
  return grpc::Status::OK;
}

ServiceClient::ServiceClient(ClientConfig config, std::shared_ptr<grpc::Channel> channel)
    : config_(std::move(config)), stub_(v1::JobService::NewStub(channel)) {}

void ServiceClient::prepare(grpc::ClientContext& context, double timeout_s) const {
  context.set_deadline(std::chrono::system_clock::now() +
                       std::chrono::duration_cast<std::chrono::system_clock::duration>(
                           std::chrono::duration<double>(timeout_s)));
  if (!config_.token.empty()) context.AddMetadata("authorization", "Bearer " + config_.token);
}

grpc::Status ServiceClient::submit(const std::filesystem::path& surface, const v1::MeshOptions& options,
                                   v1::Job& job) {
  std::ifstream in(surface, std::ios::binary);
  std::error_code ec;
  const auto size = std::filesystem::file_size(surface, ec);
  if (!in || ec) return {grpc::StatusCode::NOT_FOUND, fmt::format("{}: cannot open the surface", surface.string())};
  grpc::ClientContext context;
  prepare(context, config_.timeout_s);
  auto writer = stub_->SubmitJob(&context, &job);
  v1::SubmitRequest msg;
  msg.mutable_header()->set_file_name(surface.filename().string());
  msg.mutable_header()->set_total_bytes(size);
  *msg.mutable_header()->mutable_options() = options;
  bool open = writer->Write(msg);
  std::string buffer(kChunkBytes, '\0');
  while (open && in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    const auto n = static_cast<std::size_t>(in.gcount());
    if (n == 0) break;
    msg.set_chunk(buffer.data(), n);
    open = writer->Write(msg);  // false: the server answered early (a limit, a bad header)
  }
  if (in.bad()) {
    context.TryCancel();
    writer->Finish().ok();
    return {grpc::StatusCode::NOT_FOUND, fmt::format("{}: reading failed", surface.string())};
  }
  writer->WritesDone();
  return writer->Finish();
}

grpc::Status ServiceClient::get(std::string_view id, v1::Job& job) {
  grpc::ClientContext context;
  prepare(context, config_.timeout_s);
  v1::GetJobRequest request;
  request.set_job_id(std::string(id));
  return stub_->GetJob(&context, request, &job);
}

grpc::Status ServiceClient::watch(std::string_view id, const std::function<void(const v1::JobEvent&)>& on_event,
                                  v1::Job& last) {
  grpc::ClientContext context;
  prepare(context, config_.watch_timeout_s);
  v1::WatchJobRequest request;
  request.set_job_id(std::string(id));
  auto reader = stub_->WatchJob(&context, request);
  v1::JobEvent event;
  while (reader->Read(&event)) {
    last = event.job();
    on_event(event);
  }
  return reader->Finish();
}

grpc::Status ServiceClient::list(v1::ListJobsResponse& jobs) {
  grpc::ClientContext context;
  prepare(context, config_.timeout_s);
  return stub_->ListJobs(&context, v1::ListJobsRequest(), &jobs);
}

grpc::Status ServiceClient::cancel(std::string_view id, v1::Job& job) {
  grpc::ClientContext context;
  prepare(context, config_.timeout_s);
  v1::CancelJobRequest request;
  request.set_job_id(std::string(id));
  return stub_->CancelJob(&context, request, &job);
}

grpc::Status ServiceClient::remove(std::string_view id, v1::Job& job) {
  grpc::ClientContext context;
  prepare(context, config_.timeout_s);
  v1::DeleteJobRequest request;
  request.set_job_id(std::string(id));
  return stub_->DeleteJob(&context, request, &job);
}

grpc::Status ServiceClient::fetch(std::string_view id, const std::filesystem::path& out, std::uint64_t* bytes) {
  const Result<VolumeFormat> written = volume_format_from_path(out);
  if (written.ok() && (*written == VolumeFormat::kCgns || *written == VolumeFormat::kFoam))
    return fetch_converted(id, out, bytes);
  const std::string format = volume_format_of(out);
  if (format.empty()) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            fmt::format("{}: unknown volume mesh suffix ({})", out.string(), volume_format_suffixes())};
  }
  // The .mapbc first: whoever sees the grid sees its names too.
  if (format.ends_with("ugrid")) {
    if (grpc::Status s = fetch_format(id, "mapbc", mapbc_path(out), nullptr); !s.ok()) return s;
  }
  return fetch_format(id, format, out, bytes);
}

grpc::Status ServiceClient::fetch_converted(std::string_view id, const std::filesystem::path& out,
                                            std::uint64_t* bytes) {
  namespace fs = std::filesystem;
  // The VTU goes beside the output (a polyMesh's case/constant is made here,
  // as write_volume would make it): no other file system needs room for it.
  fs::path dir = out.lexically_normal();
  if (!dir.has_filename()) dir = dir.parent_path();  // "case/constant/polyMesh/"
  const std::string name = dir.filename().string();
  dir = dir.parent_path();
  std::error_code ec;
  if (!dir.empty()) fs::create_directories(dir, ec);
  if (ec) return {grpc::StatusCode::DATA_LOSS, fmt::format("{}: cannot make the directory: {}", dir.string(), ec.message())};
  const fs::path vtu = dir / fmt::format(".{}.{}.fetch.vtu", name, ::getpid());
  if (grpc::Status s = fetch_format(id, "vtu", vtu, nullptr); !s.ok()) return s;
  Result<VolumeMesh> mesh = read_volume(vtu);
  fs::remove(vtu, ec);
  if (!mesh.ok()) return {grpc::StatusCode::DATA_LOSS, mesh.status().to_string()};
  if (Status s = write_volume(*mesh, out); !s.ok()) return {grpc::StatusCode::DATA_LOSS, s.to_string()};
  if (bytes) {
    *bytes = 0;
    if (fs::is_directory(out, ec)) {
      for (const auto& f : fs::directory_iterator(out, ec))
        if (f.is_regular_file(ec)) *bytes += f.file_size(ec);
    } else {
      *bytes = fs::file_size(out, ec);
    }
  }
  return grpc::Status::OK;
}

grpc::Status ServiceClient::fetch_format(std::string_view id, const std::string& format,
                                         const std::filesystem::path& out, std::uint64_t* bytes) {
  grpc::ClientContext context;
  prepare(context, config_.timeout_s);
  v1::FetchRequest request;
  request.set_job_id(std::string(id));
  request.set_format(format);
  auto reader = stub_->FetchResult(&context, request);
  auto tmp = out;
  tmp += ".part";
  std::ofstream file(tmp, std::ios::binary | std::ios::trunc);
  if (!file) {
    context.TryCancel();
    reader->Finish().ok();
    return {grpc::StatusCode::DATA_LOSS, fmt::format("{}: cannot write", tmp.string())};
  }
  v1::ResultChunk chunk;
  std::uint64_t expected = 0;
  std::uint64_t received = 0;
  while (reader->Read(&chunk)) {
    if (chunk.has_header()) {
      expected = chunk.header().total_bytes();
      continue;
    }
    file.write(chunk.data().data(), static_cast<std::streamsize>(chunk.data().size()));
    received += chunk.data().size();
  }
  grpc::Status status = reader->Finish();
  file.close();
  std::error_code ec;
  if (status.ok() && received != expected) {
    status = {grpc::StatusCode::DATA_LOSS, fmt::format("received {} bytes of {}", received, expected)};
  } else if (status.ok() && !file) {
    status = {grpc::StatusCode::DATA_LOSS, fmt::format("{}: writing failed", tmp.string())};
  }
  if (status.ok()) {
    std::filesystem::rename(tmp, out, ec);
    if (ec) status = {grpc::StatusCode::DATA_LOSS, fmt::format("{}: {}", out.string(), ec.message())};
  }
  if (!status.ok()) std::filesystem::remove(tmp, ec);
  if (status.ok() && bytes) *bytes = received;
  return status;
}

}  // namespace pdrmesh::cli
