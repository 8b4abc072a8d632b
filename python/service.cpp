// SPDX-License-Identifier: AGPL-3.0-or-later
// _pdrmesh.ServiceClient: the CLI's ServiceClient (client/service_client.hpp)
// for Python. Jobs come back as the JSON `pdrmesh status --json` prints
// (client/job_json.hpp), which the package turns into dicts; a gRPC error
// raises the exception its code means, with the server's message. Every call
// waits on the network without the GIL.
#include <fmt/format.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "job_json.hpp"
#include "layers_proto.hpp"
#include "module.hpp"
#include "pdrmesh/volume_io.hpp"
#include "service_client.hpp"

namespace py = pybind11;

namespace pdrmesh::python {
namespace {

/// Raises the exception for a failed call: ValueError (INVALID_ARGUMENT),
/// LookupError (NOT_FOUND: no such job), PermissionError (a refused token),
/// ConnectionError (UNAVAILABLE), TimeoutError, OSError (DATA_LOSS: the
/// result could not be written), RuntimeError otherwise.
[[noreturn]] void raise_grpc(const grpc::Status& s, const char* what) {
  PyObject* type = PyExc_RuntimeError;
  switch (s.error_code()) {
    case grpc::StatusCode::INVALID_ARGUMENT: type = PyExc_ValueError; break;
    case grpc::StatusCode::NOT_FOUND: type = PyExc_LookupError; break;
    case grpc::StatusCode::UNAUTHENTICATED:
    case grpc::StatusCode::PERMISSION_DENIED: type = PyExc_PermissionError; break;
    case grpc::StatusCode::UNAVAILABLE: type = PyExc_ConnectionError; break;
    case grpc::StatusCode::DEADLINE_EXCEEDED: type = PyExc_TimeoutError; break;
    case grpc::StatusCode::DATA_LOSS: type = PyExc_OSError; break;
    default: break;
  }
  const std::string message = fmt::format("{}: {} ({})", what, s.error_message(), cli::code_name(s.error_code()));
  PyErr_SetString(type, message.c_str());
  throw py::error_already_set();
}

class Client {
 public:
  Client(const std::string& server, const std::string& token, const std::string& tls_ca, double timeout_s) {
    cli::ClientConfig config;
    config.server = server;
    config.token = token;
    config.tls_ca_file = tls_ca;
    config.timeout_s = timeout_s;
    if (server.empty()) throw py::value_error("no server: give the coordinator's host:port");
    if (!(timeout_s > 0)) throw py::value_error(fmt::format("timeout must be a positive number of seconds, got {}", timeout_s));
    if (auto s = cli::ServiceClient::connect(config, client_); !s.ok()) raise_grpc(s, "connect");
  }

  /// Uploads the surface file with the options of `pdrmesh submit` (`names`
  /// those of --names, the far field those of --farfield and --farfield-shape,
  /// `layers` those of --layers ...);
  /// the job as JSON.
  std::string submit(const std::filesystem::path& surface, const std::optional<std::string>& size,
                     std::optional<double> hmin, std::optional<double> hmax, double growth,
                     std::optional<double> max_tets, std::optional<int> depth, const std::string& kernel,
                     bool optimize, std::optional<double> time_limit, const std::map<int, std::string>& names,
                     std::optional<double> farfield, const std::string& farfield_shape,
                     const std::optional<LayerRequest>& layers) {
    cli::RunOptionArgs args = run_options(size, hmin, hmax, growth, max_tets, depth, kernel, optimize);
    if (const auto far = farfield_options(farfield, farfield_shape)) {
      args.farfield.distance = far->distance;
      args.farfield.shape = std::string(to_string(far->shape));
    }
    if (time_limit && !(*time_limit > 0))
      throw py::value_error(fmt::format("time_limit must be a positive number of seconds, got {}", *time_limit));
    grpc::Status s;
    Status local;
    v1::Job job;
    {
      py::gil_scoped_release release;
      std::string line;
      Result<SizingOptions> sizing = args.size.job_sizing(surface, line, args.farfield.options());
      local = sizing.status();
      if (sizing.ok()) {
        v1::MeshOptions options = args.mesh_options(*sizing);
        for (const auto& [id, name] : names) (*options.mutable_surface_names())[id] = name;
        if (time_limit) options.set_time_limit_s(*time_limit);
        if (layers) to_proto(*layers, *options.mutable_layers());
        s = client_->submit(surface, options, job);
      }
    }
    if (!local.ok()) raise(local);
    if (!s.ok()) raise_grpc(s, "submit");
    return cli::job_json(job).dump();
  }

  std::string get(const std::string& id) {
    v1::Job job;
    grpc::Status s;
    {
      py::gil_scoped_release release;
      s = client_->get(id, job);
    }
    if (!s.ok()) raise_grpc(s, "status");
    return cli::job_json(job).dump();
  }

  /// Follows the job to its end; `on_event` (may be None) gets each event as
  /// JSON ({"job": ..., "elapsed_s": ...}). An exception it raises ends the
  /// watch once the stream gives control back, and is raised here.
  std::string watch(const std::string& id, const std::optional<std::function<void(std::string)>>& on_event) {
    v1::Job last;
    grpc::Status s;
    std::optional<py::error_already_set> error;
    {
      py::gil_scoped_release release;
      s = client_->watch(
          id,
          [&](const v1::JobEvent& e) {
            if (!on_event) return;
            py::gil_scoped_acquire acquire;
            if (error) return;
            try {
              (*on_event)(nlohmann::json{{"job", cli::job_json(e.job())}, {"elapsed_s", e.elapsed_s()}}.dump());
            } catch (py::error_already_set& e2) {
              error = std::move(e2);
            }
          },
          last);
    }
    if (error) throw *error;
    if (!s.ok()) raise_grpc(s, "watch");
    return cli::job_json(last).dump();
  }

  std::string list() {
    v1::ListJobsResponse jobs;
    grpc::Status s;
    {
      py::gil_scoped_release release;
      s = client_->list(jobs);
    }
    if (!s.ok()) raise_grpc(s, "list");
    nlohmann::json out = nlohmann::json::array();
    for (const auto& j : jobs.jobs()) out.push_back(cli::job_json(j));
    return out.dump();
  }

  std::string cancel(const std::string& id) { return job_call(id, &cli::ServiceClient::cancel, "cancel"); }
  std::string remove(const std::string& id) { return job_call(id, &cli::ServiceClient::remove, "delete"); }

  /// Writes the result in the format `path`'s suffix names; its size in bytes.
  std::uint64_t fetch(const std::string& id, const std::filesystem::path& path) {
    if (!volume_format_from_path(path).ok())
      throw py::value_error(
          fmt::format("{}: the suffix names no volume mesh format ({})", path.string(), volume_format_suffixes()));
    std::uint64_t bytes = 0;
    grpc::Status s;
    {
      py::gil_scoped_release release;
      s = client_->fetch(id, path, &bytes);
    }
    if (!s.ok()) raise_grpc(s, "fetch");
    return bytes;
  }

 private:
  using JobCall = grpc::Status (cli::ServiceClient::*)(std::string_view, v1::Job&);
  std::string job_call(const std::string& id, JobCall call, const char* what) {
    v1::Job job;
    grpc::Status s;
    {
      py::gil_scoped_release release;
      s = (client_.get()->*call)(id, job);
    }
    if (!s.ok()) raise_grpc(s, what);
    return cli::job_json(job).dump();
  }

  std::unique_ptr<cli::ServiceClient> client_;
};

}  // namespace

void bind_service(py::module_& m) {
  using py::arg;
  py::class_<Client>(m, "ServiceClient")
      .def(py::init<const std::string&, const std::string&, const std::string&, double>(), arg("server"),
           arg("token"), arg("tls_ca"), arg("timeout"))
      .def("submit", &Client::submit, arg("surface"), arg("size"), arg("hmin"), arg("hmax"), arg("growth"),
           arg("max_tets"), arg("depth"), arg("kernel"), arg("optimize"), arg("time_limit"), arg("names"),
           arg("farfield"), arg("farfield_shape"), arg("layers"))
      .def("get", &Client::get, arg("job"))
      .def("watch", &Client::watch, arg("job"), arg("on_event"))
      .def("list", &Client::list)
      .def("cancel", &Client::cancel, arg("job"))
      .def("delete", &Client::remove, arg("job"))
      .def("fetch", &Client::fetch, arg("job"), arg("path"));
}

}  // namespace pdrmesh::python
