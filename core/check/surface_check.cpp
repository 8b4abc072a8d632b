// SPDX-License-Identifier: AGPL-3.0-or-later
// The surface check (surface_check.hpp): validity, topology, components,
// nesting and orientation, and exact self-intersection detection.
#include "pdrmesh/surface_check.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <numeric>
#include <tuple>
#include <utility>

#include "pdrmesh/bvh.hpp"
#include "pdrmesh/predicates.hpp"
#include "pdrmesh/union_find.hpp"

namespace pdrmesh {
namespace {

using detail::box_of;
using detail::BoxTree;

// The exact predicates, with an exact shortcut first: points that share a
// coordinate value on an axis are coplanar (collinear in the projection).
// CAD surfaces have many axis-aligned flat faces, where the adaptive
// predicates would otherwise have to run to full precision to return 0.
int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  for (int k = 0; k < 3; ++k)
    if (a[k] == b[k] && a[k] == c[k] && a[k] == d[k]) return 0;
  return exact::orient3d(a, b, c, d);
}

int orient2d(const Vec3& a, const Vec3& b, const Vec3& c, int drop) {
  for (int k = 0; k < 3; ++k)
    if (k != drop && a[k] == b[k] && a[k] == c[k]) return 0;
  return exact::orient2d(a, b, c, drop);
}

// ---------------------------------------------------------------------------
// Exact intersection tests between closed, non-degenerate triangles.

bool mixed_signs(int a, int b, int c) {
  return (a > 0 || b > 0 || c > 0) && (a < 0 || b < 0 || c < 0);
}

// An axis to drop such that the projection of the non-degenerate triangle abc
// is non-degenerate (so the projection is one-to-one on its plane). Prefers
// the dominant axis of the normal; -1 only for a degenerate triangle.
int drop_axis(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = cross(b - a, c - a);
  int best = 0;
  for (int k = 1; k < 3; ++k)
    if (std::fabs(n[k]) > std::fabs(n[best])) best = k;
  if (orient2d(a, b, c, best) != 0) return best;
  for (int k = 0; k < 3; ++k)
    if (orient2d(a, b, c, k) != 0) return k;
  return -1;
}

// x lies on the closed segment pq, given that p, q, x are collinear (in the projection).
bool within_2d(const Vec3& p, const Vec3& q, const Vec3& x, int drop) {
  for (int k = 0; k < 3; ++k) {
    if (k == drop) continue;
    if (x[k] < std::min(p[k], q[k]) || x[k] > std::max(p[k], q[k])) return false;
  }
  return true;
}

// Closed segments pq and ab meet (in the projection dropping `drop`).
bool segments_meet_2d(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, int drop) {
  const int d1 = orient2d(p, q, a, drop), d2 = orient2d(p, q, b, drop);
  const int d3 = orient2d(a, b, p, drop), d4 = orient2d(a, b, q, drop);
  if (d1 * d2 < 0 && d3 * d4 < 0) return true;
  return (d1 == 0 && within_2d(p, q, a, drop)) || (d2 == 0 && within_2d(p, q, b, drop)) ||
         (d3 == 0 && within_2d(a, b, p, drop)) || (d4 == 0 && within_2d(a, b, q, drop));
}

// x lies in the closed triangle abc (non-degenerate in the projection).
bool point_in_triangle_2d(const Vec3& x, const Vec3& a, const Vec3& b, const Vec3& c, int drop) {
  return !mixed_signs(orient2d(a, b, x, drop), orient2d(b, c, x, drop), orient2d(c, a, x, drop));
}

bool segment_meets_triangle_2d(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b,
                               const Vec3& c, int drop) {
  return point_in_triangle_2d(p, a, b, c, drop) || segments_meet_2d(p, q, a, b, drop) ||
         segments_meet_2d(p, q, b, c, drop) || segments_meet_2d(p, q, c, a, drop);
}

// The closed segment pq meets the closed non-degenerate triangle abc.
bool segment_meets_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b,
                            const Vec3& c) {
  const int o1 = orient3d(a, b, c, p), o2 = orient3d(a, b, c, q);
  if (o1 == o2 && o1 != 0) return false;
  if (o1 == 0 && o2 == 0) return segment_meets_triangle_2d(p, q, a, b, c, drop_axis(a, b, c));
  // The line pq crosses the plane in one point, which lies on the segment; the
  // line meets the closed triangle iff these signs are not mixed.
  return !mixed_signs(orient3d(p, q, a, b), orient3d(p, q, b, c), orient3d(p, q, c, a));
}

using Corners = std::array<const Vec3*, 3>;

// The closed coplanar triangles meet (projection dropping `drop`).
bool triangles_meet_2d(const Corners& s, const Corners& t, int drop) {
  for (int i = 0; i < 3; ++i) {
    if (point_in_triangle_2d(*s[i], *t[0], *t[1], *t[2], drop)) return true;
    if (point_in_triangle_2d(*t[i], *s[0], *s[1], *s[2], drop)) return true;
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (segments_meet_2d(*s[i], *s[(i + 1) % 3], *t[j], *t[(j + 1) % 3], drop)) return true;
  return false;
}

// Signs of the three points against the plane of abc.
std::array<int, 3> sides(const Corners& abc, const Corners& pts) {
  return {orient3d(*abc[0], *abc[1], *abc[2], *pts[0]),
          orient3d(*abc[0], *abc[1], *abc[2], *pts[1]),
          orient3d(*abc[0], *abc[1], *abc[2], *pts[2])};
}

bool strictly_one_side(const std::array<int, 3>& o) {
  return o[0] != 0 && o[0] == o[1] && o[0] == o[2];
}

// Closed triangles without a shared vertex meet anywhere.
bool disjoint_triangles_meet(const Corners& s, const Corners& t) {
  const std::array<int, 3> ot = sides(s, t);
  if (strictly_one_side(ot)) return false;
  if (ot[0] == 0 && ot[1] == 0 && ot[2] == 0)
    return triangles_meet_2d(s, t, drop_axis(*s[0], *s[1], *s[2]));
  if (strictly_one_side(sides(t, s))) return false;
  // Non-coplanar: the intersection is a segment on the planes' common line
  // whose ends lie on edges, so it is non-empty iff an edge meets the other.
  for (int i = 0; i < 3; ++i) {
    if (segment_meets_triangle(*s[i], *s[(i + 1) % 3], *t[0], *t[1], *t[2])) return true;
    if (segment_meets_triangle(*t[i], *t[(i + 1) % 3], *s[0], *s[1], *s[2])) return true;
  }
  return false;
}

// Triangles (v, s1, s2) and (v, t1, t2) share exactly the vertex v: do they
// meet anywhere else?
bool meet_beyond_vertex(const Vec3& v, const Vec3& s1, const Vec3& s2, const Vec3& t1,
                        const Vec3& t2) {
  const int a1 = orient3d(v, s1, s2, t1), a2 = orient3d(v, s1, s2, t2);
  if (a1 == a2 && a1 != 0) return false;
  if (a1 == 0 && a2 == 0) {
    // Coplanar: improper iff the angular sectors at v (each under 180 degrees)
    // overlap or touch along a ray, i.e. iff one holds a boundary ray of the
    // other. x is in the closed sector (v; a, b) with sign s = orient(v, a, b)
    // iff orient(v, a, x) * s >= 0 and orient(v, x, b) * s >= 0.
    const int drop = drop_axis(v, s1, s2);
    const int ss = orient2d(v, s1, s2, drop), st = orient2d(v, t1, t2, drop);
    const int p11 = orient2d(v, s1, t1, drop), p12 = orient2d(v, s1, t2, drop);
    const int p21 = orient2d(v, s2, t1, drop), p22 = orient2d(v, s2, t2, drop);
    return (p11 * ss >= 0 && -p21 * ss >= 0) ||  // t1 in sector s
           (p12 * ss >= 0 && -p22 * ss >= 0) ||  // t2 in sector s
           (-p11 * st >= 0 && p12 * st >= 0) ||  // s1 in sector t
           (-p21 * st >= 0 && p22 * st >= 0);    // s2 in sector t
  }
  const int b1 = orient3d(v, t1, t2, s1), b2 = orient3d(v, t1, t2, s2);
  if (b1 == b2 && b1 != 0) return false;
  // The intersection is a segment from v along the planes' common line; it
  // extends beyond v iff an edge opposite v meets the other triangle.
  return segment_meets_triangle(s1, s2, v, t1, t2) || segment_meets_triangle(t1, t2, v, s1, s2);
}

// Triangles (u, w, s) and (u, w, t) share exactly the edge uw.
bool overlap_across_edge(const Vec3& u, const Vec3& w, const Vec3& s, const Vec3& t) {
  if (orient3d(u, w, s, t) != 0) return false;
  const int drop = drop_axis(u, w, s);
  return orient2d(u, w, s, drop) == orient2d(u, w, t, drop);
}

// The improper-intersection test on two distinct non-degenerate triangles of
// the surface (not duplicates): they meet other than along what they share.
bool improper_intersection(const std::vector<Vec3>& pts, const Tri& a, const Tri& b) {
  int shared = 0;
  int ia[3] = {-1, -1, -1};  // ia[i]: position in b of a[i], or -1
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (a[i] == b[j]) {
        ia[i] = j;
        ++shared;
      }
  if (shared == 0) {
    const Corners s{&pts[a[0]], &pts[a[1]], &pts[a[2]]};
    const Corners t{&pts[b[0]], &pts[b[1]], &pts[b[2]]};
    return disjoint_triangles_meet(s, t);
  }
  if (shared == 1) {
    const int i = ia[0] >= 0 ? 0 : (ia[1] >= 0 ? 1 : 2);
    const int j = ia[i];
    return meet_beyond_vertex(pts[a[i]], pts[a[(i + 1) % 3]], pts[a[(i + 2) % 3]],
                              pts[b[(j + 1) % 3]], pts[b[(j + 2) % 3]]);
  }
  if (shared == 2) {
    const int i = ia[0] < 0 ? 0 : (ia[1] < 0 ? 1 : 2);  // the vertex of a not in b
    int j = 0;
    while (b[j] == a[0] || b[j] == a[1] || b[j] == a[2]) ++j;
    return overlap_across_edge(pts[a[(i + 1) % 3]], pts[a[(i + 2) % 3]], pts[a[i]], pts[b[j]]);
  }
  return false;  // same vertex set: reported as a duplicate instead
}

// A point where two intersecting triangles meet, measured in doubles for the
// message: where an edge (not through a shared vertex) crosses the other
// triangle, else the midpoint of the centroids.
Vec3 intersection_witness(const std::vector<Vec3>& pts, const Tri& a, const Tri& b) {
  auto shares = [](const Tri& t, Index v) { return t[0] == v || t[1] == v || t[2] == v; };
  for (int pass = 0; pass < 2; ++pass) {
    const Tri& s = pass == 0 ? a : b;
    const Tri& t = pass == 0 ? b : a;
    const Vec3 &t0 = pts[t[0]], &t1 = pts[t[1]], &t2 = pts[t[2]];
    const Vec3 n = cross(t1 - t0, t2 - t0);
    for (int i = 0; i < 3; ++i) {
      const Index u = s[i], w = s[(i + 1) % 3];
      if (shares(t, u) || shares(t, w)) continue;
      const Vec3 &p = pts[u], &q = pts[w];
      if (!segment_meets_triangle(p, q, t0, t1, t2)) continue;
      const double dp = dot(n, p - t0), dq = dot(n, q - t0);
      if (dp == dq) return p;
      return p + (dp / (dp - dq)) * (q - p);
    }
  }
  const Vec3 ca = (1.0 / 3.0) * (pts[a[0]] + pts[a[1]] + pts[a[2]]);
  const Vec3 cb = (1.0 / 3.0) * (pts[b[0]] + pts[b[1]] + pts[b[2]]);
  return 0.5 * (ca + cb);
}

// How a nesting ray (segment pq, q far outside) meets a triangle.
enum class Crossing { kNone, kCross, kDegenerate };

Crossing ray_crossing(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  const int o1 = orient3d(a, b, c, p), o2 = orient3d(a, b, c, q);
  if (o1 == o2 && o1 != 0) return Crossing::kNone;
  if (o1 == 0 || o2 == 0)
    return segment_meets_triangle(p, q, a, b, c) ? Crossing::kDegenerate : Crossing::kNone;
  const int s1 = orient3d(p, q, a, b), s2 = orient3d(p, q, b, c), s3 = orient3d(p, q, c, a);
  if (mixed_signs(s1, s2, s3)) return Crossing::kNone;
  if (s1 == 0 || s2 == 0 || s3 == 0) return Crossing::kDegenerate;
  return Crossing::kCross;
}

// ---------------------------------------------------------------------------
// Bookkeeping.

std::string point_str(const Vec3& p) { return fmt::format("({}, {}, {})", p[0], p[1], p[2]); }

std::string tri_str(const SurfaceMesh& s, Index t) {
  const Tri& x = s.triangles[t];
  return fmt::format("triangle {} (points {}, {}, {})", t, x[0], x[1], x[2]);
}

Vec3 centroid(const SurfaceMesh& s, Index t) {
  const Tri& x = s.triangles[t];
  return (1.0 / 3.0) * (s.points[x[0]] + s.points[x[1]] + s.points[x[2]]);
}

// Collects defects: counts all, keeps the first `cap` of each kind.
class DefectSink {
 public:
  explicit DefectSink(std::size_t cap) : cap_(cap) {}
  bool wants(DefectKind k) const { return counts_[static_cast<std::size_t>(k)] < cap_; }
  template <class Make>
  void add(DefectKind k, Make&& make) {
    if (wants(k)) {
      Defect d = make();
      d.kind = k;
      lists_[static_cast<std::size_t>(k)].push_back(std::move(d));
    }
    ++counts_[static_cast<std::size_t>(k)];
  }
  void count_only(DefectKind k, std::size_t n) { counts_[static_cast<std::size_t>(k)] += n; }
  void finish(SurfaceReport& r) {
    r.defect_counts = counts_;
    for (auto& list : lists_)
      for (auto& d : list) r.defects.push_back(std::move(d));
  }

 private:
  std::size_t cap_;
  std::array<std::size_t, kDefectKinds> counts_{};
  std::array<std::vector<Defect>, kDefectKinds> lists_;
};

// What the analysis does with each triangle.
enum class Use : std::uint8_t {
  kSkipped,  ///< bad index or non-finite coordinate, repeated index, or a later duplicate
  kFlat,     ///< collinear points: in the topology, not in geometric tests
  kFull,     ///< in the topology and in geometric tests
};

struct EdgeUse {
  std::uint64_t key;  ///< (min point << 32) | max point
  Index tri;
  std::uint8_t local;  ///< the edge from corner local to corner local + 1
  bool operator<(const EdgeUse& o) const {
    return std::tie(key, tri, local) < std::tie(o.key, o.tri, o.local);
  }
};

struct CornerFan {
  Index point, fan, tri;
  bool operator<(const CornerFan& o) const {
    return point != o.point ? point < o.point : (fan != o.fan ? fan < o.fan : tri < o.tri);
  }
};

struct ComponentFlags {
  bool open = false, nonmanifold = false, inconsistent = false, flat = false;
  Index edges = 0;
};

// The fixed list of ray directions tried for nesting (one axis dominant, the
// others small and unrelated to typical grid coordinates).
constexpr std::array<Vec3, 8> kRayDirections{{
    {1.0, 0.0012345678901, 0.00098765432109},
    {0.00076543210987, 1.0, -0.0013579246801},
    {-0.0011223344556, 0.00066778899001, 1.0},
    {-1.0, -0.00087654321098, 0.0011111222333},
    {0.0013131313131, -1.0, 0.00070707070707},
    {0.00091919191919, -0.0012121212121, -1.0},
    {1.0, -0.0010987654321, -0.00054321012345},
    {-0.00043434343434, 1.0, 0.0010203040506},
}};

class Checker {
 public:
  Checker(const SurfaceMesh& s, const CheckOptions& o)
      : s_(s), opt_(o), sink_(o.max_defects_per_kind), use_(s.triangles.size(), Use::kSkipped) {}

  SurfaceReport run() {
    report_.points = static_cast<Index>(s_.points.size());
    report_.triangles = static_cast<Index>(s_.triangles.size());
    check_values();
    check_duplicates();
    check_topology();
    find_holes();
    build_tree();
    check_nesting();
    if (opt_.self_intersections) check_intersections();
    sink_.finish(report_);
    return std::move(report_);
  }

 private:
  // Non-finite coordinates, indices out of range, degenerate triangles.
  void check_values() {
    const auto& pts = s_.points;
    std::vector<char> finite(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const Vec3& p = pts[i];
      finite[i] = is_finite(p);
      if (!finite[i]) {
        sink_.add(DefectKind::kNonFiniteCoordinate, [&] {
          return Defect{{},
                        {},
                        {static_cast<Index>(i)},
                        p,
                        fmt::format("point {} has a non-finite coordinate {}", i, point_str(p))};
        });
      }
    }
    std::vector<Index> repeated, flat;
    for (std::size_t i = 0; i < s_.triangles.size(); ++i) {
      const Tri& t = s_.triangles[i];
      const Index ti = static_cast<Index>(i);
      if (t[0] >= pts.size() || t[1] >= pts.size() || t[2] >= pts.size()) {
        sink_.add(DefectKind::kIndexOutOfRange, [&] {
          Vec3 where{0, 0, 0};
          for (Index v : t)
            if (v < pts.size() && finite[v]) where = pts[v];
          return Defect{{},
                        {ti},
                        {t[0], t[1], t[2]},
                        where,
                        fmt::format("{} names a point that does not exist (there are {} points)",
                                    tri_str(s_, ti), pts.size())};
        });
        continue;
      }
      if (!finite[t[0]] || !finite[t[1]] || !finite[t[2]]) continue;
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
        repeated.push_back(ti);
        continue;
      }
      use_[i] = Use::kFull;
    }
    // Collinearity in parallel (exact, a few orient2d each).
    std::vector<char> is_flat(s_.triangles.size(), 0);
    tbb::parallel_for(std::size_t{0}, s_.triangles.size(), [&](std::size_t i) {
      if (use_[i] != Use::kFull) return;
      const Tri& t = s_.triangles[i];
      is_flat[i] = exact::collinear(pts[t[0]], pts[t[1]], pts[t[2]]);
    });
    for (std::size_t i = 0; i < s_.triangles.size(); ++i)
      if (is_flat[i]) {
        use_[i] = Use::kFlat;
        flat.push_back(static_cast<Index>(i));
      }
    // Report degenerate triangles in index order, whichever the reason.
    std::vector<Index> all;
    std::merge(repeated.begin(), repeated.end(), flat.begin(), flat.end(), std::back_inserter(all));
    for (Index ti : all) {
      sink_.add(DefectKind::kDegenerateTriangle, [&] {
        const Tri& t = s_.triangles[ti];
        const bool rep = use_[ti] == Use::kSkipped;
        return Defect{{},
                      {ti},
                      {t[0], t[1], t[2]},
                      centroid(s_, ti),
                      fmt::format("{} has zero area ({}) at {}", tri_str(s_, ti),
                                  rep ? "a repeated point" : "collinear points",
                                  point_str(centroid(s_, ti)))};
      });
    }
  }

  // Triangles with the same vertex set; all but the first of each group are skipped.
  void check_duplicates() {
    std::vector<std::pair<Tri, Index>> keys;
    keys.reserve(s_.triangles.size());
    for (std::size_t i = 0; i < s_.triangles.size(); ++i) {
      if (use_[i] == Use::kSkipped) continue;
      Tri t = s_.triangles[i];
      std::sort(t.begin(), t.end());
      keys.emplace_back(t, static_cast<Index>(i));
    }
    tbb::parallel_sort(keys.begin(), keys.end());
    std::vector<std::vector<Index>> groups;
    for (std::size_t i = 0; i < keys.size();) {
      std::size_t j = i + 1;
      while (j < keys.size() && keys[j].first == keys[i].first) ++j;
      if (j - i > 1) {
        std::vector<Index> g;
        for (std::size_t k = i; k < j; ++k) g.push_back(keys[k].second);
        for (std::size_t k = 1; k < g.size(); ++k) use_[g[k]] = Use::kSkipped;
        groups.push_back(std::move(g));
      }
      i = j;
    }
    std::sort(groups.begin(), groups.end());
    for (auto& g : groups) {
      sink_.add(DefectKind::kDuplicateTriangle, [&] {
        const Tri& t = s_.triangles[g[0]];
        return Defect{
            {},
            g,
            {t[0], t[1], t[2]},
            centroid(s_, g[0]),
            fmt::format("triangles {} have the same points {}, {}, {} at {}", fmt::join(g, ", "),
                        t[0], t[1], t[2], point_str(centroid(s_, g[0])))};
      });
    }
  }

  // Edges, fans, components, orientation, Euler characteristic, volume.
  void check_topology() {
    const auto& tris = s_.triangles;
    const std::size_t m = tris.size();
    std::vector<EdgeUse> edges;
    edges.reserve(3 * m);
    for (std::size_t i = 0; i < m; ++i) {
      if (use_[i] == Use::kSkipped) continue;
      for (std::uint8_t k = 0; k < 3; ++k) {
        const Index u = tris[i][k], w = tris[i][(k + 1) % 3];
        const std::uint64_t key = (std::uint64_t{std::min(u, w)} << 32) | std::max(u, w);
        edges.push_back({key, static_cast<Index>(i), k});
      }
    }
    tbb::parallel_sort(edges.begin(), edges.end());

    UnionFind tri_uf(m), corner_uf(3 * m);
    auto corner = [&](Index t, Index p) {
      const Tri& x = tris[t];
      return 3 * t + (x[0] == p ? 0u : (x[1] == p ? 1u : 2u));
    };
    struct EdgeGroup {
      std::size_t first, count;
    };
    std::vector<EdgeGroup> groups;
    for (std::size_t i = 0; i < edges.size();) {
      std::size_t j = i + 1;
      while (j < edges.size() && edges[j].key == edges[i].key) ++j;
      groups.push_back({i, j - i});
      const Index u = static_cast<Index>(edges[i].key >> 32);
      const Index w = static_cast<Index>(edges[i].key & 0xffffffffu);
      for (std::size_t k = i + 1; k < j; ++k) {
        tri_uf.unite(edges[i].tri, edges[k].tri);
        // The corners at each end of a shared edge belong to the same fan.
        corner_uf.unite(corner(edges[i].tri, u), corner(edges[k].tri, u));
        corner_uf.unite(corner(edges[i].tri, w), corner(edges[k].tri, w));
      }
      i = j;
    }

    // Components, numbered by their lowest triangle.
    comp_.assign(m, kNoIndex);
    std::vector<Index> root_comp(m, kNoIndex);
    for (std::size_t i = 0; i < m; ++i) {
      if (use_[i] == Use::kSkipped) continue;
      const Index r = tri_uf.find(static_cast<Index>(i));
      if (root_comp[r] == kNoIndex) {
        root_comp[r] = static_cast<Index>(report_.components.size());
        report_.components.emplace_back();
        report_.components.back().first_triangle = static_cast<Index>(i);
      }
      comp_[i] = root_comp[r];
      ++report_.components[comp_[i]].triangles;
    }
    flags_.assign(report_.components.size(), {});
    for (std::size_t i = 0; i < m; ++i)
      if (use_[i] == Use::kFlat) flags_[comp_[i]].flat = true;

    for (const EdgeGroup& g : groups) {
      const EdgeUse& e = edges[g.first];
      const Index u = static_cast<Index>(e.key >> 32), w = static_cast<Index>(e.key & 0xffffffffu);
      ComponentFlags& f = flags_[comp_[e.tri]];
      ++f.edges;
      // Builds the defect only when the sink keeps it.
      auto report = [&](DefectKind kind, auto&& message) {
        sink_.add(kind, [&] {
          std::vector<Index> ts;
          for (std::size_t k = 0; k < g.count; ++k) ts.push_back(edges[g.first + k].tri);
          const Vec3 mid = 0.5 * (s_.points[u] + s_.points[w]);
          const std::string where = fmt::format("edge {}-{} at {}", u, w, point_str(mid));
          std::string text = message(ts, where);
          return Defect{{}, std::move(ts), {u, w}, mid, std::move(text)};
        });
      };
      if (g.count == 1) {
        f.open = true;
        open_edges_.push_back({u, w, e.tri});
        report(DefectKind::kOpenEdge, [&](const std::vector<Index>&, const std::string& where) {
          return fmt::format("{} has only one triangle: {}", where, tri_str(s_, e.tri));
        });
      } else if (g.count > 2) {
        f.nonmanifold = true;
        report(DefectKind::kNonManifoldEdge, [&](const std::vector<Index>& ts,
                                                 const std::string& where) {
          return fmt::format("{} has {} triangles: {}", where, ts.size(), fmt::join(ts, ", "));
        });
      } else {
        const EdgeUse& e2 = edges[g.first + 1];
        const bool d1 = tris[e.tri][e.local] == u, d2 = tris[e2.tri][e2.local] == u;
        if (d1 == d2) {
          f.inconsistent = true;
          report(DefectKind::kInconsistentOrientation,
                 [&](const std::vector<Index>&, const std::string& where) {
                   return fmt::format(
                       "triangles {} and {} use {} in the same direction: one of them is flipped",
                       e.tri, e2.tri, where);
                 });
        }
      }
    }

    // Fans around every point: pinched vertices, points per component.
    std::vector<CornerFan> corners;
    corners.reserve(3 * m);
    for (std::size_t i = 0; i < m; ++i) {
      if (use_[i] == Use::kSkipped) continue;
      for (Index k = 0; k < 3; ++k)
        corners.push_back(
            {tris[i][k], corner_uf.find(3 * static_cast<Index>(i) + k), static_cast<Index>(i)});
    }
    tbb::parallel_sort(corners.begin(), corners.end());
    std::vector<std::pair<Index, Index>> comp_fan;  // (component, fan) at one point
    for (std::size_t i = 0; i < corners.size();) {
      std::size_t j = i + 1;
      while (j < corners.size() && corners[j].point == corners[i].point) ++j;
      comp_fan.clear();
      for (std::size_t k = i; k < j; ++k)
        if (k == i || corners[k].fan != corners[k - 1].fan)
          comp_fan.emplace_back(comp_[corners[k].tri], corners[k].fan);
      std::sort(comp_fan.begin(), comp_fan.end());
      for (std::size_t k = 0; k < comp_fan.size(); ++k) {
        if (k == 0 || comp_fan[k].first != comp_fan[k - 1].first)
          ++report_.components[comp_fan[k].first].points;
        else
          flags_[comp_fan[k].first].nonmanifold = true;
      }
      if (comp_fan.size() > 1) {
        const Index v = corners[i].point;
        sink_.add(DefectKind::kNonManifoldVertex, [&] {
          std::vector<Index> ts;
          for (std::size_t k = i; k < j; ++k) ts.push_back(corners[k].tri);
          std::sort(ts.begin(), ts.end());
          return Defect{{},
                        ts,
                        {v},
                        s_.points[v],
                        fmt::format("point {} at {} is pinched: its {} triangles form {} separate "
                                    "fans",
                                    v, point_str(s_.points[v]), ts.size(), comp_fan.size())};
        });
      }
      i = j;
    }

    // Per-component summary and signed volume (relative to a point of the
    // component, for accuracy far from the origin).
    std::vector<double> volume(report_.components.size(), 0.0);
    for (std::size_t i = 0; i < m; ++i) {
      if (use_[i] == Use::kSkipped) continue;
      const Index c = comp_[i];
      const Vec3& ref = s_.points[tris[report_.components[c].first_triangle][0]];
      const Vec3 a = s_.points[tris[i][0]] - ref, b = s_.points[tris[i][1]] - ref,
                 d = s_.points[tris[i][2]] - ref;
      volume[c] += dot(a, cross(b, d)) / 6.0;
    }
    for (std::size_t c = 0; c < report_.components.size(); ++c) {
      ComponentReport& r = report_.components[c];
      const ComponentFlags& f = flags_[c];
      r.closed = !f.open;
      r.manifold = !f.nonmanifold;
      r.consistently_oriented = !f.inconsistent && !f.nonmanifold;
      r.euler =
          static_cast<int>(r.points) - static_cast<int>(f.edges) + static_cast<int>(r.triangles);
      if (r.closed && r.manifold && r.consistently_oriented) r.genus = (2 - r.euler) / 2;
      r.volume = volume[c];
    }
  }

  // The tree over every triangle that takes part in geometric tests.
  void build_tree() {
    std::vector<Box> boxes;
    std::vector<Index> ids;
    for (std::size_t i = 0; i < s_.triangles.size(); ++i) {
      if (use_[i] != Use::kFull) continue;
      const Tri& t = s_.triangles[i];
      boxes.push_back(box_of(s_.points[t[0]], s_.points[t[1]], s_.points[t[2]]));
      ids.push_back(static_cast<Index>(i));
    }
    tree_ = BoxTree(boxes, ids);
  }

  bool nestable(Index c) const {
    const ComponentReport& r = report_.components[c];
    return r.closed && r.manifold && r.consistently_oriented && !flags_[c].flat;
  }

  // Casts a ray from p; counts crossings per nestable component other than
  // `self`. False when the ray meets an edge or vertex exactly.
  bool cast(const Vec3& p, const Vec3& dir, Index self, std::vector<Index>& odd) const {
    const Box& all = tree_.bounds();
    double len = 1.0;
    for (int k = 0; k < 3; ++k)
      len += (all.hi[k] - all.lo[k]) + std::fabs(p[k] - all.lo[k]) + std::fabs(p[k] - all.hi[k]);
    Vec3 q = p + len * dir;
    // The dominant axis alone takes q outside the box.
    for (int tries = 0; tries < 64; ++tries) {
      bool outside = false;
      for (int k = 0; k < 3; ++k) outside = outside || q[k] < all.lo[k] || q[k] > all.hi[k];
      if (outside) break;
      len *= 2;
      q = p + len * dir;
    }
    bool degenerate = false;
    std::vector<Index> hits;
    tree_.query(box_of(p, q), [&](std::size_t k) {
      if (degenerate) return;
      const Index t = tree_.id(k);
      const Index c = comp_[t];
      if (c == self || !nestable(c)) return;
      const Tri& x = s_.triangles[t];
      switch (ray_crossing(p, q, s_.points[x[0]], s_.points[x[1]], s_.points[x[2]])) {
        case Crossing::kNone:
          break;
        case Crossing::kCross:
          hits.push_back(c);
          break;
        case Crossing::kDegenerate:
          degenerate = true;
          break;
      }
    });
    if (degenerate) return false;
    std::sort(hits.begin(), hits.end());
    odd.clear();
    for (std::size_t i = 0; i < hits.size();) {
      std::size_t j = i;
      while (j < hits.size() && hits[j] == hits[i]) ++j;
      if ((j - i) % 2 == 1) odd.push_back(hits[i]);
      i = j;
    }
    return true;
  }

  // Nesting depth and parent of every nestable component, and its
  // orientation. A shell with outward normals (positive volume) holds material;
  // one with inward normals (negative volume) is a cavity, valid only directly
  // inside material. A positive shell directly inside a positive one is an
  // interface between two regions; a negative one there is a cavity.
  void check_nesting() {
    auto& comps = report_.components;
    std::vector<Index> nest;
    for (Index c = 0; c < comps.size(); ++c)
      if (nestable(c)) nest.push_back(c);
    std::vector<int> depth(comps.size(), -1);  // -1: undecided
    std::vector<std::vector<Index>> enclosing(comps.size());
    if (nest.size() == 1) depth[nest[0]] = 0;
    if (nest.size() > 1) {
      // Points of each component to cast from: the first few of its triangles.
      std::vector<std::vector<Index>> starts(comps.size());
      for (std::size_t i = 0; i < s_.triangles.size(); ++i) {
        if (use_[i] != Use::kFull || !nestable(comp_[i])) continue;
        auto& st = starts[comp_[i]];
        for (Index v : s_.triangles[i])
          if (st.size() < 8 && std::find(st.begin(), st.end(), v) == st.end()) st.push_back(v);
      }
      tbb::parallel_for(std::size_t{0}, nest.size(), [&](std::size_t n) {
        const Index c = nest[n];
        std::vector<Index> odd;
        for (Index v : starts[c]) {
          for (const Vec3& dir : kRayDirections) {
            if (cast(s_.points[v], dir, c, odd)) {
              depth[c] = static_cast<int>(odd.size());
              enclosing[c] = odd;
              return;
            }
          }
        }
      });
    }
    // The enclosing shells form a chain (shells neither cross nor touch): the
    // parent is the one of them one level up.
    for (Index c = 0; c < comps.size(); ++c) {
      if (depth[c] <= 0) continue;
      for (Index e : enclosing[c])
        if (depth[e] == depth[c] - 1) comps[c].parent = e;
    }
    for (Index c = 0; c < comps.size(); ++c) {
      if (depth[c] < 0) continue;
      ComponentReport& r = comps[c];
      r.nesting_depth = depth[c];
      const bool in_material = r.parent != kNoIndex && comps[r.parent].volume > 0;
      r.interface = r.volume > 0 && in_material;
      r.outward = r.volume > 0 || (r.volume < 0 && in_material);
      if (r.outward) continue;
      sink_.add(DefectKind::kInwardOrientation, [&] {
        const Index t = r.first_triangle;
        const Vec3& p = s_.points[s_.triangles[t][0]];
        return Defect{
            {},
            {t},
            {s_.triangles[t][0]},
            p,
            fmt::format("component {} ({} triangles, first {}) at nesting depth {} has volume {}: "
                        "{}",
                        c, r.triangles, tri_str(s_, t), r.nesting_depth, r.volume,
                        r.parent == kNoIndex ? std::string("its normals point inward")
                                             : fmt::format("it lies in the cavity of component {}, so its normals "
                                                           "must point out of it",
                                                           r.parent))};
      });
    }
  }

  // All improperly intersecting pairs, exactly, in (i, j) order.
  void check_intersections() {
    const std::size_t n = tree_.size();
    tbb::enumerable_thread_specific<std::vector<std::pair<Index, Index>>> found;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 256), [&](const auto& range) {
      auto& local = found.local();
      for (std::size_t k = range.begin(); k != range.end(); ++k) {
        const Index a = tree_.id(k);
        tree_.query(
            tree_.box(k),
            [&](std::size_t l) {
              const Index b = tree_.id(l);
              if (improper_intersection(s_.points, s_.triangles[a], s_.triangles[b]))
                local.emplace_back(std::min(a, b), std::max(a, b));
            },
            k + 1);
      }
    });
    std::vector<std::pair<Index, Index>> pairs;
    for (auto& local : found) pairs.insert(pairs.end(), local.begin(), local.end());
    tbb::parallel_sort(pairs.begin(), pairs.end());
    const std::size_t keep = std::min(pairs.size(), opt_.max_defects_per_kind);
    for (std::size_t i = 0; i < keep; ++i) {
      const Index a = pairs[i].first, b = pairs[i].second;  // not a structured binding: clang 14 cannot capture one
      sink_.add(DefectKind::kSelfIntersection, [&] {
        const Vec3 w = intersection_witness(s_.points, s_.triangles[a], s_.triangles[b]);
        return Defect{{},
                      {a, b},
                      {},
                      w,
                      fmt::format("{} and {} intersect near {}", tri_str(s_, a), tri_str(s_, b),
                                  point_str(w))};
      });
    }
    sink_.count_only(DefectKind::kSelfIntersection, pairs.size() - keep);
  }

  const SurfaceMesh& s_;
  const CheckOptions& opt_;
  DefectSink sink_;
  SurfaceReport report_;
  std::vector<Use> use_;
  /// Groups the open edges into holes: edges that share a point belong to the
  /// same hole, so three missing triangles far apart are three holes, not nine
  /// defects to the reader. The open edges come in ascending (u, w) order.
  void find_holes() {
    if (open_edges_.empty()) return;
    UnionFind points(s_.points.size());
    for (const OpenEdge& e : open_edges_) points.unite(e.u, e.w);
    std::vector<std::size_t> hole_of(s_.points.size(), kNone);
    std::vector<std::size_t> edges_of;  // per hole, in order of first edge
    std::vector<std::size_t> first_of;  // per hole: index into open_edges_
    for (std::size_t i = 0; i < open_edges_.size(); ++i) {
      const Index root = points.find(open_edges_[i].u);
      if (hole_of[root] == kNone) {
        hole_of[root] = edges_of.size();
        edges_of.push_back(0);
        first_of.push_back(i);
      }
      ++edges_of[hole_of[root]];
    }
    report_.hole_count = edges_of.size();
    for (std::size_t h = 0; h < edges_of.size() && h < opt_.max_defects_per_kind; ++h) {
      const OpenEdge& e = open_edges_[first_of[h]];
      const Vec3 mid = 0.5 * (s_.points[e.u] + s_.points[e.w]);
      report_.holes.push_back(
          {edges_of[h],
           Defect{DefectKind::kOpenEdge, {e.tri}, {e.u, e.w}, mid,
                  fmt::format("edge {}-{} at {} has only one triangle: {}", e.u, e.w, point_str(mid),
                              tri_str(s_, e.tri))}});
    }
    open_edges_ = {};
  }

  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  struct OpenEdge {
    Index u, w, tri;
  };
  std::vector<OpenEdge> open_edges_;  ///< every open edge, for find_holes
  std::vector<Index> comp_;  ///< component of every analysed triangle
  std::vector<ComponentFlags> flags_;
  BoxTree tree_;
};

}  // namespace

std::string_view to_string(DefectKind kind) {
  static constexpr std::array<std::string_view, kDefectKinds> kNames = {"non-finite coordinate",
                                                                        "index out of range",
                                                                        "degenerate triangle",
                                                                        "duplicate triangle",
                                                                        "open edge",
                                                                        "non-manifold edge",
                                                                        "non-manifold vertex",
                                                                        "inconsistent orientation",
                                                                        "inward orientation",
                                                                        "self-intersection"};
  const auto k = static_cast<std::size_t>(kind);
  return k < kNames.size() ? kNames[k] : "unknown defect";
}

std::size_t SurfaceReport::total_defects() const {
  std::size_t n = 0;
  for (std::size_t c : defect_counts) n += c;
  return n;
}

SurfaceReport check_surface(const SurfaceMesh& surface, const CheckOptions& options) {
  return Checker(surface, options).run();
}

}  // namespace pdrmesh
