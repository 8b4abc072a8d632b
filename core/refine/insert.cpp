// SPDX-License-Identifier: AGPL-3.0-or-later
// Point location and insertion by splitting tets, faces and edges.
#include "pdrmesh/insert.hpp"

#include <array>
#include <unordered_set>
#include <vector>

#include "pdrmesh/predicates.hpp"
#include "pdrmesh/topology.hpp"

namespace pdrmesh {
namespace {

/// orient3d of p against the four outward faces of t: > 0 means beyond.
std::array<int, 4> face_signs(const TetMesh& m, Index t, const Vec3& p) {
  const Tet& k = m.tet(t);
  std::array<int, 4> s{};
  for (int f = 0; f < 4; ++f)
    s[f] = exact::orient3d(m.point(k[topo::kFaceVertex[f][0]]), m.point(k[topo::kFaceVertex[f][1]]),
                           m.point(k[topo::kFaceVertex[f][2]]), p);
  return s;
}

/// The location of p in t when no sign is positive.
Location classify(Index t, const std::array<int, 4>& s) {
  int zeros = 0, mask = 0;
  for (int f = 0; f < 4; ++f)
    if (s[f] == 0) {
      ++zeros;
      mask |= 1 << f;
    }
  switch (zeros) {
    case 0:
      return {LocationKind::kInTet, t, -1};
    case 1:
      for (int f = 0; f < 4; ++f)
        if (mask == 1 << f) return {LocationKind::kOnFace, t, f};
      break;
    case 2:  // on the planes of faces f and g: on the edge of the two other vertices
      for (int e = 0; e < 6; ++e)
        if (mask == ((1 << topo::edge_face(e, 0)) | (1 << topo::edge_face(e, 1))))
          return {LocationKind::kOnEdge, t, e};
      break;
    case 3:  // on three face planes: the vertex they share, opposite the fourth face
      for (int v = 0; v < 4; ++v)
        if ((mask & (1 << v)) == 0) return {LocationKind::kOnVertex, t, v};
      break;
    default:
      break;
  }
  return {};  // four zeros: a flat tet, which a valid mesh does not hold
}

bool inside(const std::array<int, 4>& s) {
  return s[0] <= 0 && s[1] <= 0 && s[2] <= 0 && s[3] <= 0;
}

Location scan(const TetMesh& m, const Vec3& p) {
  for (Index t = 0; t < m.num_slots(); ++t) {
    if (!m.alive(t)) continue;
    const auto s = face_signs(m, t, p);
    if (inside(s)) return classify(t, s);
  }
  return {};
}

}  // namespace

std::string_view to_string(InsertOutcome o) {
  switch (o) {
    case InsertOutcome::kDone:
      return "done";
    case InsertOutcome::kTooClose:
      return "too close";
    case InsertOutcome::kConstrained:
      return "constrained";
    case InsertOutcome::kOutside:
      return "outside";
    case InsertOutcome::kNotApplicable:
      return "not applicable";
  }
  return "?";
}

Location search(const TetMesh& m, Index start, const Vec3& p, Index max_tets) {
  if (start >= m.num_slots() || !m.alive(start)) return {};
  std::vector<Index> queue{start};
  std::unordered_set<Index> seen{start};
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const Index t = queue[head];
    const auto s = face_signs(m, t, p);
    if (inside(s)) return classify(t, s);
    for (int f = 0; f < 4; ++f) {
      const Index n = m.neighbour(t, f);
      if (n == kNoIndex || seen.size() >= max_tets) continue;
      if (seen.insert(face_tet(n)).second) queue.push_back(face_tet(n));
    }
  }
  return {};
}

Location walk(const TetMesh& m, Index start, const Vec3& p, Index max_steps, bool cross_frozen) {
  if (start >= m.num_slots() || !m.alive(start)) return {};
  Index t = start;
  std::uint32_t rotation = 0x9e3779b9u;  // fixed seed: deterministic exit choice
  for (Index step = 0; step < max_steps; ++step) {
    rotation ^= rotation << 13;
    rotation ^= rotation >> 17;
    rotation ^= rotation << 5;
    // The faces in the rotated order: the first one p lies beyond that may be
    // crossed is the exit, and the faces after it need no predicate; p is in t
    // when it lies beyond none.
    const Tet& k = m.tet(t);
    std::array<int, 4> s{};
    Index next = kNoIndex;
    bool beyond = false;
    for (int i = 0; i < 4 && next == kNoIndex; ++i) {
      const int f = static_cast<int>((rotation + static_cast<std::uint32_t>(i)) & 3u);
      s[f] = exact::orient3d(m.point(k[topo::kFaceVertex[f][0]]), m.point(k[topo::kFaceVertex[f][1]]),
                             m.point(k[topo::kFaceVertex[f][2]]), p);
      if (s[f] <= 0) continue;
      beyond = true;
      if (cross_frozen || !m.frozen(t, f)) next = m.neighbour(t, f);
    }
    if (!beyond) return classify(t, s);
    if (next == kNoIndex) break;  // p lies beyond hull (or uncrossable) faces only
    t = face_tet(next);
  }
  return {};
}

Location locate(const TetMesh& m, Index start, const Vec3& p) {
  const Location l = walk(m, start, p, m.num_slots() + 16);
  return l.kind != LocationKind::kOutside ? l : scan(m, p);
}

InsertResult insert_at(TetMesh& m, const Location& where, const Vec3& p) {
  InsertResult res;
  res.where = where;
  // Each new tet is an old tet with one vertex replaced by p; it is positive
  // exactly when p lies strictly on the inner side of the face opposite that
  // vertex, which the location guarantees.
  std::array<Index, EdgeRing::kMax> old{};
  std::array<Tet, 2 * EdgeRing::kMax> fresh{};
  std::array<Index, 2 * EdgeRing::kMax> parent{};
  std::size_t n_old = 0, n_new = 0;
  // Replacements are recorded as (old position, local vertex) until p gets its index.
  std::array<int, 2 * EdgeRing::kMax> replaced{};
  const auto replace = [&](std::size_t pos, int v) {
    fresh[n_new] = m.tet(old[pos]);
    parent[n_new] = static_cast<Index>(pos);
    replaced[n_new] = v;
    ++n_new;
  };

  switch (where.kind) {
    case LocationKind::kOutside:
      res.outcome = InsertOutcome::kOutside;
      return res;
    case LocationKind::kOnVertex:
      res.outcome = InsertOutcome::kTooClose;
      return res;
    case LocationKind::kInTet:
      old[n_old++] = where.tet;
      for (int v = 0; v < 4; ++v) replace(0, v);
      break;
    case LocationKind::kOnFace: {
      if (m.frozen(where.tet, where.local)) {
        res.outcome = InsertOutcome::kConstrained;
        return res;
      }
      old[n_old++] = where.tet;
      const Index n = m.neighbour(where.tet, where.local);
      if (n != kNoIndex) old[n_old++] = face_tet(n);
      const std::array<int, 2> face{where.local, n == kNoIndex ? -1 : face_local(n)};
      for (std::size_t i = 0; i < n_old; ++i)
        for (int v = 0; v < 4; ++v)
          if (v != face[i]) replace(i, v);
      break;
    }
    case LocationKind::kOnEdge: {
      EdgeRing r;
      if (!m.edge_ring(where.tet, where.local, r)) {
        res.outcome = InsertOutcome::kNotApplicable;
        return res;
      }
      for (int i = 0; i < r.size; ++i) {
        const Index u = r.tets[i];
        const Tet& k = m.tet(u);
        const int la = topo::local_vertex(k, r.a), lb = topo::local_vertex(k, r.b);
        const int e = topo::kEdgeIndex[la][lb];
        if (m.frozen(u, topo::edge_face(e, 0)) || m.frozen(u, topo::edge_face(e, 1))) {
          res.outcome = InsertOutcome::kConstrained;
          return res;
        }
        old[n_old++] = u;
        replace(n_old - 1, la);
        replace(n_old - 1, lb);
      }
      break;
    }
  }

  res.point = m.add_point(p);
  for (std::size_t j = 0; j < n_new; ++j) fresh[j][replaced[j]] = res.point;
  m.replace_cavity(std::span<const Index>(old.data(), n_old),
                   std::span<const Tet>(fresh.data(), n_new),
                   std::span<const Index>(parent.data(), n_new));
  res.outcome = InsertOutcome::kDone;
  return res;
}

InsertResult insert_point(TetMesh& mesh, Index start, const Vec3& p) {
  return insert_at(mesh, locate(mesh, start, p), p);
}

}  // namespace pdrmesh
