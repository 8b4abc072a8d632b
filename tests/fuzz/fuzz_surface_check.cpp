// SPDX-License-Identifier: AGPL-3.0-or-later
// Fuzz target for the surface check. Even first byte: the rest is an OFF file
// (parse, then check). Odd: a compact surface of small integer coordinates
// (many coplanar, touching and crossing triangles, which is what the exact
// predicates must get right): byte 1 gives 4..16 points, then 3 signed bytes
// per point (-128 reads as infinity), then 3 bytes per triangle, each index
// modulo n + 1 (n itself is out of range), at most 48 triangles.
// The report must be consistent: listed defects capped per kind, component
// sizes adding up, a meshable report only for closed, manifold, outward
// components, and its JSON must parse.
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include <algorithm>
#include <limits>

#include "fuzz_common.hpp"
#include "pdrmesh/surface_check.hpp"
#include "pdrmesh/surface_io.hpp"

using namespace pdrmesh;

namespace {

SurfaceMesh compact_surface(const std::uint8_t* data, std::size_t size) {
  SurfaceMesh s;
  s.name = "fuzz";
  if (size < 2) return s;
  const std::size_t n = 4 + data[1] % 13;
  std::size_t pos = 2;
  auto coordinate = [&]() -> double {
    const auto v = static_cast<std::int8_t>(pos < size ? data[pos] : 0);
    ++pos;
    return v == -128 ? std::numeric_limits<double>::infinity() : double(v);
  };
  for (std::size_t i = 0; i < n; ++i) {
    const double x = coordinate(), y = coordinate(), z = coordinate();
    s.points.push_back({x, y, z});
  }
  while (pos + 3 <= size && s.triangles.size() < 48) {
    Tri t;
    for (Index& v : t) v = static_cast<Index>(data[pos++] % (n + 1));
    s.triangles.push_back(t);
    s.surface_ids.push_back(1);
  }
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // One thread: TBB's wake-ups would cost more than these small checks, and the
  // runs stay reproducible.
  static tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  if (size == 0) return 0;
  SurfaceMesh s;
  if (data[0] % 2 == 0) {
    Result<SurfaceMesh> parsed = parse_surface(fuzz::bytes_of(data + 1, size - 1), SurfaceFormat::kOff, "fuzz.off");
    if (!parsed.ok() || parsed->triangles.size() > 256) return 0;
    s = std::move(*parsed);
  } else {
    s = compact_surface(data, size);
  }
  CheckOptions options;
  options.max_defects_per_kind = 3;
  const SurfaceReport r = check_surface(s, options);
  FUZZ_REQUIRE(r.points == s.points.size() && r.triangles == s.triangles.size());
  for (std::size_t k = 0; k < kDefectKinds; ++k) {
    const auto listed = static_cast<std::size_t>(std::count_if(
        r.defects.begin(), r.defects.end(), [&](const Defect& d) { return static_cast<std::size_t>(d.kind) == k; }));
    FUZZ_REQUIRE(listed == std::min(r.defect_counts[k], options.max_defects_per_kind));
  }
  for (const Defect& d : r.defects) {
    FUZZ_REQUIRE(!d.message.empty());
    for (Index t : d.triangles) FUZZ_REQUIRE(t < s.triangles.size());
  }
  std::size_t in_components = 0;
  for (const ComponentReport& c : r.components) {
    in_components += c.triangles;
    FUZZ_REQUIRE(c.first_triangle < s.triangles.size());
    if (r.meshable()) FUZZ_REQUIRE(c.closed && c.manifold && c.consistently_oriented && c.outward && c.genus >= 0);
  }
  FUZZ_REQUIRE(in_components <= s.triangles.size());
  FUZZ_REQUIRE(require_meshable(r, "fuzz").ok() == r.meshable());
  FUZZ_REQUIRE(!format_report(r, "fuzz").empty());
  FUZZ_REQUIRE(!nlohmann::json::parse(report_to_json(r, "fuzz"), nullptr, false).is_discarded());
  return 0;
}
