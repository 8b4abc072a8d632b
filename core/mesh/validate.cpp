// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/validate.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
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

#include "pdrmesh/fixed_chunks.hpp"
#include "pdrmesh/mixed_cells.hpp"

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

std::string point_str(const Vec3& p) { return fmt::format("({}, {}, {})", p[0], p[1], p[2]); }

/// Counts every error and keeps the first few of each check.
class Recorder {
 public:
  Recorder(ValidationReport& report, std::size_t cap) : report_(report), cap_(cap) {}
  std::size_t cap() const { return cap_; }
  template <class... Args>
  void add(std::string_view check, fmt::format_string<Args...> f, Args&&... args) {
    ++report_.error_count;
    auto& n = kept_[std::string(check)];
    if (n++ < cap_) report_.errors.push_back(fmt::format("{}: {}", check, fmt::format(f, std::forward<Args>(args)...)));
  }
  /// `count` errors of `check` whose first messages are `messages`, as if added one by one.
  void add_formatted(std::string_view check, std::size_t count, const std::vector<std::string>& messages) {
    report_.error_count += count;
    auto& n = kept_[std::string(check)];
    const std::size_t keep = n < cap_ ? std::min({cap_ - n, count, messages.size()}) : 0;
    for (std::size_t i = 0; i < keep; ++i) report_.errors.push_back(fmt::format("{}: {}", check, messages[i]));
    n += count;
  }

 private:
  ValidationReport& report_;
  std::size_t cap_;
  std::map<std::string, std::size_t, std::less<>> kept_;
};

/// One chunk's errors of one check: all counted, the first `cap` formatted.
struct ChunkLog {
  std::size_t cap = 0;
  std::size_t count = 0;
  std::vector<std::string> kept;
  template <class... Args>
  void add(fmt::format_string<Args...> f, Args&&... args) {
    if (count++ < cap) kept.push_back(fmt::format(f, std::forward<Args>(args)...));
  }
};

constexpr std::size_t kTetGrain = 16384;
constexpr std::size_t kItemGrain = 8192;
/// From this many tets on, the face check goes in slices of points (ValidationOptions::face_slices).
constexpr std::size_t kSlicedTets = std::size_t{1} << 20;

/// Runs body(log, chunk, i) for every i in [0, n) in fixed chunks of `grain`, in
/// parallel, then records each chunk's errors of `check` in chunk order: the
/// messages, their order and the caps are those of a serial loop. Returns the
/// number of errors.
template <class Body>
std::size_t scan(Recorder& rec, std::string_view check, std::size_t n, std::size_t grain, Body&& body) {
  std::vector<ChunkLog> logs(detail::chunk_count(n, grain), ChunkLog{rec.cap(), 0, {}});
  detail::for_each_chunk(n, grain, [&](std::size_t c, std::size_t lo, std::size_t hi) {
    for (std::size_t i = lo; i < hi; ++i) body(logs[c], c, i);
  });
  std::size_t errors = 0;
  for (const ChunkLog& log : logs) {
    rec.add_formatted(check, log.count, log.kept);
    errors += log.count;
  }
  return errors;
}

/// out[i] = f(i) for i in [0, n), in parallel.
template <class T, class F>
std::vector<T> tabulate(std::size_t n, F&& f) {
  std::vector<T> out(n);
  detail::for_each_chunk(n, kItemGrain, [&](std::size_t, std::size_t lo, std::size_t hi) {
    for (std::size_t i = lo; i < hi; ++i) out[i] = f(i);
  });
  return out;
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

// Every pass runs over fixed chunks (fixed_chunks.hpp) and combines the chunks
// in order, so the report is the same for any number of threads, and the same
// as one serial pass would give.
ValidationReport validate_mesh(const VolumeMesh& mesh, const SurfaceMesh* surface,
                               const ValidationOptions& options) {
  if (mesh.mixed()) return validate_mixed_mesh(mesh, surface, options);
  ValidationReport report;
  Recorder rec(report, options.max_messages_per_check);
  const auto& P = mesh.points;
  const auto& T = mesh.tets;
  const std::size_t np = P.size();
  const std::size_t nt = T.size();
  report.tets = nt;
  report.points = np;

  // 1. Indices, distinct vertices, finite coordinates.
  std::size_t bad = scan(rec, "index", nt, kTetGrain, [&](ChunkLog& log, std::size_t, std::size_t t) {
    const Tet& k = T[t];
    for (Index v : k) {
      if (v >= np) log.add("tet {} refers to point {} of {}", t, v, np);
    }
    if (k[0] == k[1] || k[0] == k[2] || k[0] == k[3] || k[1] == k[2] || k[1] == k[3] || k[2] == k[3]) {
      log.add("tet {} repeats a vertex ({}, {}, {}, {})", t, k[0], k[1], k[2], k[3]);
    }
  });
  bad += scan(rec, "coordinates", np, kItemGrain, [&](ChunkLog& log, std::size_t, std::size_t i) {
    if (!is_finite(P[i])) log.add("point {} is not finite {}", i, point_str(P[i]));
  });
  if (bad > 0) return report;  // nothing below is safe

  // 2. Orientation, exactly; volume in doubles. The tet volumes are summed in
  // tet order after the parallel pass, so the sum is the serial one, bit for bit.
  {
    detail::UninitVector<double> volume(nt);  // every item written below
    scan(rec, "orientation", nt, kTetGrain, [&](ChunkLog& log, std::size_t, std::size_t t) {
      const Tet& k = T[t];
      const int o = exact::orient3d(P[k[0]], P[k[1]], P[k[2]], P[k[3]]);
      if (o <= 0) log.add("tet {} is {} near {}", t, o == 0 ? "degenerate (zero volume)" : "inverted", point_str(P[k[0]]));
      volume[t] = signed_volume(P[k[0]], P[k[1]], P[k[2]], P[k[3]]);
    });
    for (const double v : volume) report.volume += v;
  }

  // 3. Faces: shared by at most two tets, with opposite orientations. The
  // faces are grouped by their smallest point a; each point's faces are then
  // scanned in parallel, chunks of points concatenated in order. A large mesh
  // goes in slices of points (whole chunks), so that one slice's faces (16
  // bytes each) are held at a time rather than four per tet.
  std::vector<Tri> boundary;  // derived: faces of exactly one tet, outward
  // Faces two tets of different regions share (canonical, oriented out of the
  // first tet), sorted: where the interfaces between regions may lie.
  const bool has_regions = !mesh.tet_regions.empty() && mesh.tet_regions.size() == nt;
  if (!mesh.tet_regions.empty() && !has_regions)
    rec.add("regions", "{} tet regions for {} tets", mesh.tet_regions.size(), nt);
  std::vector<Tri> between;
  std::size_t unique_faces = 0;
  const std::size_t slices = options.face_slices > 0 ? options.face_slices : nt >= kSlicedTets ? 4 : 1;
  const std::size_t per_slice = detail::chunk_count(detail::chunk_count(np, kItemGrain), slices) * kItemGrain;
  // Every slice's faces counted in one pass.
  const std::vector<std::size_t> face_counts = per_slice < np ? detail::face_counts(T, np) : std::vector<std::size_t>();
  for (std::size_t lo = 0; lo < np; lo += per_slice) {
    const std::size_t hi = std::min(np, lo + per_slice);
    const detail::Buckets<detail::FaceRef> faces =
        detail::faces_by_smallest_point(T, lo, hi, face_counts.empty() ? nullptr : &face_counts);
    const auto oriented = [&](const detail::FaceRef& r) { return topo::face_of(T[r.tet], static_cast<int>(r.slot)); };
    const std::size_t chunks = detail::chunk_count(hi - lo, kItemGrain);
    std::vector<std::vector<Tri>> chunk_boundary(chunks), chunk_between(chunks);
    std::vector<std::size_t> chunk_unique(chunks, 0);
    scan(rec, "conformity", hi - lo, kItemGrain, [&](ChunkLog& log, std::size_t chunk, std::size_t local) {
      const auto& F = faces.items;
      const std::size_t a = lo + local;
      for (std::size_t i = faces.first[local], end = faces.first[local + 1]; i < end;) {
        std::size_t j = i;
        while (j < end && F[j].b == F[i].b && F[j].c == F[i].c) ++j;
        ++chunk_unique[chunk];
        const Index b = F[i].b, c = F[i].c;
        if (j - i == 1) {
          chunk_boundary[chunk].push_back(oriented(F[i]));
        } else if (j - i == 2) {
          if (F[i].even == F[i + 1].even) {
            log.add("tets {} and {} overlap across face ({}, {}, {}) at {}", F[i].tet, F[i + 1].tet, a, b, c,
                    point_str(P[a]));
          } else if (has_regions && mesh.tet_regions[F[i].tet] != mesh.tet_regions[F[i + 1].tet]) {
            chunk_between[chunk].push_back(canonical(oriented(F[i])));
          }
        } else {
          log.add("face ({}, {}, {}) at {} is shared by {} tets", a, b, c, point_str(P[a]), j - i);
        }
        i = j;
      }
    });
    std::vector<Tri> part = detail::concatenate(chunk_boundary);
    boundary.insert(boundary.end(), part.begin(), part.end());
    part = detail::concatenate(chunk_between);
    between.insert(between.end(), part.begin(), part.end());
    unique_faces += std::accumulate(chunk_unique.begin(), chunk_unique.end(), std::size_t{0});
  }
  report.boundary_faces = boundary.size();
  tbb::parallel_sort(between.begin(), between.end());
  // Whether triangle t (either orientation) is a face between two regions.
  const auto is_between = [&](const Tri& t) {
    return std::binary_search(between.begin(), between.end(), canonical(t)) ||
           std::binary_search(between.begin(), between.end(), canonical(Tri{t[0], t[2], t[1]}));
  };
  if (has_regions) {
    std::vector<int> ids(mesh.tet_regions);
    std::sort(ids.begin(), ids.end());
    report.regions = static_cast<std::size_t>(std::unique(ids.begin(), ids.end()) - ids.begin());
  }

  // 4. Points: used, and no two with the same coordinates. (The parallel sorts
  // here and below use total orders, ties broken by an index, so they give
  // exactly what std::sort gives.)
  std::vector<char> used(np, 0);
  detail::for_each_chunk(nt, kTetGrain, [&](std::size_t, std::size_t lo, std::size_t hi) {
    for (std::size_t t = lo; t < hi; ++t)
      for (Index v : T[t]) std::atomic_ref<char>(used[v]).store(1, std::memory_order_relaxed);
  });
  scan(rec, "points", np, kItemGrain, [&](ChunkLog& log, std::size_t, std::size_t i) {
    if (!used[i]) log.add("point {} {} is used by no tet", i, point_str(P[i]));
  });
  std::vector<Index> by_coord = tabulate<Index>(np, [](std::size_t i) { return static_cast<Index>(i); });
  tbb::parallel_sort(by_coord.begin(), by_coord.end(), [&](Index a, Index b) {
    return point_less(P[a], P[b]) || (!point_less(P[b], P[a]) && a < b);
  });
  scan(rec, "points", np > 0 ? np - 1 : 0, kItemGrain, [&](ChunkLog& log, std::size_t, std::size_t i) {
    if (same_point(P[by_coord[i]], P[by_coord[i + 1]]))
      log.add("points {} and {} are both at {}", by_coord[i], by_coord[i + 1], point_str(P[by_coord[i + 1]]));
  });

  // 5. Boundary: closed 2-manifold. Groups of a sorted list are scanned in
  // parallel by their first item, so a chunk finishes the group it starts.
  std::size_t boundary_edges = 0, boundary_vertices = 0;
  {
    struct DirectedEdge {
      Index lo, hi;
      bool forward;  // lo -> hi
      Index face;
    };
    std::vector<DirectedEdge> edges = tabulate<DirectedEdge>(3 * boundary.size(), [&](std::size_t i) {
      const Index u = boundary[i / 3][i % 3], v = boundary[i / 3][(i + 1) % 3];
      return DirectedEdge{std::min(u, v), std::max(u, v), u < v, static_cast<Index>(i / 3)};
    });
    tbb::parallel_sort(edges.begin(), edges.end(), [](const DirectedEdge& a, const DirectedEdge& b) {
      return std::tie(a.lo, a.hi, a.face, a.forward) < std::tie(b.lo, b.hi, b.face, b.forward);
    });
    const auto same_edge = [&](std::size_t i, std::size_t j) { return edges[j].lo == edges[i].lo && edges[j].hi == edges[i].hi; };
    std::vector<std::size_t> edge_groups(detail::chunk_count(edges.size(), kItemGrain), 0);
    scan(rec, "boundary", edges.size(), kItemGrain, [&](ChunkLog& log, std::size_t chunk, std::size_t i) {
      if (i > 0 && same_edge(i - 1, i)) return;
      std::size_t j = i;
      while (j < edges.size() && same_edge(i, j)) ++j;
      ++edge_groups[chunk];
      if (j - i != 2 || edges[i].forward == edges[i + 1].forward) {
        log.add("boundary edge ({}, {}) at {} is used by {} boundary faces{}", edges[i].lo, edges[i].hi,
                point_str(P[edges[i].lo]), j - i, j - i == 2 ? " with the same direction" : "");
      }
    });
    boundary_edges = std::accumulate(edge_groups.begin(), edge_groups.end(), std::size_t{0});
    // One fan per vertex: around v, each face (v, x, y) links x -> y; a single
    // fan is a single cycle through all of v's faces.
    struct Corner {
      Index v, x, y;
    };
    std::vector<Corner> corners = tabulate<Corner>(3 * boundary.size(), [&](std::size_t i) {
      const Tri& t = boundary[i / 3];
      const std::size_t c = i % 3;
      return Corner{t[c], t[(c + 1) % 3], t[(c + 2) % 3]};
    });
    tbb::parallel_sort(corners.begin(), corners.end(),
                       [](const Corner& a, const Corner& b) { return std::tie(a.v, a.x, a.y) < std::tie(b.v, b.x, b.y); });
    std::vector<std::size_t> vertex_groups(detail::chunk_count(corners.size(), kItemGrain), 0);
    scan(rec, "boundary", corners.size(), kItemGrain, [&](ChunkLog& log, std::size_t chunk, std::size_t i) {
      if (i > 0 && corners[i - 1].v == corners[i].v) return;
      std::size_t j = i;
      while (j < corners.size() && corners[j].v == corners[i].v) ++j;
      ++vertex_groups[chunk];
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
        log.add("boundary vertex {} at {} is not a single fan of faces", corners[i].v, point_str(P[corners[i].v]));
      }
    });
    boundary_vertices = std::accumulate(vertex_groups.begin(), vertex_groups.end(), std::size_t{0});
  }
  report.euler_boundary = static_cast<long long>(boundary_vertices) - static_cast<long long>(boundary_edges) +
                          static_cast<long long>(boundary.size());

  // 6. Euler characteristic of the volume: chi(M) = chi(boundary of M) / 2.
  {
    // Edges grouped by their smaller point (a counting sort), each group's
    // larger points sorted and counted once.
    detail::Buckets<Index> ends = detail::bucket_items<Index>(nt, np, kTetGrain, [&](std::size_t t, auto&& emit) {
      const Tet& k = T[t];
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b) emit(std::min(k[a], k[b]), std::max(k[a], k[b]));
    });
    detail::sort_buckets(ends, std::less<Index>());
    const std::size_t ne = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, np), std::size_t{0},
        [&](const tbb::blocked_range<std::size_t>& r, std::size_t n) {
          for (std::size_t v = r.begin(); v != r.end(); ++v) {
            const auto lo = ends.items.begin() + static_cast<std::ptrdiff_t>(ends.first[v]);
            const auto hi = ends.items.begin() + static_cast<std::ptrdiff_t>(ends.first[v + 1]);
            n += static_cast<std::size_t>(std::unique(lo, hi) - lo);
          }
          return n;
        },
        std::plus<>());
    const auto nv = static_cast<std::size_t>(std::count(used.begin(), used.end(), char{1}));
    report.euler_volume = static_cast<long long>(nv) - static_cast<long long>(ne) +
                          static_cast<long long>(unique_faces) - static_cast<long long>(nt);
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
    std::vector<Tri> derived = tabulate<Tri>(boundary.size(), [&](std::size_t f) { return canonical(boundary[f]); });
    tbb::parallel_sort(derived.begin(), derived.end());
    std::vector<std::vector<std::pair<Tri, int>>> chunk_declared(detail::chunk_count(mesh.boundary.size(), kItemGrain));
    std::vector<std::size_t> chunk_interfaces(chunk_declared.size(), 0);
    scan(rec, "boundary", mesh.boundary.size(), kItemGrain, [&](ChunkLog& log, std::size_t chunk, std::size_t f) {
      const Tri& t = mesh.boundary[f];
      if (t[0] >= np || t[1] >= np || t[2] >= np) {
        log.add("boundary face {} refers to a point out of range", f);
        return;
      }
      const Tri c = canonical(t);
      chunk_declared[chunk].emplace_back(c, f < mesh.boundary_ids.size() ? mesh.boundary_ids[f] : 0);
      if (!std::binary_search(derived.begin(), derived.end(), c)) {
        if (is_between(t)) {
          ++chunk_interfaces[chunk];
        } else {
          log.add("listed boundary face {} ({}, {}, {}) at {} is not an outward boundary face of the tets{}", f, t[0],
                  t[1], t[2], point_str(P[t[0]]), has_regions ? " nor a face between two regions" : "");
        }
      }
    });
    declared = detail::concatenate(chunk_declared);
    report.interface_faces = std::accumulate(chunk_interfaces.begin(), chunk_interfaces.end(), std::size_t{0});
    if (mesh.boundary.size() != boundary.size() + report.interface_faces) {
      rec.add("boundary", "the mesh lists {} boundary faces, its tets have {}", mesh.boundary.size() - report.interface_faces,
              boundary.size());
    }
    tbb::parallel_sort(declared.begin(), declared.end());  // equal items are identical: the order of std::sort
  }

  // 8. Against the input surface: same triangles, same orientation, same ids, same volume.
  if (surface != nullptr) {
    const std::vector<Index> to_mesh = tabulate<Index>(surface->points.size(), [&](std::size_t i) {
      const Vec3& q = surface->points[i];
      const auto it = std::lower_bound(by_coord.begin(), by_coord.end(), q,
                                       [&](Index a, const Vec3& key) { return point_less(P[a], key); });
      return it != by_coord.end() && same_point(P[*it], q) ? *it : kNoIndex;
    });
    // An input triangle on a face between two regions is an interface: not on
    // the hull, and not a wall of the volume the tets fill.
    std::vector<std::vector<Tri>> chunk_expected(detail::chunk_count(surface->triangles.size(), kItemGrain));
    std::vector<std::vector<std::size_t>> chunk_interface(chunk_expected.size());
    scan(rec, "surface", surface->triangles.size(), kItemGrain, [&](ChunkLog& log, std::size_t chunk, std::size_t f) {
      const Tri& t = surface->triangles[f];
      Tri m{};
      bool found = true;
      for (int c = 0; c < 3; ++c) {
        m[c] = t[c] < to_mesh.size() ? to_mesh[t[c]] : kNoIndex;
        if (m[c] == kNoIndex) found = false;
      }
      if (!found) {
        log.add("input triangle {} has a vertex that is not a mesh point", f);
        return;
      }
      const Tri c = canonical(m);
      if (!between.empty() && is_between(m)) {
        chunk_interface[chunk].push_back(f);
      } else {
        chunk_expected[chunk].push_back(c);
      }
      if (!declared.empty() && f < surface->surface_ids.size()) {
        const auto it = std::lower_bound(declared.begin(), declared.end(), std::make_pair(c, std::numeric_limits<int>::min()));
        if (it != declared.end() && it->first == c && it->second != surface->surface_ids[f]) {
          log.add("input triangle {} has surface id {} but the mesh gives {}", f, surface->surface_ids[f], it->second);
        }
      }
    });
    std::vector<Tri> expected = detail::concatenate(chunk_expected);
    const std::vector<std::size_t> interface = detail::concatenate(chunk_interface);
    report.enclosed_volume = enclosed_volume(*surface);
    for (std::size_t f : interface) {
      const Tri& t = surface->triangles[f];
      report.enclosed_volume -= dot(surface->points[t[0]], cross(surface->points[t[1]], surface->points[t[2]])) / 6.0;
    }
    if (!declared.empty() && interface.size() != report.interface_faces)
      rec.add("regions", "the input has {} triangles between two regions, the mesh lists {}", interface.size(),
              report.interface_faces);
    std::vector<Tri> actual = tabulate<Tri>(boundary.size(), [&](std::size_t f) { return canonical(boundary[f]); });
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
  if (r.prisms + r.pyramids > 0) s += fmt::format("  prisms {}  pyramids {}", r.prisms, r.pyramids);
  if (r.regions > 0) s += fmt::format("  regions {}  interface faces {}", r.regions, r.interface_faces);
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
