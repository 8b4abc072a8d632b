// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/size_band.hpp"

#include <algorithm>
#include <utility>
#include <vector>

#include "pdrmesh/topology.hpp"

namespace pdrmesh {

SizeBand measure_size_band(const VolumeMesh& mesh, const SizingField& h) {
  std::vector<bool> on_boundary(mesh.points.size(), false);
  for (const Tri& t : mesh.boundary)
    for (Index v : t) on_boundary[v] = true;
  std::vector<std::pair<Index, Index>> edges;
  edges.reserve(mesh.tets.size() * 6);
  for (const Tet& k : mesh.tets)
    for (int e = 0; e < 6; ++e) {
      const Index a = k[topo::kEdgeVertex[e][0]], b = k[topo::kEdgeVertex[e][1]];
      if (!on_boundary[a] && !on_boundary[b]) edges.push_back({std::min(a, b), std::max(a, b)});
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  SizeBand band;
  band.edges = edges.size();
  for (const auto& [a, b] : edges) {
    const double size = h.at(0.5 * (mesh.points[a] + mesh.points[b]));
    const double l = norm(mesh.points[a] - mesh.points[b]);
    if (l < 0.6 * size) ++band.shorter;
    else if (l > 1.5 * size) ++band.longer;
    else ++band.within;
  }
  return band;
}

}  // namespace pdrmesh
