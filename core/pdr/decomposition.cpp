// SPDX-License-Identifier: AGPL-3.0-or-later
// PDR data decomposition: leaf assignment by barycenter, N1/N2 neighbourhoods and
// interface faces (see decomposition.hpp).
#include "pdrmesh/decomposition.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <tuple>

#include <fmt/format.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_sort.h>

#include "pdrmesh/fixed_chunks.hpp"

namespace pdrmesh {
namespace {

constexpr std::size_t kTetGrain = 16384;
constexpr std::size_t kPointGrain = 8192;

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
  const std::size_t np = mesh.points.size();
  if (nt >= (std::size_t{1} << 30)) {
    return resource_exhausted(fmt::format("{} tets are too many for one decomposition", nt));
  }
  // Every pass below runs over fixed chunks (fixed_chunks.hpp), combined in
  // chunk order: the result does not depend on the number of threads.
  {
    std::vector<std::size_t> first_bad(detail::chunk_count(nt, kTetGrain), nt);  // per chunk
    detail::for_each_chunk(nt, kTetGrain, [&](std::size_t c, std::size_t lo, std::size_t hi) {
      for (std::size_t t = lo; t < hi && first_bad[c] == nt; ++t) {
        for (Index v : mesh.tets[t]) {
          if (v >= np) first_bad[c] = t;
        }
      }
    });
    for (const std::size_t t : first_bad) {
      if (t == nt) continue;
      const Tet& k = mesh.tets[t];
      const Index v = *std::find_if(k.begin(), k.end(), [&](Index x) { return x >= np; });
      return invalid_input(fmt::format("tet {} refers to point {}, but the mesh has {} points", t, v, np));
    }
  }

  Decomposition d;
  d.depth = depth;
  d.per_side = 1 << depth;
  d.box = box;

  // Leaf assignment by barycenter; the non-empty leaves from each chunk's own.
  std::vector<LeafId> grid_of_tet(nt);
  {
    std::vector<std::vector<LeafId>> chunk_leaves(detail::chunk_count(nt, kTetGrain));
    detail::for_each_chunk(nt, kTetGrain, [&](std::size_t c, std::size_t lo, std::size_t hi) {
      for (std::size_t t = lo; t < hi; ++t) {
        grid_of_tet[t] = leaf_of_point(d.box, depth, tet_barycenter(mesh, static_cast<Index>(t)));
      }
      auto& own = chunk_leaves[c];  // runs of one leaf first (neighbouring tets share leaves), then sorted
      std::unique_copy(grid_of_tet.begin() + static_cast<std::ptrdiff_t>(lo),
                       grid_of_tet.begin() + static_cast<std::ptrdiff_t>(hi), std::back_inserter(own));
      std::sort(own.begin(), own.end());
      own.erase(std::unique(own.begin(), own.end()), own.end());
    });
    for (const auto& own : chunk_leaves) d.leaves.insert(d.leaves.end(), own.begin(), own.end());
    tbb::parallel_sort(d.leaves.begin(), d.leaves.end());
    d.leaves.erase(std::unique(d.leaves.begin(), d.leaves.end()), d.leaves.end());
  }
  const std::size_t nl = d.leaves.size();
  auto index_of = [&](LeafId id) -> Index {
    const auto it = std::lower_bound(d.leaves.begin(), d.leaves.end(), id);
    return it != d.leaves.end() && *it == id ? static_cast<Index>(it - d.leaves.begin()) : kNoIndex;
  };
  d.tet_leaf.resize(nt);
  tbb::parallel_for(std::size_t{0}, nt, [&](std::size_t t) { d.tet_leaf[t] = index_of(grid_of_tet[t]); });
  // leaf_tets: a stable counting sort. at[c * nl + l] counts chunk c's tets in
  // leaf l, then becomes where they start in leaf_tets[l]. Chunks of at least
  // 16 nl tets keep the table within nt / 16 entries.
  d.leaf_tets.assign(nl, {});
  {
    const std::size_t grain = std::max(kTetGrain, 16 * nl);
    std::vector<Index> at(detail::chunk_count(nt, grain) * nl, 0);
    detail::for_each_chunk(nt, grain, [&](std::size_t c, std::size_t lo, std::size_t hi) {
      Index* row = at.data() + c * nl;
      for (std::size_t t = lo; t < hi; ++t) ++row[d.tet_leaf[t]];
    });
    tbb::parallel_for(std::size_t{0}, nl, [&](std::size_t l) {
      Index sum = 0;
      for (std::size_t i = l; i < at.size(); i += nl) {
        const Index k = at[i];
        at[i] = sum;
        sum += k;
      }
      d.leaf_tets[l].resize(sum);
    });
    detail::for_each_chunk(nt, grain, [&](std::size_t c, std::size_t lo, std::size_t hi) {
      Index* row = at.data() + c * nl;
      for (std::size_t t = lo; t < hi; ++t) {
        const Index l = d.tet_leaf[t];
        d.leaf_tets[l][row[l]++] = static_cast<Index>(t);
      }
    });
  }

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
  // Interface faces: equal faces are adjacent once grouped by their smallest
  // point and sorted (a total order); the points are scanned in chunks, each
  // stopping at its first face of more than two tets. The first such face in
  // that order is the error.
  struct Interface {
    Index leaf, tet;
    int face;
    bool operator<(const Interface& o) const { return std::tie(leaf, tet, face) < std::tie(o.leaf, o.tet, o.face); }
  };
  const auto faces = detail::faces_by_smallest_point(mesh.tets, np);
  const auto& F = faces.items;
  const std::size_t chunks = detail::chunk_count(np, kPointGrain);
  std::vector<std::vector<Interface>> found(chunks);
  std::vector<std::pair<Index, std::size_t>> over_shared(chunks, {kNoIndex, 0});  // (point, first face) per chunk
  detail::for_each_chunk(np, kPointGrain, [&](std::size_t c, std::size_t lo, std::size_t hi) {
    for (std::size_t a = lo; a < hi && over_shared[c].first == kNoIndex; ++a) {
      for (std::size_t i = faces.first[a], end = faces.first[a + 1]; i < end;) {
        std::size_t j = i + 1;
        while (j < end && F[j].b == F[i].b && F[j].c == F[i].c) ++j;
        if (j - i > 2) {
          over_shared[c] = {static_cast<Index>(a), i};
          break;
        }
        if (j - i == 2) {
          const Index la = d.tet_leaf[F[i].tet], lb = d.tet_leaf[F[i + 1].tet];
          if (la != lb) {
            found[c].push_back({la, F[i].tet, static_cast<int>(F[i].slot)});
            found[c].push_back({lb, F[i + 1].tet, static_cast<int>(F[i + 1].slot)});
          }
        }
        i = j;
      }
    }
  });
  for (const auto& [a, i] : over_shared) {
    if (a == kNoIndex) continue;
    std::size_t j = i + 1;
    while (j < faces.first[a + 1] && F[j].b == F[i].b && F[j].c == F[i].c) ++j;
    return invalid_input(fmt::format("face ({}, {}, {}) is shared by {} tets (tets {}, {}, {}, ...)", a, F[i].b, F[i].c,
                                     j - i, F[i].tet, F[i + 1].tet, F[i + 2].tet));
  }
  std::vector<Interface> all;
  for (auto& part : found) {
    all.insert(all.end(), part.begin(), part.end());
    part = {};
  }
  tbb::parallel_sort(all.begin(), all.end());
  for (const Interface& x : all) d.interface_faces[x.leaf].emplace_back(x.tet, x.face);
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
