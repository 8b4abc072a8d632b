// SPDX-License-Identifier: AGPL-3.0-or-later
// Fuzz target for one volume mesh reader (compiled once per format,
// FUZZ_READER): it must return a Status or a mesh that every writer accepts
// (consistent sizes, indices in range, finite coordinates).
#include <string>

#include "fuzz_common.hpp"
#include "volume_io_detail.hpp"

using namespace pdrmesh;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes = fuzz::bytes_of(data, size);
  const std::string name = "fuzz";
  Result<VolumeMesh> m = volio::FUZZ_READER;
  if (!m.ok()) {
    FUZZ_REQUIRE(!m.status().message().empty());
    return 0;
  }
  FUZZ_REQUIRE(fuzz::indices_below(m->tets, m->points.size()));
  FUZZ_REQUIRE(fuzz::indices_below(m->boundary, m->points.size()));
  FUZZ_REQUIRE(volio::check_writable(*m).ok());
  return 0;
}
