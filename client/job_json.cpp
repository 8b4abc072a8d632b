// SPDX-License-Identifier: AGPL-3.0-or-later
#include "job_json.hpp"

#include <fmt/format.h>

#include <cctype>
#include <map>
#include <string>
#include <string_view>

namespace pdrmesh::cli {

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

std::string state_name(v1::JobState s) {
  std::string name = v1::JobState_Name(s);
  constexpr std::string_view kPrefix = "JOB_STATE_";
  if (name.rfind(kPrefix, 0) == 0) name = name.substr(kPrefix.size());
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return name;
}

nlohmann::json options_json(const v1::MeshOptions& o) {
  nlohmann::json j = nlohmann::json::object();
  if (o.has_max_volume()) j["max_volume"] = o.max_volume();
  if (o.has_time_limit_s()) j["time_limit_s"] = o.time_limit_s();
  if (o.has_size()) j["size"] = o.size();
  if (o.has_hmin()) j["hmin"] = o.hmin();
  if (o.has_hmax()) j["hmax"] = o.hmax();
  if (o.has_growth()) j["growth"] = o.growth();
  if (o.has_depth()) j["depth"] = o.depth();
  if (o.has_kernel()) j["kernel"] = o.kernel();
  if (o.has_interface_round()) j["interface_round"] = o.interface_round();
  if (o.has_optimize()) j["optimize"] = o.optimize();
  // Ascending ids, so the output does not depend on the map's order.
  const std::map<int, std::string> names(o.surface_names().begin(), o.surface_names().end());
  for (const auto& [id, name] : names) j["surface_names"][std::to_string(id)] = name;
  if (o.has_farfield()) j["farfield"] = o.farfield();
  if (o.has_farfield_shape()) j["farfield_shape"] = o.farfield_shape();
  return j;
}

nlohmann::json job_json(const v1::Job& j) {
  return {{"id", j.id()},
          {"user", j.user()},
          {"state", state_name(j.state())},
          {"phase", j.phase()},
          {"progress", j.progress()},
          {"options", options_json(j.options())},
          {"input_name", j.input_name()},
          {"input_bytes", j.input_bytes()},
          {"created_unix_ms", j.created_unix_ms()},
          {"started_unix_ms", j.started_unix_ms()},
          {"finished_unix_ms", j.finished_unix_ms()},
          {"error", j.error()},
          {"tets", j.tets()},
          {"points", j.points()},
          {"leaves_done", j.leaves_done()},
          {"leaves_total", j.leaves_total()}};
}

}  // namespace pdrmesh::cli
