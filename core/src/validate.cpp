// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/validate.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <iterator>
#include <limits>
#include <map>
#include <numeric>
#include <string_view>
#include <utility>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_reduce.h>
#include <oneapi/tbb/parallel_sort.h>

#include "pdrmesh/predicates.hpp"
#include "pdrmesh/topology.hpp"

namespace pdrmesh {
namespace {

/// An oriented triangle rotated so that its smallest index comes first: two
/// oriented triangles are the same iff their canonical forms are equal.
Tri canonical(Tri t) {
  const auto m = std::min_element(t.begin(), t.end()) - t.begin();
  std::rotate(t.begin(), t.begin() + m, t.end());
  return t;
}

/// Sorted vertex set of a triangle and whether `t` is an even permutation of it.
struct FaceKey {
  Tri sorted;
  bool even;
};
FaceKey face_key(const Tri& t) {
  const Tri c = canonical(t);  // c[0] is the smallest
  if (c[1] < c[2]) return {c, true};
  return {{c[0], c[2], c[1]}, false};
}

std::string point_str(const Vec3& p) { return fmt::format("({}, {}, {})", p[0], p[1], p[2]); }

/// Counts every error and keeps the first few of each check.
class Recorder {
 public:
  Recorder(ValidationReport& report, std::size_t cap) : report_(report), cap_(cap) {}
  template <class... Args>
  void add(std::string_view check, fmt::format_string<Args...> f, Args&&... args) {
    ++report_.error_count;
    auto& n = kept_[std::string(check)];
    if (n++ < cap_) report_.errors.push_back(fmt::format("{}: {}", check, fmt::format(f, std::forward<Args>(args)...)));
  }

 private:
  ValidationReport& report_;
  std::size_t cap_;
  std::map<std::string, std::size_t, std::less<>> kept_;
};

/// The offsets of a counting sort by a key in [0, keys): `each(add)` calls
/// add(key) once per item; key k's items go to [start[k], start[k + 1]).
template <class Each>
std::vector<std::size_t> bucket_starts(std::size_t keys, Each&& each) {
  std::vector<std::size_t> start(keys + 1, 0);
  each([&](Index key) { ++start[key + 1]; });
  std::partial_sum(start.begin(), start.end(), start.begin());
  return start;
}

/// Sorts each bucket [start[k], start[k + 1]) of `items` by `less`, buckets in parallel.
template <class T, class Less>
void sort_buckets(std::vector<T>& items, const std::vector<std::size_t>& start, Less less) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, start.size() - 1), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t k = r.begin(); k != r.end(); ++k) {
      std::sort(items.begin() + static_cast<std::ptrdiff_t>(start[k]),
                items.begin() + static_cast<std::ptrdiff_t>(start[k + 1]), less);
    }
  });
}

bool same_point(const Vec3& a, const Vec3& b) { return a[0] == b[0] && a[1] == b[1] && a[2] == b[2]; }
bool point_less(const Vec3& a, const Vec3& b) { return a < b; }

}  // namespace

double enclosed_volume(const SurfaceMesh& surface) {
  double v = 0;
  for (const Tri& t : surface.triangles) {
    v += dot(surface.points[t[0]], cross(surface.points[t[1]], surface.points[t[2]])) / 6.0;
  }
  return v;
}

ValidationReport validate_mesh(const VolumeMesh& mesh, const SurfaceMesh* surface,
                               const ValidationOptions& options) {
  ValidationReport report;
  Recorder rec(report, options.max_messages_per_check);
  const auto& P = mesh.points;
  const std::size_t np = P.size();
  report.tets = mesh.tets.size();
  report.points = np;

  // 1. Indices, distinct vertices, finite coordinates.
  bool indices_ok = true;
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const Tet& k = mesh.tets[t];
    for (Index v : k) {
      if (v >= np) {
        rec.add("index", "tet {} refers to point {} of {}", t, v, np);
        indices_ok = false;
      }
    }
    if (k[0] == k[1] || k[0] == k[2] || k[0] == k[3] || k[1] == k[2] || k[1] == k[3] || k[2] == k[3]) {
      rec.add("index", "tet {} repeats a vertex ({}, {}, {}, {})", t, k[0], k[1], k[2], k[3]);
      indices_ok = false;
    }
  }
  for (std::size_t i = 0; i < np; ++i) {
    if (!is_finite(P[i])) {
      rec.add("coordinates", "point {} is not finite {}", i, point_str(P[i]));
      indices_ok = false;
    }
  }
  if (!indices_ok) return report;  // nothing below is safe

  // 2. Orientation, exactly; volume in doubles.
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const Tet& k = mesh.tets[t];
    const int o = exact::orient3d(P[k[0]], P[k[1]], P[k[2]], P[k[3]]);
    if (o <= 0) {
      rec.add("orientation", "tet {} is {} near {}", t, o == 0 ? "degenerate (zero volume)" : "inverted",
              point_str(P[k[0]]));
    }
    report.volume += signed_volume(P[k[0]], P[k[1]], P[k[2]], P[k[3]]);
  }

  // 3. Faces: shared by at most two tets, with opposite orientations. The
  // faces are grouped by their smallest point (a counting sort) and each group
  // sorted by its other two points, then the tet: the order of one sort by
  // (sorted points, tet), in linear time plus small sorts, 16 bytes a face.
  struct FaceRef {
    Index b, c;     // the face's other two points, b < c
    Index tet;
    std::uint32_t slot;  // topo::face_of(mesh.tets[tet], slot)
  };
  const std::vector<std::size_t> face_first = bucket_starts(np, [&](auto&& add) {
    for (const Tet& k : mesh.tets)
      for (int f = 0; f < 4; ++f) add(std::min({k[(f + 1) % 4], k[(f + 2) % 4], k[(f + 3) % 4]}));  // face f: all but k[f]
  });
  std::vector<FaceRef> faces(face_first[np]);
  {
    std::vector<std::size_t> next(face_first.begin(), face_first.end() - 1);
    for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
      for (int f = 0; f < 4; ++f) {
        const Tri s = topo::sorted_key(topo::face_of(mesh.tets[t], f));
        faces[next[s[0]]++] = {s[1], s[2], static_cast<Index>(t), static_cast<std::uint32_t>(f)};
      }
    }
  }
  sort_buckets(faces, face_first, [](const FaceRef& x, const FaceRef& y) {
    return std::tie(x.b, x.c, x.tet) < std::tie(y.b, y.c, y.tet);
  });
  const auto oriented = [&](const FaceRef& r) { return topo::face_of(mesh.tets[r.tet], static_cast<int>(r.slot)); };
  std::vector<Tri> boundary;  // derived: faces of exactly one tet, outward
  std::size_t unique_faces = 0;
  for (Index a = 0; a < np; ++a) {
    for (std::size_t i = face_first[a], end = face_first[a + 1]; i < end;) {
      std::size_t j = i;
      while (j < end && faces[j].b == faces[i].b && faces[j].c == faces[i].c) ++j;
      ++unique_faces;
      const Index b = faces[i].b, c = faces[i].c;
      if (j - i == 1) {
        boundary.push_back(oriented(faces[i]));
      } else if (j - i == 2) {
        if (face_key(oriented(faces[i])).even == face_key(oriented(faces[i + 1])).even) {
          rec.add("conformity", "tets {} and {} overlap across face ({}, {}, {}) at {}", faces[i].tet,
                  faces[i + 1].tet, a, b, c, point_str(P[a]));
        }
      } else {
        rec.add("conformity", "face ({}, {}, {}) at {} is shared by {} tets", a, b, c, point_str(P[a]), j - i);
      }
      i = j;
    }
  }
  faces = {};
  report.boundary_faces = boundary.size();

  // 4. Points: used, and no two with the same coordinates. (The parallel sorts
  // here and below use total orders, ties broken by an index, so they give
  // exactly what std::sort gives.)
  {
    std::vector<char> used(np, 0);
    for (const Tet& k : mesh.tets)
      for (Index v : k) used[v] = 1;
    for (std::size_t i = 0; i < np; ++i)
      if (!used[i]) rec.add("points", "point {} {} is used by no tet", i, point_str(P[i]));
    std::vector<Index> order(np);
    for (std::size_t i = 0; i < np; ++i) order[i] = static_cast<Index>(i);
    tbb::parallel_sort(order.begin(), order.end(), [&](Index a, Index b) {
      return point_less(P[a], P[b]) || (!point_less(P[b], P[a]) && a < b);
    });
    for (std::size_t i = 1; i < np; ++i)
      if (same_point(P[order[i - 1]], P[order[i]]))
        rec.add("points", "points {} and {} are both at {}", order[i - 1], order[i], point_str(P[order[i]]));
  }

  // 5. Boundary: closed 2-manifold.
  std::size_t boundary_edges = 0, boundary_vertices = 0;
  {
    struct DirectedEdge {
      Index lo, hi;
      bool forward;  // lo -> hi
      Index face;
    };
    std::vector<DirectedEdge> edges;
    edges.reserve(3 * boundary.size());
    for (std::size_t f = 0; f < boundary.size(); ++f) {
      for (int e = 0; e < 3; ++e) {
        const Index u = boundary[f][e], v = boundary[f][(e + 1) % 3];
        edges.push_back({std::min(u, v), std::max(u, v), u < v, static_cast<Index>(f)});
      }
    }
    tbb::parallel_sort(edges.begin(), edges.end(), [](const DirectedEdge& a, const DirectedEdge& b) {
      return std::tie(a.lo, a.hi, a.face, a.forward) < std::tie(b.lo, b.hi, b.face, b.forward);
    });
    for (std::size_t i = 0; i < edges.size();) {
      std::size_t j = i;
      while (j < edges.size() && edges[j].lo == edges[i].lo && edges[j].hi == edges[i].hi) ++j;
      ++boundary_edges;
      if (j - i != 2 || edges[i].forward == edges[i + 1].forward) {
        rec.add("boundary", "boundary edge ({}, {}) at {} is used by {} boundary faces{}", edges[i].lo,
                edges[i].hi, point_str(P[edges[i].lo]), j - i,
                j - i == 2 ? " with the same direction" : "");
      }
      i = j;
    }
    // One fan per vertex: around v, each face (v, x, y) links x -> y; a single
    // fan is a single cycle through all of v's faces.
    struct Corner {
      Index v, x, y;
    };
    std::vector<Corner> corners;
    corners.reserve(3 * boundary.size());
    for (const Tri& t : boundary)
      for (int c = 0; c < 3; ++c) corners.push_back({t[c], t[(c + 1) % 3], t[(c + 2) % 3]});
    tbb::parallel_sort(corners.begin(), corners.end(),
                       [](const Corner& a, const Corner& b) { return std::tie(a.v, a.x, a.y) < std::tie(b.v, b.x, b.y); });
    for (std::size_t i = 0; i < corners.size();) {
      std::size_t j = i;
      while (j < corners.size() && corners[j].v == corners[i].v) ++j;
      ++boundary_vertices;
      std::size_t steps = 0;
      Index x = corners[i].x;
      do {
        const auto it = std::lower_bound(corners.begin() + static_cast<std::ptrdiff_t>(i),
                                         corners.begin() + static_cast<std::ptrdiff_t>(j), x,
                                         [](const Corner& c, Index key) { return c.x < key; });
        if (it == corners.begin() + static_cast<std::ptrdiff_t>(j) || it->x != x) break;
        x = it->y;
        ++steps;
      } while (x != corners[i].x && steps <= j - i);
      if (steps != j - i) {
        rec.add("boundary", "boundary vertex {} at {} is not a single fan of faces", corners[i].v,
                point_str(P[corners[i].v]));
      }
      i = j;
    }
  }
  report.euler_boundary = static_cast<long long>(boundary_vertices) - static_cast<long long>(boundary_edges) +
                          static_cast<long long>(boundary.size());

  // 6. Euler characteristic of the volume: chi(M) = chi(boundary of M) / 2.
  {
    // Edges grouped by their smaller point (a counting sort), each group's
    // larger points sorted and counted once.
    const std::vector<std::size_t> edge_first = bucket_starts(np, [&](auto&& add) {
      for (const Tet& k : mesh.tets)
        for (int a = 0; a < 4; ++a)
          for (int b = a + 1; b < 4; ++b) add(std::min(k[a], k[b]));
    });
    std::vector<Index> ends(edge_first[np]);
    {
      std::vector<std::size_t> next(edge_first.begin(), edge_first.end() - 1);
      for (const Tet& k : mesh.tets)
        for (int a = 0; a < 4; ++a)
          for (int b = a + 1; b < 4; ++b) ends[next[std::min(k[a], k[b])]++] = std::max(k[a], k[b]);
    }
    sort_buckets(ends, edge_first, std::less<Index>());
    const std::size_t ne = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, np), std::size_t{0},
        [&](const tbb::blocked_range<std::size_t>& r, std::size_t n) {
          for (std::size_t v = r.begin(); v != r.end(); ++v) {
            const auto lo = ends.begin() + static_cast<std::ptrdiff_t>(edge_first[v]);
            const auto hi = ends.begin() + static_cast<std::ptrdiff_t>(edge_first[v + 1]);
            n += static_cast<std::size_t>(std::unique(lo, hi) - lo);
          }
          return n;
        },
        std::plus<>());
    std::vector<char> used(np, 0);
    std::size_t nv = 0;
    for (const Tet& k : mesh.tets)
      for (Index v : k) nv += used[v] ? 0 : (used[v] = 1);
    report.euler_volume = static_cast<long long>(nv) - static_cast<long long>(ne) +
                          static_cast<long long>(unique_faces) - static_cast<long long>(mesh.tets.size());
    if (2 * report.euler_volume != report.euler_boundary) {
      rec.add("topology", "V - E + F - T = {} but the boundary's Euler characteristic is {} (expected twice as much)",
              report.euler_volume, report.euler_boundary);
    }
  }

  // 7. The mesh's own boundary list, when it has one, equals the derived boundary.
  std::vector<std::pair<Tri, int>> declared;  // canonical triangle, id
  if (!mesh.boundary.empty() || !mesh.boundary_ids.empty()) {
    if (mesh.boundary_ids.size() != mesh.boundary.size()) {
      rec.add("boundary", "{} boundary faces but {} boundary ids", mesh.boundary.size(), mesh.boundary_ids.size());
    }
    std::vector<Tri> derived;
    derived.reserve(boundary.size());
    for (const Tri& t : boundary) derived.push_back(canonical(t));
    tbb::parallel_sort(derived.begin(), derived.end());
    for (std::size_t f = 0; f < mesh.boundary.size(); ++f) {
      const Tri& t = mesh.boundary[f];
      if (t[0] >= np || t[1] >= np || t[2] >= np) {
        rec.add("boundary", "boundary face {} refers to a point out of range", f);
        continue;
      }
      const Tri c = canonical(t);
      declared.emplace_back(c, f < mesh.boundary_ids.size() ? mesh.boundary_ids[f] : 0);
      if (!std::binary_search(derived.begin(), derived.end(), c)) {
        rec.add("boundary", "listed boundary face {} ({}, {}, {}) at {} is not an outward boundary face of the tets",
                f, t[0], t[1], t[2], point_str(P[t[0]]));
      }
    }
    if (mesh.boundary.size() != boundary.size()) {
      rec.add("boundary", "the mesh lists {} boundary faces, its tets have {}", mesh.boundary.size(), boundary.size());
    }
    std::sort(declared.begin(), declared.end());
  }

  // 8. Against the input surface: same triangles, same orientation, same ids, same volume.
  if (surface != nullptr) {
    report.enclosed_volume = enclosed_volume(*surface);
    std::vector<Index> by_coord(np);
    for (std::size_t i = 0; i < np; ++i) by_coord[i] = static_cast<Index>(i);
    tbb::parallel_sort(by_coord.begin(), by_coord.end(), [&](Index a, Index b) {
      return point_less(P[a], P[b]) || (!point_less(P[b], P[a]) && a < b);
    });
    std::vector<Index> to_mesh(surface->points.size(), kNoIndex);
    for (std::size_t i = 0; i < surface->points.size(); ++i) {
      const Vec3& q = surface->points[i];
      const auto it = std::lower_bound(by_coord.begin(), by_coord.end(), q,
                                       [&](Index a, const Vec3& key) { return point_less(P[a], key); });
      if (it != by_coord.end() && same_point(P[*it], q)) to_mesh[i] = *it;
    }
    std::vector<Tri> expected;
    expected.reserve(surface->triangles.size());
    for (std::size_t f = 0; f < surface->triangles.size(); ++f) {
      const Tri& t = surface->triangles[f];
      Tri m{};
      bool found = true;
      for (int c = 0; c < 3; ++c) {
        m[c] = t[c] < to_mesh.size() ? to_mesh[t[c]] : kNoIndex;
        if (m[c] == kNoIndex) found = false;
      }
      if (!found) {
        rec.add("surface", "input triangle {} has a vertex that is not a mesh point", f);
        continue;
      }
      const Tri c = canonical(m);
      expected.push_back(c);
      if (!declared.empty() && f < surface->surface_ids.size()) {
        const auto it = std::lower_bound(declared.begin(), declared.end(), std::make_pair(c, std::numeric_limits<int>::min()));
        if (it != declared.end() && it->first == c && it->second != surface->surface_ids[f]) {
          rec.add("surface", "input triangle {} has surface id {} but the mesh gives {}", f, surface->surface_ids[f],
                  it->second);
        }
      }
    }
    std::vector<Tri> actual;
    actual.reserve(boundary.size());
    for (const Tri& t : boundary) actual.push_back(canonical(t));
    tbb::parallel_sort(expected.begin(), expected.end());
    tbb::parallel_sort(actual.begin(), actual.end());
    std::vector<Tri> missing, extra;
    std::set_difference(expected.begin(), expected.end(), actual.begin(), actual.end(), std::back_inserter(missing));
    std::set_difference(actual.begin(), actual.end(), expected.begin(), expected.end(), std::back_inserter(extra));
    for (const Tri& t : missing)
      rec.add("surface", "input triangle ({}, {}, {}) at {} is not a boundary face of the mesh (with its orientation)",
              t[0], t[1], t[2], point_str(P[t[0]]));
    for (const Tri& t : extra)
      rec.add("surface", "boundary face ({}, {}, {}) at {} is not an input triangle", t[0], t[1], t[2],
              point_str(P[t[0]]));
    const double scale = std::max(std::abs(report.enclosed_volume), std::abs(report.volume));
    if (std::abs(report.volume - report.enclosed_volume) > options.volume_tolerance * scale) {
      rec.add("volume", "the tets fill {} but the surface encloses {} (relative difference {:.3g})", report.volume,
              report.enclosed_volume, scale > 0 ? std::abs(report.volume - report.enclosed_volume) / scale : 0.0);
    }
  }
  return report;
}

std::string format_validation(const ValidationReport& r) {
  std::string s = fmt::format("tets {}  points {}  boundary faces {}  volume {:.9g}", r.tets, r.points,
                              r.boundary_faces, r.volume);
  if (r.enclosed_volume != 0) s += fmt::format("  enclosed {:.9g}", r.enclosed_volume);
  s += fmt::format("\nEuler characteristic: volume {}, boundary {}\n", r.euler_volume, r.euler_boundary);
  if (r.ok()) return s + "valid\n";
  s += fmt::format("INVALID: {} error(s)\n", r.error_count);
  for (const auto& e : r.errors) s += "  " + e + "\n";
  if (r.errors.size() < r.error_count) s += fmt::format("  ... and {} more\n", r.error_count - r.errors.size());
  return s;
}

Status validation_status(const ValidationReport& r) {
  if (r.ok()) return Status::ok_status();
  std::string m = fmt::format("mesh is invalid ({} errors)", r.error_count);
  for (std::size_t i = 0; i < std::min<std::size_t>(3, r.errors.size()); ++i) m += "; " + r.errors[i];
  return invalid_input(std::move(m));
}

}  // namespace pdrmesh
