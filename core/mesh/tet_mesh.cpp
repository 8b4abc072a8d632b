// SPDX-License-Identifier: AGPL-3.0-or-later
// TetMesh: construction from a VolumeMesh, adjacency rewriting, compaction and
// the validity check.
#include "pdrmesh/tet_mesh.hpp"

#include <fmt/format.h>
#include <oneapi/tbb/parallel_sort.h>

#include <algorithm>
#include <cassert>
#include <limits>
#include <string>
#include <tuple>

#include "pdrmesh/fixed_chunks.hpp"
#include "pdrmesh/predicates.hpp"
#include "pdrmesh/topology.hpp"

namespace pdrmesh {
namespace {

constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();

/// Puts v[order[i]] at v[i] and drops the rest, through one scratch copy of
/// the moved entries: the array keeps its capacity for the growth that
/// follows, and only one array's copy exists at a time (new arrays for all
/// four at once: armadillo's `pdrmesh mesh`, renumbered during refinement,
/// peaked at 286 MB, now 260 MB). A gather rather than an in-place walk of the
/// permutation's cycles, whose random swaps took about four times as long
/// (perf, sphere966 at diag/100) for 256 MB.
template <class T>
void permute(std::vector<T>& v, std::span<const Index> order) {
  std::vector<T> moved(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) moved[i] = v[order[i]];
  std::copy(moved.begin(), moved.end(), v.begin());
  v.resize(order.size());
}

std::string describe_tet(const Tet& k, Index t) {
  return fmt::format("tet {} (points {}, {}, {}, {})", t, k[0], k[1], k[2], k[3]);
}

}  // namespace

Result<TetMesh> TetMesh::from_volume_mesh(const VolumeMesh& mesh) {
  std::vector<GlobalId> ids(mesh.points.size());
  for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = i;
  return from_volume_mesh(mesh, std::move(ids), static_cast<GlobalId>(mesh.points.size()));
}

Result<TetMesh> TetMesh::from_volume_mesh(const VolumeMesh& mesh, std::vector<GlobalId> point_ids,
                                          GlobalId next_id) {
  if (point_ids.size() != mesh.points.size())
    return invalid_input(
        fmt::format("{} point ids given for {} points", point_ids.size(), mesh.points.size()));
  if (mesh.tets.size() >= kMaxTets)
    return resource_exhausted(
        fmt::format("{} tets exceed the refiner's limit of {}", mesh.tets.size(), kMaxTets - 1));
  if (mesh.points.size() >= kNoIndex)
    return resource_exhausted(fmt::format("{} points exceed the index range", mesh.points.size()));
  if (!mesh.tet_regions.empty() && mesh.tet_regions.size() != mesh.tets.size())
    return invalid_input(
        fmt::format("{} tet regions given for {} tets", mesh.tet_regions.size(), mesh.tets.size()));
  if (mesh.boundary_ids.size() != mesh.boundary.size())
    return invalid_input(fmt::format("{} boundary ids given for {} boundary triangles",
                                     mesh.boundary_ids.size(), mesh.boundary.size()));

  TetMesh m;
  m.points_ = mesh.points;
  m.ids_ = std::move(point_ids);
  m.next_id_ = next_id;
  m.cells_.resize(mesh.tets.size());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t)
    m.cells_[t] = {mesh.tets[t], {kNoIndex, kNoIndex, kNoIndex, kNoIndex}};
  m.regions_ = mesh.tet_regions;
  m.boundary_ = mesh.boundary;
  m.boundary_ids_ = mesh.boundary_ids;
  const Index nt = static_cast<Index>(mesh.tets.size());
  const Index np = static_cast<Index>(mesh.points.size());
  m.flags_.assign(nt, kAlive | kActive);
  m.quality_.assign(nt, kUnknown);
  m.alive_count_ = nt;

  for (Index t = 0; t < nt; ++t) {
    const Tet& k = m.cells_[t].v;
    for (Index v : k)
      if (v >= np)
        return invalid_input(
            fmt::format("{} refers to a point beyond the {} points", describe_tet(k, t), np));
    const auto& p = m.points_;
    if (exact::orient3d(p[k[0]], p[k[1]], p[k[2]], p[k[3]]) <= 0)
      return invalid_input(fmt::format("{} is not positively oriented (first point at {}, {}, {})",
                                       describe_tet(k, t), p[k[0]][0], p[k[0]][1], p[k[0]][2]));
  }

  // Every face by its sorted points (bucketed by the smallest: linear time),
  // so that equal faces are adjacent.
  const auto faces = detail::faces_by_smallest_point(std::span<const Tet>(mesh.tets), m.points_.size());
  const auto bucket = [&](Index a) {
    return std::span<const detail::FaceRef>(faces.items.data() + faces.first[a], faces.first[a + 1] - faces.first[a]);
  };
  std::string problem;
  for (Index a = 0; a < m.points_.size() && problem.empty(); ++a) {
    detail::for_each_face_group(faces, a, [&](std::span<const detail::FaceRef> group) {
      if (!problem.empty()) return;
      if (group.size() > 2) {
        problem = fmt::format("face (points {}, {}, {}) is shared by {} tets, first {}", a, group[0].b, group[0].c,
                              group.size(), group[0].tet);
      } else if (group.size() == 2) {
        const Index x = pack_face(group[0].tet, static_cast<int>(group[0].slot));
        const Index y = pack_face(group[1].tet, static_cast<int>(group[1].slot));
        if (face_tet(x) == face_tet(y)) {
          problem = fmt::format("tet {} has a repeated point", face_tet(x));
          return;
        }
        m.cells_[face_tet(x)].adj[face_local(x)] = y;
        m.cells_[face_tet(y)].adj[face_local(y)] = x;
      }
    });
  }
  if (!problem.empty()) return invalid_input(problem);

  for (std::size_t i = 0; i < mesh.boundary.size(); ++i) {
    const Tri key = topo::sorted_key(mesh.boundary[i]);
    const auto group = key[0] < m.points_.size() ? bucket(key[0]) : std::span<const detail::FaceRef>();
    const auto it = std::lower_bound(group.begin(), group.end(), key, [](const detail::FaceRef& f, const Tri& k) {
      return std::tie(f.b, f.c) < std::tie(k[1], k[2]);
    });
    if (it == group.end() || it->b != key[1] || it->c != key[2])
      return invalid_input(
          fmt::format("boundary triangle {} (points {}, {}, {}) is not a face of "
                      "any tet",
                      i, mesh.boundary[i][0], mesh.boundary[i][1], mesh.boundary[i][2]));
    m.set_frozen(it->tet, static_cast<int>(it->slot), true);
  }
  return m;
}

VolumeMesh TetMesh::to_volume_mesh() const {
  VolumeMesh out;
  out.points = points_;
  out.tets.reserve(alive_count_);
  if (!regions_.empty()) out.tet_regions.reserve(alive_count_);
  for (Index t = 0; t < num_slots(); ++t) {
    if (!alive(t)) continue;
    out.tets.push_back(cells_[t].v);
    if (!regions_.empty()) out.tet_regions.push_back(regions_[t]);
  }
  out.boundary = boundary_;
  out.boundary_ids = boundary_ids_;
  return out;
}

Index TetMesh::add_point(const Vec3& p) {
  points_.push_back(p);
  ids_.push_back(next_id_++);
  return static_cast<Index>(points_.size() - 1);
}

void TetMesh::invalidate_quality(Index t) { quality_[t] = kUnknown; }

void TetMesh::set_active(Index t, bool on) {
  flags_[t] = static_cast<Flags>(on ? flags_[t] | kActive : flags_[t] & ~kActive);
}

void TetMesh::set_frozen(Index t, int f, bool on) {
  const Flags bit = frozen_bit(f);
  flags_[t] = static_cast<Flags>(on ? flags_[t] | bit : flags_[t] & ~bit);
  const Index n = cells_[t].adj[f];
  if (n == kNoIndex) return;
  const Flags nbit = frozen_bit(face_local(n));
  Flags& nf = flags_[face_tet(n)];
  nf = static_cast<Flags>(on ? nf | nbit : nf & ~nbit);
}

bool TetMesh::edge_ring(Index t, int e, EdgeRing& r, int max_size) const {
  const int limit = std::clamp(max_size, 1, EdgeRing::kMax);
  const Tet& k = cells_[t].v;
  r.a = k[topo::kEdgeVertex[e][0]];
  r.b = k[topo::kEdgeVertex[e][1]];
  // Invariant of the walk: tet `cur` holds {a, b, p, q} with orient3d(a,b,p,q) > 0.
  Index cur = t;
  Index p = k[topo::kEdgeOther[e][0]];
  Index q = k[topo::kEdgeOther[e][1]];
  // Walk backwards (through the face opposite q), recording. Back at t, the
  // ring is closed, and a forward walk would meet the same tets after t in
  // the reverse order: the record with all but its first entry reversed is
  // the ring, without a second walk (the first one's tets were cache misses).
  r.closed = false;
  for (int m = 0;;) {
    if (m == limit) return false;
    r.tets[m] = cur;
    r.ring[m] = p;
    ++m;
    const Index n = cells_[cur].adj[topo::local_vertex(cells_[cur].v, q)];
    if (n == kNoIndex) break;  // open: the first tet of the ring
    const Index u = face_tet(n);
    if (u == t) {
      r.closed = true;
      r.size = m;
      std::reverse(r.tets.begin() + 1, r.tets.begin() + m);
      std::reverse(r.ring.begin() + 1, r.ring.begin() + m);
      return true;
    }
    q = p;
    p = cells_[u].v[face_local(n)];
    cur = u;
  }
  // Open ring: walk forwards (through the face opposite p) from the hull,
  // recording it.
  const Index first = cur;
  r.size = 0;
  for (;;) {
    if (r.size == limit) return false;
    r.tets[r.size] = cur;
    r.ring[r.size] = p;
    ++r.size;
    const Index n = cells_[cur].adj[topo::local_vertex(cells_[cur].v, p)];
    if (n == kNoIndex) {
      r.ring[r.size] = q;
      return !r.closed;  // a closed ring never reaches the hull
    }
    const Index u = face_tet(n);
    if (u == first) return r.closed;
    p = q;
    q = cells_[u].v[face_local(n)];
    cur = u;
  }
}

Index TetMesh::allocate_tet() {
  if (!free_.empty()) {
    const Index t = free_.back();
    free_.pop_back();
    return t;
  }
  assert(cells_.size() < kMaxTets);
  cells_.push_back({{kNoIndex, kNoIndex, kNoIndex, kNoIndex}, {kNoIndex, kNoIndex, kNoIndex, kNoIndex}});
  flags_.push_back(0);
  quality_.push_back(kUnknown);
  if (!regions_.empty()) regions_.push_back(0);
  return static_cast<Index>(cells_.size() - 1);
}

void TetMesh::free_tet(Index t) {
  cells_[t].v = {kNoIndex, kNoIndex, kNoIndex, kNoIndex};
  cells_[t].adj = {kNoIndex, kNoIndex, kNoIndex, kNoIndex};
  flags_[t] = 0;
  free_.push_back(t);
  --alive_count_;
}

void TetMesh::replace_cavity(std::span<const Index> old_tets, std::span<const Tet> new_tets,
                             std::span<const Index> parent) {
  faces_.clear();
  outer_.clear();
  old_regions_.clear();
  created_.clear();
  // Which tets are old: a small table on the stack for a small cavity (a
  // mark in the flags of each old tet made every outer face's test read the
  // flags of a tet outside the cavity, a cache miss), else the marks.
  constexpr std::size_t kTable = 128;
  std::array<Index, kTable> table;
  const bool hashed = old_tets.size() <= kTable / 2;
  const auto slot = [](Index t) { return static_cast<std::size_t>((t * 0x9E3779B1u) >> 25); };  // 7 bits
  if (hashed) {
    table.fill(kNoIndex);
    for (Index t : old_tets) {
      std::size_t h = slot(t);
      while (table[h] != kNoIndex) h = (h + 1) & (kTable - 1);
      table[h] = t;
    }
  } else {
    for (Index t : old_tets) flags_[t] = static_cast<Flags>(flags_[t] | kMark);
  }
  const auto old = [&](Index u) {
    if (!hashed) return (flags_[u] & kMark) != 0;
    for (std::size_t h = slot(u);; h = (h + 1) & (kTable - 1)) {
      if (table[h] == u) return true;
      if (table[h] == kNoIndex) return false;
    }
  };
  for (Index t : old_tets) {
    if (!regions_.empty()) old_regions_.push_back(regions_[t]);
    for (int f = 0; f < 4; ++f) {
      const Index n = cells_[t].adj[f];
      if (n != kNoIndex && old(face_tet(n))) continue;  // inside
      faces_.push_back(
          {topo::sorted_key(topo::face_of(cells_[t].v, f)), static_cast<Index>(outer_.size()), true});
      outer_.push_back({n, frozen(t, f)});
    }
  }
  for (auto it = old_tets.rbegin(); it != old_tets.rend(); ++it) free_tet(*it);

  for (std::size_t j = 0; j < new_tets.size(); ++j) {
    const Index t = allocate_tet();
    cells_[t].v = new_tets[j];
    flags_[t] = kAlive | kActive;
    quality_[t] = kUnknown;
    if (!regions_.empty()) regions_[t] = old_regions_[parent[j]];
    ++alive_count_;
    created_.push_back(t);
    for (int f = 0; f < 4; ++f)
      faces_.push_back({topo::sorted_key(topo::face_of(new_tets[j], f)), pack_face(t, f), false});
  }

  // Pair equal face keys through a small open-addressing table (each key occurs
  // once or twice, so the pairing, and hence the result, does not depend on the
  // probe order). Linear in the cavity size: the sort this replaced cost 10-15%
  // of a refinement profile.
  std::size_t capacity = 64;
  while (capacity < 2 * faces_.size()) capacity *= 2;
  if (bucket_.size() < capacity) bucket_.resize(capacity);
  std::fill(bucket_.begin(), bucket_.begin() + static_cast<std::ptrdiff_t>(capacity), kNoIndex);
  const std::size_t mask = capacity - 1;
  for (std::size_t i = 0; i < faces_.size(); ++i) {
    const Tri& key = faces_[i].key;
    std::size_t h = (std::size_t{key[0]} * 0x9E3779B97F4A7C15ull) ^ (std::size_t{key[1]} * 0xC2B2AE3D27D4EB4Full) ^
                    (std::size_t{key[2]} * 0x165667B19E3779F9ull);
    h = (h ^ (h >> 29)) & mask;
    for (;; h = (h + 1) & mask) {
      const Index j = bucket_[h];
      if (j == kNoIndex) {
        bucket_[h] = static_cast<Index>(i);
        break;
      }
      const Tri& other = faces_[j].key;
      if (other[0] != key[0] || other[1] != key[1] || other[2] != key[2]) continue;
      // A matched pair: at most one of them is an outer face of the cavity.
      const FaceSlot& x = faces_[j].outer ? faces_[j] : faces_[i];
      const FaceSlot& y = faces_[j].outer ? faces_[i] : faces_[j];
      assert(!y.outer);
      if (x.outer) {
        const OuterFace& o = outer_[x.who];
        const Index t = face_tet(y.who);
        const int f = face_local(y.who);
        cells_[t].adj[f] = o.neighbour;
        if (o.neighbour != kNoIndex) cells_[face_tet(o.neighbour)].adj[face_local(o.neighbour)] = y.who;
        if (o.frozen) flags_[t] = static_cast<Flags>(flags_[t] | frozen_bit(f));
      } else {
        cells_[face_tet(x.who)].adj[face_local(x.who)] = y.who;
        cells_[face_tet(y.who)].adj[face_local(y.who)] = x.who;
      }
      break;
    }
  }
  // A key left alone is a hull face of the cavity that the operation subdivides
  // (the old one unfrozen, on the hull), or one of its pieces, which stays on
  // the hull: its adjacency stays kNoIndex.
  // Old slots were freed and their kMark cleared with their flags; the reused
  // ones now hold new tets, whose flags were set above.
}

void TetMesh::replace_star(std::span<const Index> old_tets, Index apex, std::span<const StarFace> faces) {
  created_.clear();
  old_regions_.clear();
  if (!regions_.empty())
    for (Index t : old_tets) old_regions_.push_back(regions_[t]);
  for (auto it = old_tets.rbegin(); it != old_tets.rend(); ++it) free_tet(*it);
  // Each boundary edge is held by two faces, so 3 n / 2 keys: a table of at
  // least twice that, a power of two.
  std::size_t capacity = 64;
  while (capacity < 3 * faces.size()) capacity *= 2;
  if (edges_.size() < capacity) edges_.resize(capacity);
  std::fill(edges_.begin(), edges_.begin() + static_cast<std::ptrdiff_t>(capacity), EdgeSlot{kNoEdge, kNoIndex});
  const std::size_t mask = capacity - 1;
  [[maybe_unused]] std::size_t paired = 0;
  for (const StarFace& face : faces) {
    const Index t = allocate_tet();
    const Tri& p = face.points;
    cells_[t].v = {p[0], p[2], p[1], apex};
    flags_[t] = static_cast<Flags>(kAlive | kActive | (face.frozen ? frozen_bit(3) : 0));
    quality_[t] = kUnknown;
    if (!regions_.empty()) regions_[t] = old_regions_[face.parent];
    ++alive_count_;
    created_.push_back(t);
    cells_[t].adj[3] = face.neighbour;
    if (face.neighbour != kNoIndex) cells_[face_tet(face.neighbour)].adj[face_local(face.neighbour)] = pack_face(t, 3);
    // Face i < 3 of (p0, p2, p1, apex) holds the apex and the edge of the
    // other two: face 0 (p2, p1), face 1 (p0, p1), face 2 (p0, p2).
    const std::array<std::array<Index, 2>, 3> edge{{{p[2], p[1]}, {p[0], p[1]}, {p[0], p[2]}}};
    for (int i = 0; i < 3; ++i) {
      const Index lo = std::min(edge[i][0], edge[i][1]), hi = std::max(edge[i][0], edge[i][1]);
      const std::uint64_t key = (std::uint64_t{lo} << 32) | hi;
      std::size_t h = static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> 32) & mask;
      for (;; h = (h + 1) & mask) {
        EdgeSlot& slot = edges_[h];
        if (slot.edge == kNoEdge) {
          slot = {key, pack_face(t, i)};
          break;
        }
        if (slot.edge != key) continue;
        cells_[t].adj[i] = slot.face;
        cells_[face_tet(slot.face)].adj[face_local(slot.face)] = pack_face(t, i);
        ++paired;
        break;
      }
    }
  }
  assert(2 * paired == 3 * faces.size());  // every boundary edge held by exactly two faces
}

std::vector<Index> TetMesh::remove_unused_points(Index first) {
  std::vector<Index> map(points_.size(), kNoIndex);
  for (Index v = 0; v < std::min(first, num_points()); ++v) map[v] = 0;
  for (Index t = 0; t < num_slots(); ++t)
    if (alive(t))
      for (Index v : cells_[t].v) map[v] = 0;
  Index next = 0;
  for (Index v = 0; v < num_points(); ++v) {
    if (map[v] == kNoIndex) continue;
    map[v] = next;
    points_[next] = points_[v];
    ids_[next] = ids_[v];
    ++next;
  }
  if (next == num_points()) return map;
  points_.resize(next);
  ids_.resize(next);
  for (Index t = 0; t < num_slots(); ++t)
    if (alive(t))
      for (Index& v : cells_[t].v) v = map[v];
  for (Tri& f : boundary_)
    for (Index& v : f) v = map[v];
  return map;
}

std::vector<Index> TetMesh::compact() {
  const Index n = num_slots();
  std::vector<Index> map(n, kNoIndex);
  Index next = 0;
  for (Index t = 0; t < n; ++t)
    if (alive(t)) map[t] = next++;
  for (Index t = 0; t < n; ++t) {
    if (map[t] == kNoIndex) continue;
    const Index nt = map[t];
    cells_[nt].v = cells_[t].v;
    flags_[nt] = flags_[t];
    quality_[nt] = quality_[t];
    if (!regions_.empty()) regions_[nt] = regions_[t];
    for (int f = 0; f < 4; ++f) {
      const Index a = cells_[t].adj[f];
      cells_[nt].adj[f] = a == kNoIndex ? kNoIndex : pack_face(map[face_tet(a)], face_local(a));
    }
  }
  cells_.resize(next);
  flags_.resize(next);
  quality_.resize(next);
  if (!regions_.empty()) regions_.resize(next);
  free_.clear();
  return map;
}

std::vector<Index> TetMesh::reorder(std::span<const Index> order) {
  assert(order.size() == alive_count_);
  const Index n = num_slots();
  std::vector<Index> map(n, kNoIndex);
  for (std::size_t i = 0; i < order.size(); ++i) map[order[i]] = static_cast<Index>(i);
  // The neighbours' new indices first, in the old slots; then every array moves.
  for (Index t = 0; t < n; ++t) {
    if (!alive(t)) continue;
    for (int f = 0; f < 4; ++f) {
      const Index a = cells_[t].adj[f];
      if (a != kNoIndex) cells_[t].adj[f] = pack_face(map[face_tet(a)], face_local(a));
    }
  }
  permute(cells_, order);
  permute(flags_, order);
  permute(quality_, order);
  if (!regions_.empty()) permute(regions_, order);
  free_.clear();
  return map;
}

Status TetMesh::check() const {
  const Index n = num_slots();
  if (flags_.size() != n || quality_.size() != n ||
      (!regions_.empty() && regions_.size() != n))
    return internal_error("tet arrays have different lengths");
  if (ids_.size() != points_.size()) return internal_error("point ids and points differ in count");
  Index alive_seen = 0;
  for (Index t = 0; t < n; ++t) {
    const Flags fl = flags_[t];
    if ((fl & ~(kAlive | kActive | kFrozenMask)) != 0)
      return internal_error(
          fmt::format("tet {} has flags {:#x} with reserved or scratch bits", t, fl));
    if (!alive(t)) continue;
    ++alive_seen;
    const Tet& k = cells_[t].v;
    for (int i = 0; i < 4; ++i) {
      if (k[i] >= num_points())
        return internal_error(fmt::format("{} refers to a missing point", describe_tet(k, t)));
      for (int j = i + 1; j < 4; ++j)
        if (k[i] == k[j])
          return internal_error(fmt::format("{} repeats a point", describe_tet(k, t)));
    }
    const auto& p = points_;
    if (exact::orient3d(p[k[0]], p[k[1]], p[k[2]], p[k[3]]) <= 0)
      return internal_error(fmt::format("{} is not positively oriented (first point at {}, {}, {})",
                                        describe_tet(k, t), p[k[0]][0], p[k[0]][1], p[k[0]][2]));
    for (int f = 0; f < 4; ++f) {
      const Index a = cells_[t].adj[f];
      if (a == kNoIndex) continue;
      const Index u = face_tet(a);
      const int g = face_local(a);
      if (u >= n || !alive(u) || u == t)
        return internal_error(fmt::format("{} face {}: neighbour {} is not an alive other tet",
                                          describe_tet(k, t), f, u));
      if (cells_[u].adj[g] != pack_face(t, f))
        return internal_error(fmt::format("{} face {}: neighbour tet {} face {} points elsewhere",
                                          describe_tet(k, t), f, u, g));
      if (topo::sorted_key(topo::face_of(k, f)) != topo::sorted_key(topo::face_of(cells_[u].v, g)))
        return internal_error(fmt::format("{} face {}: neighbour {} face {} has other points",
                                          describe_tet(k, t), f, describe_tet(cells_[u].v, u), g));
      if (cells_[u].v[g] == k[f])
        return internal_error(fmt::format("{} face {}: neighbour tet {} has the same apex",
                                          describe_tet(k, t), f, u));
      if (frozen(t, f) != frozen(u, g))
        return internal_error(fmt::format("{} face {}: frozen on one side only (neighbour tet {})",
                                          describe_tet(k, t), f, u));
    }
  }
  if (alive_seen != alive_count_)
    return internal_error(
        fmt::format("{} alive tets counted, {} recorded", alive_seen, alive_count_));
  if (free_.size() != n - alive_count_)
    return internal_error(
        fmt::format("free list holds {} slots, {} are dead", free_.size(), n - alive_count_));
  for (Index t : free_)
    if (t >= n || alive(t))
      return internal_error(fmt::format("free list holds slot {}, which is alive", t));

  // Every boundary triangle is a frozen face.
  std::vector<Tri> frozen_faces;
  for (Index t = 0; t < n; ++t)
    if (alive(t))
      for (int f = 0; f < 4; ++f)
        if (frozen(t, f)) frozen_faces.push_back(topo::sorted_key(topo::face_of(cells_[t].v, f)));
  std::sort(frozen_faces.begin(), frozen_faces.end());
  for (std::size_t i = 0; i < boundary_.size(); ++i) {
    const Tri& b = boundary_[i];
    if (!std::binary_search(frozen_faces.begin(), frozen_faces.end(), topo::sorted_key(b)))
      return internal_error(
          fmt::format("boundary triangle {} (points {}, {}, {}) is no longer a "
                      "frozen face",
                      i, b[0], b[1], b[2]));
  }
  return Status::ok_status();
}

}  // namespace pdrmesh
