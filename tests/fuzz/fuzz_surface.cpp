// SPDX-License-Identifier: AGPL-3.0-or-later
// Fuzz target for one surface reader (compiled once per format, FUZZ_FORMAT):
// parse_surface must return a Status or a surface whose indices, ids and
// coordinates are valid; for the formats that keep everything (.mesh, .surf,
// .ply) writing and re-reading gives the same surface.
// FUZZ_STL_MODE 1 prefixes "solid" (the ASCII STL path), 2 an 80-byte header
// (the binary path: the input starts at the triangle count).
#include <string>

#include "fuzz_common.hpp"
#include "pdrmesh/surface_io.hpp"

#ifndef FUZZ_STL_MODE
#define FUZZ_STL_MODE 0
#endif

using namespace pdrmesh;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  constexpr SurfaceFormat format = SurfaceFormat::FUZZ_FORMAT;
  std::string bytes;
  if (FUZZ_STL_MODE == 1) bytes = "solid";
  if (FUZZ_STL_MODE == 2) bytes.assign(80, '\0');
  bytes.append(fuzz::bytes_of(data, size));
  Result<SurfaceMesh> s = parse_surface(bytes, format, "fuzz");
  if (!s.ok()) {
    FUZZ_REQUIRE(!s.status().message().empty());
    return 0;
  }
  FUZZ_REQUIRE(!s->triangles.empty());
  FUZZ_REQUIRE(s->surface_ids.size() == s->triangles.size());
  FUZZ_REQUIRE(fuzz::indices_below(s->triangles, s->points.size()));
  for (const Vec3& p : s->points) FUZZ_REQUIRE(fuzz::finite(p));
  Result<std::string> written = format_surface(*s, format);
  FUZZ_REQUIRE(written.ok());
  Result<SurfaceMesh> back = parse_surface(*written, format, "fuzz");
  FUZZ_REQUIRE(back.ok());
  FUZZ_REQUIRE(back->triangles.size() == s->triangles.size());
  if (format == SurfaceFormat::kMedit || format == SurfaceFormat::kAflr3Surf || format == SurfaceFormat::kPly) {
    FUZZ_REQUIRE(back->points == s->points);
    FUZZ_REQUIRE(back->triangles == s->triangles);
    FUZZ_REQUIRE(back->surface_ids == s->surface_ids);
  }
  return 0;
}
