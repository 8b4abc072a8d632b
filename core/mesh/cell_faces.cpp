// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/cell_faces.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <numeric>
#include <tuple>

#include "pdrmesh/fixed_chunks.hpp"
#include "pdrmesh/topology.hpp"

namespace pdrmesh {

Result<CellFaces> cell_faces(std::span<const Tet> tets, std::size_t points) {
  // Equal faces are adjacent in faces_by_smallest_point's buckets, the lower
  // tet first; a pair is an internal face owned by the lower tet, a single
  // face is on the hull.
  const detail::Buckets<detail::FaceRef> refs = detail::faces_by_smallest_point(tets, points);
  struct Internal {
    Index owner, neighbour;
    std::uint32_t slot;  // the owner's local face
  };
  std::vector<Internal> internal;
  std::vector<std::pair<Index, std::uint32_t>> hull;  // (tet, local face)
  internal.reserve(2 * tets.size() + 2);
  Status bad;
  for (std::size_t a = 0; a < points && bad.ok(); ++a) {
    detail::for_each_face_group(refs, a, [&](std::span<const detail::FaceRef> g) {
      if (g.size() == 1) {
        hull.emplace_back(g[0].tet, g[0].slot);
      } else if (g.size() == 2 && g[0].tet != g[1].tet) {
        internal.push_back({g[0].tet, g[1].tet, g[0].slot});
      } else if (bad.ok()) {
        bad = invalid_input(fmt::format("face ({}, {}, {}) is shared by {} tet faces (tets {} and {}, ...); a "
                                        "face belongs to one or two tets",
                                        a, g[0].b, g[0].c, g.size(), g[0].tet, g[1].tet));
      }
    });
  }
  PDR_TRY(bad);
  std::sort(internal.begin(), internal.end(), [](const Internal& x, const Internal& y) {
    return std::tie(x.owner, x.neighbour) < std::tie(y.owner, y.neighbour);
  });
  std::sort(hull.begin(), hull.end());

  CellFaces out;
  const std::size_t n = internal.size() + hull.size();
  out.faces.reserve(n);
  out.owner.reserve(n);
  out.neighbour.reserve(internal.size());
  for (const Internal& f : internal) {
    out.faces.push_back(topo::face_of(tets[f.owner], static_cast<int>(f.slot)));
    out.owner.push_back(f.owner);
    out.neighbour.push_back(f.neighbour);
  }
  for (const auto& [t, slot] : hull) {
    out.faces.push_back(topo::face_of(tets[t], static_cast<int>(slot)));
    out.owner.push_back(t);
  }
  return out;
}

}  // namespace pdrmesh
