// SPDX-License-Identifier: AGPL-3.0-or-later
// Jobs and gRPC status codes as the service commands print them (and the
// Python module returns them): one JSON shape for `status --json`, `list
// --json`, `watch --json` and pdrmesh.Client.
#pragma once

#include <grpcpp/grpcpp.h>

#include <nlohmann/json.hpp>
#include <string>

#include "pdrmesh/v1/pdrmesh.pb.h"

namespace pdrmesh::cli {

/// "INVALID_ARGUMENT", "UNAVAILABLE", ...
std::string code_name(grpc::StatusCode c);

/// A job state as the text output names it: "queued", "running", "succeeded", ...
std::string state_name(v1::JobState s);

/// The options a job was submitted with: the ones set.
nlohmann::json options_json(const v1::MeshOptions& o);

/// A job as JSON: the proto's field names, numbers as numbers (not the strings
/// of protobuf's JSON mapping of 64-bit integers), the state as state_name says it.
nlohmann::json job_json(const v1::Job& j);

}  // namespace pdrmesh::cli
