// SPDX-License-Identifier: AGPL-3.0-or-later
// submit, status, watch, fetch, list, cancel, delete: thin commands over
// ServiceClient. Server, token, TLS CA and timeout come from, in this order of
// precedence: the command's flags, the environment (PDRMESH_SERVER,
// PDRMESH_TOKEN, PDRMESH_TOKEN_FILE, PDRMESH_TLS_CA), the client config file
// (--config, else PDRMESH_CONFIG, else $XDG_CONFIG_HOME/pdrmesh/client.json or
// ~/.config/pdrmesh/client.json; a JSON object with "server", "token",
// "token_file", "tls_ca", "timeout_s"), then the defaults.
#include "service_commands.hpp"

#include <fmt/format.h>
#include <google/protobuf/util/json_util.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iterator>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "exit_codes.hpp"
#include "progress_display.hpp"
#include "run_options.hpp"
#include "service_client.hpp"
#include "pdrmesh/surface_io.hpp"

namespace pdrmesh::cli {
namespace {

/// Flags of every service command, then resolve() fills `config`.
struct Common {
  std::string server, token, token_file, tls_ca, config_file;
  double timeout_s = 120;
  CLI::Option* timeout_flag = nullptr;
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

std::string code_name(grpc::StatusCode c) {
  switch (c) {
    case grpc::StatusCode::OK: return "OK";
    case grpc::StatusCode::CANCELLED: return "CANCELLED";
    case grpc::StatusCode::INVALID_ARGUMENT: return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED: return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND: return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS: return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED: return "PERMISSION_DENIED";
    case grpc::StatusCode::UNAUTHENTICATED: return "UNAUTHENTICATED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION: return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED: return "ABORTED";
    case grpc::StatusCode::UNAVAILABLE: return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS: return "DATA_LOSS";
    default: return fmt::format("CODE_{}", static_cast<int>(c));
  }
}

/// Prints the error on stderr (and, with --output json, as {"error": ...} on stdout).
int fail(const Common& c, const grpc::Status& s, std::string_view what) {
  fmt::print(stderr, "pdrmesh: {}: {} ({})\n", what, s.error_message(), code_name(s.error_code()));
  const int code = exit_code_for(s);
  if (c.output == "json") {
    const nlohmann::json j = {{"error",
                               {{"command", what}, {"code", code_name(s.error_code())},
                                {"message", s.error_message()}, {"exit_code", code}}}};
    fmt::print("{}\n", j.dump());
  }
  return code;
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
  if (j.leaves_total() > 0) line += fmt::format("  {}/{} leaves", j.leaves_done(), j.leaves_total());
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

std::optional<std::string> env(const char* name) {
  const char* v = std::getenv(name);
  if (v == nullptr || *v == '\0') return std::nullopt;
  return std::string(v);
}

/// The config file to read: --config, PDRMESH_CONFIG, or the per-user default
/// (which may be absent); empty when none applies.
std::string config_path(const Common& c, bool& explicit_path) {
  explicit_path = true;
  if (!c.config_file.empty()) return c.config_file;
  if (auto p = env("PDRMESH_CONFIG")) return *p;
  explicit_path = false;
  if (auto x = env("XDG_CONFIG_HOME")) return *x + "/pdrmesh/client.json";
  if (auto h = env("HOME")) return *h + "/.config/pdrmesh/client.json";
  return {};
}

/// Reads the first line of a token file, without its line end.
std::optional<std::string> read_token_file(const std::string& path, std::string& error) {
  std::ifstream in(path);
  std::string line;
  if (!in || !std::getline(in, line)) {
    error = fmt::format("{}: cannot read the token file", path);
    return std::nullopt;
  }
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
  return line;
}

/// Fills c.config by precedence (flags, environment, config file, defaults);
/// returns an error message when a named file cannot be read.
std::string resolve(Common& c) {
  bool explicit_path = false;
  const std::string path = config_path(c, explicit_path);
  nlohmann::json file = nlohmann::json::object();
  if (!path.empty()) {
    std::ifstream in(path);
    if (in) {
      file = nlohmann::json::parse(std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()),
                                   nullptr, /*allow_exceptions=*/false);
      if (!file.is_object()) return fmt::format("{}: the client config is not a JSON object", path);
    } else if (explicit_path) {
      return fmt::format("{}: cannot open the client config", path);
    }
  }
  auto from_file = [&](const char* key) -> std::optional<std::string> {
    const auto it = file.find(key);
    if (it == file.end() || !it->is_string()) return std::nullopt;
    return it->get<std::string>();
  };
  for (const char* key : {"server", "token", "token_file", "tls_ca"}) {
    if (file.contains(key) && !file[key].is_string()) return fmt::format("{}: \"{}\" must be a string", path, key);
  }
  if (file.contains("timeout_s") && !file["timeout_s"].is_number()) {
    return fmt::format("{}: \"timeout_s\" must be a number", path);
  }
  auto pick = [](const std::string& flag, std::optional<std::string> e, std::optional<std::string> f) {
    if (!flag.empty()) return flag;
    if (e) return *e;
    return f.value_or("");
  };
  c.config.server = pick(c.server, env("PDRMESH_SERVER"), from_file("server"));
  c.config.tls_ca_file = pick(c.tls_ca, env("PDRMESH_TLS_CA"), from_file("tls_ca"));
  // The token: a flag (--token, --token-file), then the environment, then the file; at each level a
  // literal token before a token file.
  std::string error;
  std::optional<std::string> token;
  if (!c.token.empty()) {
    token = c.token;
  } else if (!c.token_file.empty()) {
    token = read_token_file(c.token_file, error);
  } else if (auto t = env("PDRMESH_TOKEN")) {
    token = t;
  } else if (auto tf = env("PDRMESH_TOKEN_FILE")) {
    token = read_token_file(*tf, error);
  } else if (auto ft = from_file("token")) {
    token = ft;
  } else if (auto ftf = from_file("token_file")) {
    token = read_token_file(*ftf, error);
  }
  if (!error.empty()) return error;
  c.config.token = token.value_or("");
  c.config.timeout_s = c.timeout_s;
  if ((c.timeout_flag == nullptr || c.timeout_flag->count() == 0) && file.contains("timeout_s")) {
    c.config.timeout_s = file["timeout_s"].get<double>();
  }
  return {};
}

int connect(Common& c, std::unique_ptr<ServiceClient>& client) {
  if (std::string error = resolve(c); !error.empty()) {
    fmt::print(stderr, "pdrmesh: {}\n", error);
    return kExitUsage;
  }
  if (c.config.server.empty()) {
    fmt::print(stderr, "pdrmesh: no server: give --server HOST:PORT, set PDRMESH_SERVER or \"server\" in the "
                       "client config\n");
    return kExitUsage;
  }
  if (auto s = ServiceClient::connect(c.config, client); !s.ok()) return fail(c, s, "connect");
  return kExitOk;
}

ProgressState state_of(const v1::JobEvent& e) {
  const v1::Job& j = e.job();
  return {j.phase(), j.leaves_done(), j.leaves_total(), j.tets(), e.elapsed_s()};
}

/// Watches `id` to its end: events as JSON lines on stdout (watch --output
/// json), else the progress display on stderr.
int watch_to_end(const Common& c, ServiceClient& client, std::string_view id, bool events_on_stdout, v1::Job& last) {
  ProgressDisplay display(false);
  auto on_event = [&](const v1::JobEvent& e) {
    if (c.output == "json" && events_on_stdout) {
      fmt::print("{}\n", to_json(e));
      std::fflush(stdout);
    } else {
      display.update(state_of(e));
    }
  };
  const grpc::Status s = client.watch(id, on_event, last);
  display.finish();
  if (!s.ok()) return fail(c, s, "watch");
  return kExitOk;
}

void add_common(CLI::App* cmd, const std::shared_ptr<Common>& c) {
  cmd->add_option("--server", c->server, "coordinator host:port (env PDRMESH_SERVER)");
  cmd->add_option("--token", c->token, "bearer token (env PDRMESH_TOKEN)");
  cmd->add_option("--token-file", c->token_file, "file whose first line is the bearer token (env PDRMESH_TOKEN_FILE)");
  cmd->add_option("--tls-ca", c->tls_ca, "PEM CA certificates: connect with TLS (env PDRMESH_TLS_CA)");
  cmd->add_option("--config", c->config_file,
                  "client config (JSON; env PDRMESH_CONFIG; default ~/.config/pdrmesh/client.json)");
  c->timeout_flag = cmd->add_option("--timeout", c->timeout_s, "seconds each call may take")
                        ->check(CLI::PositiveNumber)
                        ->capture_default_str();
  cmd->add_option("--output", c->output, "text or json")->check(CLI::IsMember({"text", "json"}))->capture_default_str();
}

int print_or_fail(const Common& c, const grpc::Status& s, const v1::Job& job, std::string_view what) {
  if (!s.ok()) return fail(c, s, what);
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

/// Prints a fetched file: its path (text) or {"job_id", "file", "bytes"} (json).
void print_fetched(const Common& c, std::string_view id, const std::string& file, std::uint64_t bytes) {
  if (c.output == "json") {
    fmt::print("{}\n", nlohmann::json{{"job_id", id}, {"file", file}, {"bytes", bytes}}.dump());
  } else {
    fmt::print(stderr, "wrote {} ({} bytes)\n", file, bytes);
  }
}

struct SubmitArgs {
  std::string surface;
  double max_volume = 0;
  double time_limit_s = 0;
  bool wait = false;
  std::string out;
  RunOptionArgs mesh;
};

int run_submit(Common& c, const SubmitArgs& a) {
  std::unique_ptr<ServiceClient> client;
  if (int code = connect(c, client); code != kExitOk) return code;
  if (!a.out.empty() && volume_format_of(a.out).empty()) {
    fmt::print(stderr, "pdrmesh: {}: unknown volume mesh suffix (.vtu .mesh .meshb .ugrid .lb8.ugrid .b8.ugrid .msh "
                       ".su2)\n", a.out);
    return kExitUsage;
  }
  if (a.mesh.size.max_tets > 0 && a.max_volume <= 0) {  // the coordinator checks its own limits in any case
    auto surface = read_surface(a.surface);
    Status s = surface.ok() ? a.mesh.size.check_tet_limit(*surface, false) : surface.status();
    if (!s.ok()) {
      fmt::print(stderr, "pdrmesh: error: {}\n", s.to_string());
      return cli::exit_code_for(s);
    }
  }
  v1::MeshOptions options = a.mesh.mesh_options();
  if (a.max_volume > 0) options.set_max_volume(a.max_volume);
  if (a.time_limit_s > 0) options.set_time_limit_s(a.time_limit_s);
  v1::Job job;
  if (auto s = client->submit(a.surface, options, job); !s.ok()) return fail(c, s, "submit");
  const bool wait = a.wait || !a.out.empty();
  if (!wait) {
    if (c.output == "json") {
      print_job(c, job);
    } else {
      fmt::print("{}\n", job.id());
    }
    return kExitOk;
  }
  if (c.output != "json") fmt::print("{}\n", job.id());
  std::fflush(stdout);
  v1::Job last = job;
  if (int code = watch_to_end(c, *client, job.id(), false, last); code != kExitOk) return code;
  if (c.output == "json") print_job(c, last);  // the final job, one object
  if (int code = final_code(last); code != kExitOk || a.out.empty()) return code;
  std::uint64_t bytes = 0;
  if (auto s = client->fetch(job.id(), a.out, &bytes); !s.ok()) return fail(c, s, "fetch");
  if (c.output != "json") print_fetched(c, job.id(), a.out, bytes);
  return kExitOk;
}

}  // namespace

void add_service_commands(CLI::App& app, int& exit_code) {
  {
    auto* cmd = app.add_subcommand("submit", "Submit a surface to a coordinator with the mesh options of run; "
                                             "prints the job id.");
    auto c = std::make_shared<Common>();
    auto a = std::make_shared<SubmitArgs>();
    add_common(cmd, c);
    cmd->add_option("SURFACE", a->surface, "surface file (.stl .obj .off .ply .mesh .surf)")->required();
    a->mesh.add_to(cmd);
    cmd->add_option("--max-volume", a->max_volume,
                    "write the initial mesh alone, with this maximum tet volume (the mesh options are ignored)")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--time-limit", a->time_limit_s, "seconds the job may mesh (default: the coordinator's)")
        ->check(CLI::PositiveNumber);
    cmd->add_flag("--wait", a->wait,
                  "follow the job until it ends (progress on stderr); with --output json print the final job");
    cmd->add_option("-o,--output-file", a->out, "download the result here when done (implies --wait)");
    cmd->callback([&exit_code, c, a] { exit_code = run_submit(*c, *a); });
  }
  add_job_command(app, "status", "Show one job.", exit_code,
                  [](const Common& c, ServiceClient& client, const std::string& id) {
                    v1::Job job;
                    return print_or_fail(c, client.get(id, job), job, "status");
                  });
  add_job_command(app, "watch",
                  "Follow a job until it ends (--output json: one event per line); exit 0 when it succeeded, "
                  "1 otherwise.",
                  exit_code, [](const Common& c, ServiceClient& client, const std::string& id) {
                    v1::Job last;
                    const int code = watch_to_end(c, client, id, true, last);
                    return code != kExitOk ? code : final_code(last);
                  });
  {
    auto out = std::make_shared<std::string>();
    auto* cmd = add_job_command(app, "fetch", "Download a succeeded job's mesh, in the format named by the suffix.",
                                exit_code, [out](const Common& c, ServiceClient& client, const std::string& id) {
                                  std::uint64_t bytes = 0;
                                  const grpc::Status s = client.fetch(id, *out, &bytes);
                                  if (!s.ok()) return fail(c, s, "fetch");
                                  print_fetched(c, id, *out, bytes);
                                  return static_cast<int>(kExitOk);
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
        exit_code = fail(*c, s, "list");
        return;
      }
      if (c->output == "json") {
        fmt::print("{}\n", to_json(jobs));
      } else {
        for (const auto& j : jobs.jobs()) fmt::print("{}\n", job_line(j));
      }
    });
  }
  add_job_command(app, "cancel", "Cancel a job (queued: at once; running: at its next merged leaf or phase).",
                  exit_code, [](const Common& c, ServiceClient& client, const std::string& id) {
                    v1::Job job;
                    return print_or_fail(c, client.cancel(id, job), job, "cancel");
                  });
  add_job_command(app, "delete", "Delete a job and its files (a running job is cancelled first).", exit_code,
                  [](const Common& c, ServiceClient& client, const std::string& id) {
                    v1::Job job;
                    const grpc::Status s = client.remove(id, job);
                    if (!s.ok()) return fail(c, s, "delete");
                    if (c.output == "json") {
                      print_job(c, job);
                    } else {
                      fmt::print("deleted {}\n", job.id());
                    }
                    return static_cast<int>(kExitOk);
                  });
}

}  // namespace pdrmesh::cli
