// SPDX-License-Identifier: AGPL-3.0-or-later
// PdrCheckpoint's bytes: the engine's state after a round, to resume from.
#include <fmt/format.h>

#include <cstring>
#include <tuple>
#include <type_traits>

#include "pdrmesh/byte_codec.hpp"
#include "pdrmesh/digest.hpp"
#include "pdrmesh/pdr.hpp"

namespace pdrmesh {

namespace {

constexpr char kCheckpointMagic[8] = {'P', 'D', 'R', 'C', 'K', 'P', 'T', '\0'};
constexpr std::uint32_t kCheckpointVersion = 1;

Status checkpoint_error(std::string_view what) {
  return invalid_input(fmt::format("PDR checkpoint: {}", what));
}

}  // namespace

std::string PdrCheckpoint::encode() const {
  codec::Writer w;
  w.bytes(kCheckpointMagic, sizeof kCheckpointMagic);
  w.u32(kCheckpointVersion);
  w.u32(static_cast<std::uint32_t>(rounds_done));
  w.u64(round.size());
  w.bytes(round.data(), round.size());
  w.u64(mesh.points.size());
  for (const Vec3& p : mesh.points)
    for (double c : p) w.f64(c);
  w.u64(mesh.tets.size());
  for (const Tet& t : mesh.tets)
    for (Index v : t) w.u32(v);
  w.u64(mesh.boundary.size());
  for (const Tri& f : mesh.boundary)
    for (Index v : f) w.u32(v);
  w.u64(mesh.boundary_ids.size());
  for (int id : mesh.boundary_ids) w.u32(static_cast<std::uint32_t>(id));
  w.u64(mesh.tet_regions.size());
  for (int r : mesh.tet_regions) w.u32(static_cast<std::uint32_t>(r));
  std::string bytes = w.take();
  codec::Writer tail;
  tail.u64(content_digest(bytes));
  bytes += tail.take();  // appended: no second copy of a large mesh's bytes
  return bytes;
}

Result<PdrCheckpoint> PdrCheckpoint::decode(std::string_view bytes) {
  // The digest at the end first: a file cut short or damaged is refused whole.
  std::uint64_t digest = 0;
  if (bytes.size() < 8 || !codec::Reader(bytes.substr(bytes.size() - 8)).u64(digest) ||
      digest != content_digest(bytes.substr(0, bytes.size() - 8))) {
    return checkpoint_error("the bytes do not match their digest (cut short or damaged)");
  }
  bytes.remove_suffix(8);
  codec::Reader r(bytes);
  char magic[8];
  std::uint32_t version = 0, rounds = 0;
  if (!r.bytes(magic, 8) || std::memcmp(magic, kCheckpointMagic, 8) != 0 || !r.u32(version) ||
      version != kCheckpointVersion) {
    return checkpoint_error("bad magic or version");
  }
  PdrCheckpoint c;
  std::size_t n = 0;
  if (!r.u32(rounds) || rounds > 64 || !r.count(1, n)) return checkpoint_error("truncated header");
  c.rounds_done = static_cast<int>(rounds);
  c.round.resize(n);
  if (!r.bytes(c.round.data(), n)) return checkpoint_error("truncated round name");
  if (!r.count(24, n)) return checkpoint_error("bad point count");
  c.mesh.points.resize(n);
  for (Vec3& p : c.mesh.points)
    for (double& x : p) r.f64(x);
  const auto indices = [&](auto& items, const char* what) -> Status {
    constexpr std::size_t k = std::tuple_size_v<typename std::decay_t<decltype(items)>::value_type>;
    if (!r.count(4 * k, n)) return checkpoint_error(fmt::format("bad {} count", what));
    items.resize(n);
    for (auto& item : items) {
      for (Index& v : item) {
        r.u32(v);
        if (v >= c.mesh.points.size()) return checkpoint_error(fmt::format("{} index {} out of range", what, v));
      }
    }
    return {};
  };
  const auto ints = [&](std::vector<int>& items, std::size_t expected, const char* what) -> Status {
    if (!r.count(4, n) || n != expected) {
      return checkpoint_error(fmt::format("bad {} count", what));
    }
    items.resize(n);
    for (int& x : items) {
      std::uint32_t u = 0;
      r.u32(u);
      x = static_cast<int>(u);
    }
    return {};
  };
  PDR_TRY(indices(c.mesh.tets, "tet"));
  PDR_TRY(indices(c.mesh.boundary, "boundary face"));
  PDR_TRY(ints(c.mesh.boundary_ids, c.mesh.boundary.size(), "boundary id"));
  PDR_TRY(ints(c.mesh.tet_regions, c.mesh.tets.size(), "tet region"));
  if (r.left() != 0) return checkpoint_error(fmt::format("{} bytes after the end", r.left()));
  return c;
}

}  // namespace pdrmesh
