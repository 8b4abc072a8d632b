// SPDX-License-Identifier: AGPL-3.0-or-later
// submit, status, watch, fetch, list, cancel: thin commands over ServiceClient.
#include "service_commands.hpp"

#include <fmt/format.h>
#include <google/protobuf/util/json_util.h>

#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <string>

#include "exit_codes.hpp"
#include "service_client.hpp"

namespace pdrmesh::cli {
namespace {

struct Common {
  ClientConfig config;
  std::string output = "text";  ///< text | json
};

int exit_code_for(const grpc::Status& s) {
  switch (s.error_code()) {
    case grpc::StatusCode::OK: return kExitOk;
    case grpc::StatusCode::INVALID_ARGUMENT: return kExitBadInput;
    case grpc::StatusCode::NOT_FOUND: return kExitNoInput;
    case grpc::StatusCode::UNAUTHENTICATED:
    case grpc::StatusCode::PERMISSION_DENIED: return kExitNoPerm;
    case grpc::StatusCode::UNAVAILABLE: return kExitUnavailable;
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
    case grpc::StatusCode::DEADLINE_EXCEEDED:
    case grpc::StatusCode::FAILED_PRECONDITION:
    case grpc::StatusCode::ABORTED:
    case grpc::StatusCode::CANCELLED: return kExitTempFail;
    case grpc::StatusCode::DATA_LOSS: return kExitIo;
    default: return kExitInternal;
  }
}

int fail(const grpc::Status& s, std::string_view what) {
  fmt::print(stderr, "pdrmesh: {}: {} (gRPC code {})\n", what, s.error_message(), static_cast<int>(s.error_code()));
  return exit_code_for(s);
}

std::string state_name(v1::JobState s) {
  std::string name = v1::JobState_Name(s);
  constexpr std::string_view kPrefix = "JOB_STATE_";
  if (name.rfind(kPrefix, 0) == 0) name = name.substr(kPrefix.size());
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return name;
}

std::string to_json(const google::protobuf::Message& m) {
  std::string out;
  google::protobuf::util::JsonPrintOptions o;
  o.preserve_proto_field_names = true;
  o.always_print_primitive_fields = true;
  if (!google::protobuf::util::MessageToJsonString(m, &out, o).ok()) return "{}";
  return out;
}

std::string job_line(const v1::Job& j) {
  std::string line = fmt::format("{}  {:<9}  {:<16} {:3.0f}%  {}", j.id(), state_name(j.state()), j.phase(),
                                 100 * j.progress(), j.input_name());
  if (j.tets() > 0) line += fmt::format("  {} tets", j.tets());
  if (!j.error().empty()) line += "  error: " + j.error();
  return line;
}

void print_job(const Common& c, const v1::Job& j) {
  fmt::print("{}\n", c.output == "json" ? to_json(j) : job_line(j));
}

/// Exit code of a job that reached a final state.
int final_code(const v1::Job& j) {
  if (j.state() == v1::JOB_STATE_SUCCEEDED) return kExitOk;
  fmt::print(stderr, "pdrmesh: job {} {}{}{}\n", j.id(), state_name(j.state()), j.error().empty() ? "" : ": ",
             j.error());
  return kExitJobFailed;
}

int connect(const Common& c, std::unique_ptr<ServiceClient>& client) {
  if (c.config.server.empty()) {
    fmt::print(stderr, "pdrmesh: no server: give --server HOST:PORT or set PDRMESH_SERVER\n");
    return kExitUsage;
  }
  if (auto s = ServiceClient::connect(c.config, client); !s.ok()) return fail(s, "connect");
  return kExitOk;
}

/// Watches `id` to its end, progress on stderr (text) or events on stdout (json lines).
int watch_to_end(const Common& c, ServiceClient& client, std::string_view id, bool events_on_stdout, v1::Job& last) {
  auto on_event = [&](const v1::JobEvent& e) {
    if (c.output == "json" && events_on_stdout) {
      fmt::print("{}\n", to_json(e));
      std::fflush(stdout);
    } else {
      fmt::print(stderr, "[{:7.1f}s] {}\n", e.elapsed_s(), job_line(e.job()));
    }
  };
  if (auto s = client.watch(id, on_event, last); !s.ok()) return fail(s, "watch");
  return kExitOk;
}

void add_common(CLI::App* cmd, const std::shared_ptr<Common>& c) {
  if (const char* s = std::getenv("PDRMESH_SERVER")) c->config.server = s;
  if (const char* t = std::getenv("PDRMESH_TOKEN")) c->config.token = t;
  cmd->add_option("--server", c->config.server, "coordinator host:port (env PDRMESH_SERVER)");
  cmd->add_option("--token", c->config.token, "bearer token (env PDRMESH_TOKEN)");
  cmd->add_option("--tls-ca", c->config.tls_ca_file, "PEM CA certificates: connect with TLS");
  cmd->add_option("--timeout", c->config.timeout_s, "seconds each call may take")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--output", c->output, "text or json")->check(CLI::IsMember({"text", "json"}))->capture_default_str();
}

int print_or_fail(const Common& c, const grpc::Status& s, const v1::Job& job, std::string_view what) {
  if (!s.ok()) return fail(s, what);
  print_job(c, job);
  return kExitOk;
}

using JobAction = std::function<int(const Common&, ServiceClient&, const std::string& id)>;

/// A subcommand taking one job id: connects, then runs `action`.
CLI::App* add_job_command(CLI::App& app, const char* name, const char* help, int& exit_code, JobAction action) {
  auto* cmd = app.add_subcommand(name, help);
  auto c = std::make_shared<Common>();
  auto id = std::make_shared<std::string>();
  add_common(cmd, c);
  cmd->add_option("JOB", *id, "job id")->required();
  cmd->callback([&exit_code, c, id, action] {
    std::unique_ptr<ServiceClient> client;
    if ((exit_code = connect(*c, client)) != kExitOk) return;
    exit_code = action(*c, *client, *id);
  });
  return cmd;
}

struct SubmitArgs {
  std::string surface;
  double max_volume = 0;
  double time_limit_s = 0;
  bool wait = false;
  std::string out;
};

int run_submit(const Common& c, const SubmitArgs& a) {
  std::unique_ptr<ServiceClient> client;
  if (int code = connect(c, client); code != kExitOk) return code;
  if (!a.out.empty() && volume_format_of(a.out).empty()) {
    fmt::print(stderr, "pdrmesh: {}: unknown volume mesh suffix\n", a.out);
    return kExitUsage;
  }
  v1::MeshOptions options;
  if (a.max_volume > 0) options.set_max_volume(a.max_volume);
  if (a.time_limit_s > 0) options.set_time_limit_s(a.time_limit_s);
  v1::Job job;
  if (auto s = client->submit(a.surface, options, job); !s.ok()) return fail(s, "submit");
  if (c.output == "json") {
    print_job(c, job);
  } else {
    fmt::print("{}\n", job.id());
  }
  std::fflush(stdout);
  if (!a.wait && a.out.empty()) return kExitOk;
  v1::Job last = job;
  if (int code = watch_to_end(c, *client, job.id(), false, last); code != kExitOk) return code;
  if (int code = final_code(last); code != kExitOk || a.out.empty()) return code;
  if (auto s = client->fetch(job.id(), a.out); !s.ok()) return fail(s, "fetch");
  fmt::print(stderr, "wrote {}\n", a.out);
  return kExitOk;
}

}  // namespace

void add_service_commands(CLI::App& app, int& exit_code) {
  {
    auto* cmd = app.add_subcommand("submit", "Submit a surface to a coordinator; prints the job id.");
    auto c = std::make_shared<Common>();
    auto a = std::make_shared<SubmitArgs>();
    add_common(cmd, c);
    cmd->add_option("SURFACE", a->surface, "surface file (.stl .obj .off .ply .mesh .surf)")->required();
    cmd->add_option("--max-volume", a->max_volume, "write the initial mesh alone, with this maximum tet volume")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--time-limit", a->time_limit_s, "seconds the job may mesh")->check(CLI::PositiveNumber);
    cmd->add_flag("--wait", a->wait, "watch the job (progress on stderr) until it ends");
    cmd->add_option("-o,--output-file", a->out, "download the result here when done (implies --wait)");
    cmd->callback([&exit_code, c, a] { exit_code = run_submit(*c, *a); });
  }
  add_job_command(app, "status", "Show one job.", exit_code,
                  [](const Common& c, ServiceClient& client, const std::string& id) {
                    v1::Job job;
                    return print_or_fail(c, client.get(id, job), job, "status");
                  });
  add_job_command(app, "watch", "Follow a job until it ends; exit 0 when it succeeded, 1 otherwise.", exit_code,
                  [](const Common& c, ServiceClient& client, const std::string& id) {
                    v1::Job last;
                    const int code = watch_to_end(c, client, id, true, last);
                    return code != kExitOk ? code : final_code(last);
                  });
  {
    auto out = std::make_shared<std::string>();
    auto* cmd = add_job_command(app, "fetch", "Download a succeeded job's mesh, in the format named by the suffix.",
                                exit_code, [out](const Common&, ServiceClient& client, const std::string& id) {
                                  const grpc::Status s = client.fetch(id, *out);
                                  return s.ok() ? kExitOk : fail(s, "fetch");
                                });
    cmd->add_option("-o,--output-file", *out,
                    "volume mesh (.vtu .mesh .meshb .ugrid .lb8.ugrid .b8.ugrid .msh .su2)")
        ->required();
  }
  {
    auto* cmd = app.add_subcommand("list", "List your jobs, newest first.");
    auto c = std::make_shared<Common>();
    add_common(cmd, c);
    cmd->callback([&exit_code, c] {
      std::unique_ptr<ServiceClient> client;
      if ((exit_code = connect(*c, client)) != kExitOk) return;
      v1::ListJobsResponse jobs;
      if (auto s = client->list(jobs); !s.ok()) {
        exit_code = fail(s, "list");
        return;
      }
      if (c->output == "json") {
        fmt::print("{}\n", to_json(jobs));
      } else {
        for (const auto& j : jobs.jobs()) fmt::print("{}\n", job_line(j));
      }
    });
  }
  add_job_command(app, "cancel", "Cancel a job (queued: at once; running: at its next phase).", exit_code,
                  [](const Common& c, ServiceClient& client, const std::string& id) {
                    v1::Job job;
                    return print_or_fail(c, client.cancel(id, job), job, "cancel");
                  });
}

}  // namespace pdrmesh::cli
