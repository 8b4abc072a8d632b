// SPDX-License-Identifier: AGPL-3.0-or-later
// PDR data decomposition: leaf assignment by barycenter, N1/N2 neighbourhoods and
// interface faces (see decomposition.hpp).
#include "pdrmesh/decomposition.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>

#include <fmt/format.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_sort.h>

namespace pdrmesh {
namespace {


/// One face of one tet, keyed by its sorted vertices; `packed` = 4 * tet + face.
struct FaceRecord {
  std::array<Index, 3> key;
  Index packed;
  bool operator<(const FaceRecord& o) const {
    return std::tie(key, packed) < std::tie(o.key, o.packed);
  }
};

Result<Decomposition> decompose_impl(const VolumeMesh& mesh, int depth, const Box& box, bool interfaces);

}  // namespace

LeafId leaf_of_point(const Box& box, int depth, const Vec3& p) {
  depth = std::clamp(depth, 0, kMaxDepth);
  const std::int64_t n = std::int64_t{1} << depth;
  std::int64_t c[3];
  for (int a = 0; a < 3; ++a) {
    const double w = box.hi[a] - box.lo[a];
    const double t = w > 0 ? (p[a] - box.lo[a]) / w * static_cast<double>(n) : 0.0;
    if (!(t >= 0)) {
      c[a] = 0;  // below the box, or NaN
    } else if (t >= static_cast<double>(n)) {
      c[a] = n - 1;
    } else {
      c[a] = static_cast<std::int64_t>(std::floor(t));
    }
  }
  return static_cast<LeafId>(c[0] + n * (c[1] + n * c[2]));
}

std::array<std::uint32_t, 3> leaf_coords(LeafId id, int depth) {
  const std::uint32_t mask = (std::uint32_t{1} << depth) - 1;
  return {id & mask, (id >> depth) & mask, (id >> (2 * depth)) & mask};
}

Box leaf_box(const Box& box, int depth, LeafId id) {
  const auto c = leaf_coords(id, depth);
  const double n = static_cast<double>(std::int64_t{1} << depth);
  Box b;
  for (int a = 0; a < 3; ++a) {
    const double w = box.hi[a] - box.lo[a];
    b.lo[a] = box.lo[a] + static_cast<double>(c[a]) * w / n;
    b.hi[a] = box.lo[a] + static_cast<double>(c[a] + 1) * w / n;
  }
  return b;
}

Vec3 tet_barycenter(const VolumeMesh& mesh, Index t) {
  const Tet& v = mesh.tets[t];
  const auto& P = mesh.points;
  return 0.25 * ((P[v[0]] + P[v[1]]) + (P[v[2]] + P[v[3]]));
}

Result<Decomposition> decompose(const VolumeMesh& mesh, int depth) {
  Box bb;
  for (const Vec3& p : mesh.points) bb.add(p);
  return decompose(mesh, depth, root_cube(bb));
}

Result<Decomposition> decompose(const VolumeMesh& mesh, int depth, const Box& box) {
  return decompose_impl(mesh, depth, box, true);
}

Result<Decomposition> decompose_leaves(const VolumeMesh& mesh, int depth, const Box& box) {
  return decompose_impl(mesh, depth, box, false);
}

namespace {

Result<Decomposition> decompose_impl(const VolumeMesh& mesh, int depth, const Box& box, bool interfaces) {
  if (depth < 0 || depth > kMaxDepth) {
    return invalid_input(fmt::format("octree depth {} is outside [0, {}]", depth, kMaxDepth));
  }
  const std::size_t nt = mesh.tets.size();
  if (nt >= (std::size_t{1} << 30)) {
    return resource_exhausted(fmt::format("{} tets are too many for one decomposition", nt));
  }
  for (std::size_t t = 0; t < nt; ++t) {
    for (Index v : mesh.tets[t]) {
      if (v >= mesh.points.size()) {
        return invalid_input(fmt::format("tet {} refers to point {}, but the mesh has {} points",
                                         t, v, mesh.points.size()));
      }
    }
  }

  Decomposition d;
  d.depth = depth;
  d.per_side = 1 << depth;
  d.box = box;

  // Leaf assignment by barycenter.
  std::vector<LeafId> grid_of_tet(nt);
  tbb::parallel_for(std::size_t{0}, nt, [&](std::size_t t) {
    grid_of_tet[t] = leaf_of_point(d.box, depth, tet_barycenter(mesh, static_cast<Index>(t)));
  });
  d.leaves = grid_of_tet;
  tbb::parallel_sort(d.leaves.begin(), d.leaves.end());
  d.leaves.erase(std::unique(d.leaves.begin(), d.leaves.end()), d.leaves.end());
  const std::size_t nl = d.leaves.size();
  auto index_of = [&](LeafId id) -> Index {
    const auto it = std::lower_bound(d.leaves.begin(), d.leaves.end(), id);
    return it != d.leaves.end() && *it == id ? static_cast<Index>(it - d.leaves.begin()) : kNoIndex;
  };
  d.tet_leaf.resize(nt);
  d.leaf_tets.assign(nl, {});
  tbb::parallel_for(std::size_t{0}, nt, [&](std::size_t t) { d.tet_leaf[t] = index_of(grid_of_tet[t]); });
  {
    std::vector<std::size_t> count(nl, 0);
    for (Index l : d.tet_leaf) ++count[l];
    for (std::size_t l = 0; l < nl; ++l) d.leaf_tets[l].reserve(count[l]);
  }
  for (std::size_t t = 0; t < nt; ++t) d.leaf_tets[d.tet_leaf[t]].push_back(static_cast<Index>(t));

  d.n1 = grid_n1(d.leaves, depth);
  // N2: n1 of the n1 members, less {L} and n1 (stamp[x] == l: x seen for l).
  d.n2.assign(nl, {});
  std::vector<Index> stamp(nl, kNoIndex);
  for (std::size_t l = 0; l < nl; ++l) {
    const Index li = static_cast<Index>(l);
    stamp[l] = li;
    for (Index m : d.n1[l]) stamp[m] = li;
    std::vector<Index>& out = d.n2[l];
    for (Index m : d.n1[l]) {
      for (Index x : d.n1[m]) {
        if (stamp[x] != li) {
          stamp[x] = li;
          out.push_back(x);
        }
      }
    }
    std::sort(out.begin(), out.end());
  }

  d.interface_faces.assign(nl, {});
  if (!interfaces) return d;
  // Interface faces: pair up equal face keys after a sort (a total order, so the
  // outcome does not depend on the sort algorithm or thread count).
  std::vector<FaceRecord> faces;
  faces.reserve(4 * nt);
  for (std::size_t t = 0; t < nt; ++t) {
    const Tet& v = mesh.tets[t];
    for (int f = 0; f < 4; ++f) {
      std::array<Index, 3> key;
      int m = 0;
      for (int q = 0; q < 4; ++q) {
        if (q != f) key[static_cast<std::size_t>(m++)] = v[static_cast<std::size_t>(q)];
      }
      std::sort(key.begin(), key.end());
      faces.push_back({key, static_cast<Index>(4 * t + static_cast<std::size_t>(f))});
    }
  }
  tbb::parallel_sort(faces.begin(), faces.end());
  for (std::size_t i = 0; i < faces.size();) {
    std::size_t j = i + 1;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j - i > 2) {
      const auto& k = faces[i].key;
      return invalid_input(fmt::format("face ({}, {}, {}) is shared by {} tets (tets {}, {}, {}, ...)",
                                       k[0], k[1], k[2], j - i, faces[i].packed / 4,
                                       faces[i + 1].packed / 4, faces[i + 2].packed / 4));
    }
    if (j - i == 2) {
      const Index a = faces[i].packed, b = faces[i + 1].packed;
      const Index la = d.tet_leaf[a / 4], lb = d.tet_leaf[b / 4];
      if (la != lb) {
        d.interface_faces[la].emplace_back(a / 4, static_cast<int>(a % 4));
        d.interface_faces[lb].emplace_back(b / 4, static_cast<int>(b % 4));
      }
    }
    i = j;
  }
  for (auto& list : d.interface_faces) std::sort(list.begin(), list.end());
  return d;
}

}  // namespace

std::vector<std::vector<Index>> grid_n1(std::span<const LeafId> leaves, int depth) {
  depth = std::clamp(depth, 0, kMaxDepth);
  auto index_of = [&](LeafId id) -> Index {
    const auto it = std::lower_bound(leaves.begin(), leaves.end(), id);
    return it != leaves.end() && *it == id ? static_cast<Index>(it - leaves.begin()) : kNoIndex;
  };
  // The 26-neighbourhood, visited in ascending grid id (k, then j, then i).
  const std::int64_t n = std::int64_t{1} << depth;
  std::vector<std::vector<Index>> n1(leaves.size());
  for (std::size_t l = 0; l < leaves.size(); ++l) {
    const auto c = leaf_coords(leaves[l], depth);
    for (std::int64_t dk = -1; dk <= 1; ++dk) {
      for (std::int64_t dj = -1; dj <= 1; ++dj) {
        for (std::int64_t di = -1; di <= 1; ++di) {
          if (di == 0 && dj == 0 && dk == 0) continue;
          const std::int64_t i = c[0] + di, j = c[1] + dj, k = c[2] + dk;
          if (i < 0 || j < 0 || k < 0 || i >= n || j >= n || k >= n) continue;
          const Index m = index_of(static_cast<LeafId>(i + n * (j + n * k)));
          if (m != kNoIndex) n1[l].push_back(m);
        }
      }
    }
  }
  return n1;
}

Box root_cube(const Box& bb) {
  double side = 0;
  for (int a = 0; a < 3; ++a) side = std::max(side, bb.hi[a] - bb.lo[a]);
  side *= 1.0 + 1e-6;
  if (!(side > 0)) side = 1.0;  // a single point (or nothing): any cube will do
  Box cube;
  for (int a = 0; a < 3; ++a) {
    const double centre = 0.5 * (bb.lo[a] + bb.hi[a]);
    cube.lo[a] = centre - 0.5 * side;
    cube.hi[a] = centre + 0.5 * side;
  }
  return cube;
}

int default_depth(std::size_t target_tets, std::size_t tets_per_leaf) {
  return default_depth(target_tets, tets_per_leaf, [](int d) { return std::size_t{1} << (3 * d); });
}

int default_depth(std::size_t target_tets, std::size_t tets_per_leaf,
                  const std::function<std::size_t(int depth)>& occupied_leaves) {
  tets_per_leaf = std::max<std::size_t>(tets_per_leaf, 1);
  const std::size_t leaves = target_tets / tets_per_leaf + (target_tets % tets_per_leaf != 0 ? 1 : 0);
  const auto occupied = [&](int d) {
    return std::clamp<std::size_t>(occupied_leaves(d), 1, std::size_t{1} << (3 * d));
  };
  int d = 0;
  while (d < kMaxDepth && occupied(d) < leaves) ++d;
  return d;
}

std::size_t occupied_leaves_estimate(std::span<const Vec3> surface_points, double enclosed_volume, int depth) {
  Box bb;
  for (const Vec3& p : surface_points) bb.add(p);
  const Box cube = root_cube(bb);
  std::vector<LeafId> cells(surface_points.size());
  for (std::size_t i = 0; i < surface_points.size(); ++i) cells[i] = leaf_of_point(cube, depth, surface_points[i]);
  std::sort(cells.begin(), cells.end());
  const auto touched = static_cast<std::size_t>(std::unique(cells.begin(), cells.end()) - cells.begin());
  const double leaf_side = (cube.hi[0] - cube.lo[0]) / static_cast<double>(std::size_t{1} << depth);
  const double by_volume = enclosed_volume / (leaf_side * leaf_side * leaf_side);
  const double filled = std::isfinite(by_volume) ? std::clamp(by_volume, 0.0, 1e18) : 0.0;
  return std::max(touched, static_cast<std::size_t>(std::ceil(filled)));
}

}  // namespace pdrmesh
