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

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "exit_codes.hpp"
#include "job_json.hpp"
#include "layer_options.hpp"
#include "layers_proto.hpp"
#include "options.hpp"
#include "pdrmesh/boundary_names_io.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/volume_io.hpp"
#include "progress_display.hpp"
#include "run_options.hpp"
#include "service_client.hpp"

namespace pdrmesh::cli {
namespace {

/// Flags of every service command, then resolve() fills `config`.
struct Common {
  std::string server, token, token_file, tls_ca, config_file;
  double timeout_s = 120;
  CLI::Option* timeout_flag = nullptr;
  ClientConfig config;
  bool json = false;  ///< --json: machine-readable output on stdout
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

/// Prints the error on stderr (and, with --json, as {"error": ...} on stdout).
int fail(const Common& c, const grpc::Status& s, std::string_view what) {
  fmt::print(stderr, "pdrmesh: {}: {} ({})\n", what, s.error_message(), code_name(s.error_code()));
  const int code = exit_code_for(s);
  if (c.json) {
    const nlohmann::json j = {{"error",
                               {{"command", what}, {"code", code_name(s.error_code())},
                                {"message", s.error_message()}, {"exit_code", code}}}};
    fmt::print("{}\n", j.dump());
  }
  return code;
}

/// How long ago, as kubectl says it: 5s, 3m, 2h, 4d.
std::string age(std::int64_t unix_ms) {
  const auto now_ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                          std::chrono::system_clock::now().time_since_epoch()).count();
  const std::int64_t s = std::max<std::int64_t>(0, (now_ms - unix_ms) / 1000);
  if (s < 120) return fmt::format("{}s", s);
  if (s < 120 * 60) return fmt::format("{}m", s / 60);
  if (s < 48 * 3600) return fmt::format("{}h", s / 3600);
  return fmt::format("{}d", s / 86400);
}

/// Jobs as a table with a header row; columns as wide as their widest cell.
void print_job_table(const std::vector<v1::Job>& jobs) {
  std::vector<std::vector<std::string>> rows = {{"JOB", "STATE", "PHASE", "PROGRESS", "AGE", "TETS", "INPUT"}};
  for (const v1::Job& j : jobs) {
    std::string input = j.input_name();
    if (j.leaves_total() > 0) input += fmt::format("  {}/{} leaves", j.leaves_done(), j.leaves_total());
    if (!j.error().empty()) input += "  error: " + j.error();
    rows.push_back({j.id(), state_name(j.state()), j.phase(), fmt::format("{:.0f}%", 100 * j.progress()),
                    age(j.created_unix_ms()), j.tets() > 0 ? fmt::format("{}", j.tets()) : "-", input});
  }
  std::vector<std::size_t> width(rows[0].size(), 0);
  for (const auto& r : rows)
    for (std::size_t k = 0; k < r.size(); ++k) width[k] = std::max(width[k], r[k].size());
  for (const auto& r : rows) {
    std::string line;
    for (std::size_t k = 0; k + 1 < r.size(); ++k) line += fmt::format("{:<{}}  ", r[k], width[k]);
    line += r.back();
    fmt::print("{}\n", line);
  }
}

void print_job(const Common& c, const v1::Job& j) {
  if (c.json) {
    fmt::print("{}\n", job_json(j).dump());
  } else {
    print_job_table({j});
  }
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

/// Watches `id` to its end: events as JSON lines on stdout (watch --json),
/// else the progress display on stderr.
int watch_to_end(const Common& c, ServiceClient& client, std::string_view id, bool events_on_stdout, v1::Job& last) {
  ProgressDisplay display(false);
  auto on_event = [&](const v1::JobEvent& e) {
    if (c.json && events_on_stdout) {
      fmt::print("{}\n", nlohmann::json{{"job", job_json(e.job())}, {"elapsed_s", e.elapsed_s()}}.dump());
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
  c->timeout_flag = add_number(cmd, "--timeout", c->timeout_s, "seconds each call may take", kSeconds)
                        ->capture_default_str();
  cmd->add_flag("--json", c->json, "print machine-readable JSON on stdout");
}

int print_or_fail(const Common& c, const grpc::Status& s, const v1::Job& job, std::string_view what) {
  if (!s.ok()) return fail(c, s, what);
  print_job(c, job);
  return kExitOk;
}

using JobAction = std::function<int(const Common&, ServiceClient&, const std::string& id)>;

/// A subcommand taking one job id: connects, then runs `action`.
CLI::App* add_job_command(CLI::App& app, const char* name, const char* help, int& exit_code, JobAction action,
                          const std::vector<std::pair<std::string, std::string>>& examples) {
  auto* cmd = app.add_subcommand(name, help);
  cmd->footer(help_footer(examples));
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
  if (c.json) {
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
  LayerArgs layers;
  bool growth_given = false;  ///< --growth on the command line (else the layers' ratio continues)
};

int run_submit(Common& c, const SubmitArgs& a) {
  // A percentage size is resolved here, from the surface's bounding box: the
  // coordinator takes lengths.
  SizingOptions sizing = a.mesh.size.options(0);
  if (a.max_volume == 0) {
    std::string line;
    auto job_sizing = a.mesh.size.job_sizing(a.surface, line, a.mesh.farfield.options());
    if (!job_sizing.ok()) {
      fmt::print(stderr, "pdrmesh: error: {}\n", job_sizing.status().to_string());
      return cli::exit_code_for(job_sizing.status());
    }
    sizing = *job_sizing;
    fmt::print(stderr, "{}\n", line);
  }
  // The names file's own mistakes (file:line) are found here; the
  // coordinator checks its ids against the surface.
  std::map<int, std::string> names;
  if (!a.mesh.names.empty()) {
    auto read = read_boundary_names(a.mesh.names);
    if (!read.ok()) {
      fmt::print(stderr, "pdrmesh: error: {}\n", read.status().to_string());
      return cli::exit_code_for(read.status());
    }
    names = std::move(read).value();
  }
  std::unique_ptr<ServiceClient> client;
  if (int code = connect(c, client); code != kExitOk) return code;
  v1::MeshOptions options = a.mesh.mesh_options(sizing);
  for (const auto& [id, name] : names) (*options.mutable_surface_names())[id] = name;
  if (a.max_volume > 0) options.set_max_volume(a.max_volume);
  if (a.time_limit_s > 0) options.set_time_limit_s(a.time_limit_s);
  if (a.layers.layers > 0) {
    to_proto(a.layers.request(), *options.mutable_layers());
    if (!a.growth_given) options.clear_growth();  // the coordinator continues the layers' ratio
  }
  v1::Job job;
  if (auto s = client->submit(a.surface, options, job); !s.ok()) return fail(c, s, "submit");
  const bool wait = a.wait || !a.out.empty();
  if (!wait) {
    if (c.json) {
      print_job(c, job);
    } else {
      fmt::print("{}\n", job.id());
    }
    return kExitOk;
  }
  if (!c.json) fmt::print("{}\n", job.id());
  std::fflush(stdout);
  v1::Job last = job;
  if (int code = watch_to_end(c, *client, job.id(), false, last); code != kExitOk) return code;
  if (c.json) print_job(c, last);  // the final job, one object
  if (int code = final_code(last); code != kExitOk || a.out.empty()) return code;
  std::uint64_t bytes = 0;
  if (auto s = client->fetch(job.id(), a.out, &bytes); !s.ok()) return fail(c, s, "fetch");
  if (!c.json) print_fetched(c, job.id(), a.out, bytes);
  return kExitOk;
}

}  // namespace

void add_service_commands(CLI::App& app, int& exit_code) {
  const std::string volume_formats = fmt::format("({})", volume_format_suffixes());
  {
    auto* cmd = app.add_subcommand("submit", "Submit a surface to a coordinator with the mesh options of run; "
                                             "prints the job id.");
    auto c = std::make_shared<Common>();
    auto a = std::make_shared<SubmitArgs>();
    add_common(cmd, c);
    cmd->add_option("SURFACE", a->surface, "surface file (.stl .obj .off .ply .mesh .surf)")
        ->required()
        ->check(surface_input_check());
    cmd->add_option("-o,--output", a->out, "download the result here when done (implies --wait) " + volume_formats)
        ->check(output_check(OutputKind::kVolumeMesh));
    a->mesh.add_to(cmd);
    a->layers.add_to(cmd);
    add_number(cmd, "--max-volume", a->max_volume,
               "write the initial mesh alone, with this maximum tet volume (instead of the mesh options)", kVolume);
    add_time_limit(cmd, a->time_limit_s, "the coordinator's");
    cmd->add_flag("--wait", a->wait,
                  "follow the job until it ends (progress on stderr); with --json print the final job");
    cmd->footer(help_footer({{"pdrmesh submit part.stl --server mesh.example:7443 -o part.meshb",
                              "mesh on the coordinator, wait, download the result"},
                             {"pdrmesh submit part.stl --size 1% --time-limit 3600 --json",
                              "queue a job, print it as JSON and return at once"},
                             {"pdrmesh submit wing.stl --farfield 20 --layers 20 --first-height yplus:1 "
                              "--reynolds 1e6 -o wing.cgns",
                              "an external-flow job with prism layers on the body"}}));
    cmd->callback([&exit_code, c, a, cmd] {
      a->mesh.size.check();
      a->layers.check(*cmd);
      a->growth_given = cmd->count("--growth") > 0;
      refuse_together(*cmd, "--max-volume",
                      {"--size", "--hmin", "--hmax", "--growth", "--depth", "--kernel", "--no-interface-round",
                       "--no-optimize", "--layers"},
                      "--max-volume writes the initial mesh alone, unrefined");
      exit_code = run_submit(*c, *a);
    });
  }
  add_job_command(app, "status", "Show one job.", exit_code,
                  [](const Common& c, ServiceClient& client, const std::string& id) {
                    v1::Job job;
                    return print_or_fail(c, client.get(id, job), job, "status");
                  },
                  {{"pdrmesh status 3f2a9c", "state, phase, progress, age of the job"},
                   {"pdrmesh status 3f2a9c --json", "the job as JSON"}});
  add_job_command(app, "watch",
                  "Follow a job until it ends (--json: one event per line); exit 0 when it succeeded, "
                  "1 otherwise.",
                  exit_code, [](const Common& c, ServiceClient& client, const std::string& id) {
                    v1::Job last;
                    const int code = watch_to_end(c, client, id, true, last);
                    return code != kExitOk ? code : final_code(last);
                  },
                  {{"pdrmesh watch 3f2a9c", "a progress line on stderr until the job ends"},
                   {"pdrmesh watch 3f2a9c --json", "one JSON event per line on stdout"}});
  {
    auto out = std::make_shared<std::string>();
    auto* cmd = add_job_command(app, "fetch", "Download a succeeded job's mesh, in the format named by the suffix.",
                                exit_code, [out](const Common& c, ServiceClient& client, const std::string& id) {
                                  std::uint64_t bytes = 0;
                                  const grpc::Status s = client.fetch(id, *out, &bytes);
                                  if (!s.ok()) return fail(c, s, "fetch");
                                  print_fetched(c, id, *out, bytes);
                                  return static_cast<int>(kExitOk);
                                },
                                {{"pdrmesh fetch 3f2a9c -o part.vtu", "the mesh as VTK XML"},
                                 {"pdrmesh fetch 3f2a9c -o part.su2 --json", "as SU2; prints {job_id, file, bytes}"}});
    cmd->add_option("-o,--output", *out, "volume mesh " + volume_formats)
        ->required()
        ->check(output_check(OutputKind::kVolumeMesh));
  }
  {
    auto* cmd = app.add_subcommand("list", "List your jobs, newest first.");
    auto c = std::make_shared<Common>();
    add_common(cmd, c);
    cmd->footer(help_footer({{"pdrmesh list", "a table: job, state, phase, progress, age, tets, input"},
                             {"pdrmesh list --json", "{\"jobs\": [...]}"}}));
    cmd->callback([&exit_code, c] {
      std::unique_ptr<ServiceClient> client;
      if ((exit_code = connect(*c, client)) != kExitOk) return;
      v1::ListJobsResponse jobs;
      if (auto s = client->list(jobs); !s.ok()) {
        exit_code = fail(*c, s, "list");
        return;
      }
      if (c->json) {
        nlohmann::json list = nlohmann::json::array();
        for (const auto& j : jobs.jobs()) list.push_back(job_json(j));
        fmt::print("{}\n", nlohmann::json{{"jobs", list}}.dump());
      } else {
        print_job_table({jobs.jobs().begin(), jobs.jobs().end()});
      }
    });
  }
  add_job_command(app, "cancel", "Cancel a job (queued: at once; running: at its next merged leaf or phase).",
                  exit_code, [](const Common& c, ServiceClient& client, const std::string& id) {
                    v1::Job job;
                    return print_or_fail(c, client.cancel(id, job), job, "cancel");
                  },
                  {{"pdrmesh cancel 3f2a9c", "stop the job; its state becomes cancelled"},
                   {"pdrmesh cancel 3f2a9c --json", "and print the job as JSON"}});
  add_job_command(app, "delete", "Delete a job and its files (a running job is cancelled first).", exit_code,
                  [](const Common& c, ServiceClient& client, const std::string& id) {
                    v1::Job job;
                    const grpc::Status s = client.remove(id, job);
                    if (!s.ok()) return fail(c, s, "delete");
                    if (c.json) {
                      print_job(c, job);
                    } else {
                      fmt::print("deleted {}\n", job.id());
                    }
                    return static_cast<int>(kExitOk);
                  },
                  {{"pdrmesh delete 3f2a9c", "the job, its input and its result"},
                   {"pdrmesh delete 3f2a9c --json", "and print the job as JSON"}});
}

}  // namespace pdrmesh::cli
