// SPDX-License-Identifier: AGPL-3.0-or-later
// Fuzz target for the coordinator's decoding of a client request, without a
// server. First byte even: the rest is a serialized SubmitRequest (what
// SubmitJob reads first): its header's MeshOptions through from_proto. Odd:
// the rest is stored job options JSON through JobOptions::from_json. Accepted
// options must validate, and survive to_json / from_json and to_proto /
// from_proto unchanged (what the JobStore and GetJob do with them); a number
// the client sent must be the number the job gets.
#include <nlohmann/json.hpp>

#include "fuzz_common.hpp"
#include "job_runner.hpp"
#include "job_service.hpp"

using namespace pdrmesh;
using namespace pdrmesh::server;

namespace {

void check_accepted(const JobOptions& o) {
  FUZZ_REQUIRE(o.validate().ok());
  const std::string json = o.to_json();
  Result<JobOptions> back = JobOptions::from_json(json);
  FUZZ_REQUIRE(back.ok());
  FUZZ_REQUIRE(back->to_json() == json);
  v1::MeshOptions proto;
  to_proto(o, proto);
  Result<JobOptions> again = from_proto(proto, JobOptions{});
  FUZZ_REQUIRE(again.ok());
  FUZZ_REQUIRE(again->to_json() == json);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view rest = fuzz::bytes_of(data + 1, size - 1);
  if (data[0] % 2 == 0) {
    v1::SubmitRequest request;
    if (!request.ParseFromArray(rest.data(), static_cast<int>(rest.size())) || !request.has_header()) return 0;
    const v1::SubmitHeader& header = request.header();
    Result<JobOptions> o = from_proto(header.options(), JobOptions{});
    if (!o.ok()) return 0;
    check_accepted(*o);
    if (header.options().has_depth()) FUZZ_REQUIRE(o->depth == header.options().depth());
    return 0;
  }
  Result<JobOptions> o = JobOptions::from_json(rest);
  if (!o.ok()) return 0;
  check_accepted(*o);
  const nlohmann::json j = nlohmann::json::parse(rest, nullptr, false);
  if (j.contains("depth")) FUZZ_REQUIRE(j["depth"] == o->depth);
  if (j.contains("time_limit_s")) FUZZ_REQUIRE(j["time_limit_s"].get<double>() == o->time_limit_s);
  return 0;
}
