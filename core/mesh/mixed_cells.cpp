// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/mixed_cells.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <tuple>

#include "pdrmesh/predicates.hpp"
#include "pdrmesh/topology.hpp"

namespace pdrmesh {
namespace {

/// The six relabellings of a prism that keep its orientation: the three
/// rotations of the triangles, and the same with top and bottom exchanged.
constexpr int kPrismFrames[6][6] = {{0, 1, 2, 3, 4, 5}, {1, 2, 0, 4, 5, 3}, {2, 0, 1, 5, 3, 4},
                                    {3, 5, 4, 0, 2, 1}, {4, 3, 5, 1, 0, 2}, {5, 4, 3, 2, 1, 0}};

/// The tets of a prism seen in frame q (q[0] its apex of the cut), with the
/// diagonal 1-5 (`first`) or 2-4 of the quad opposite q[0].
std::array<Tet, 3> prism_cut(const std::array<Index, 6>& q, bool first) {
  if (first) return {{{q[0], q[1], q[2], q[5]}, {q[0], q[1], q[5], q[4]}, {q[0], q[4], q[5], q[3]}}};
  return {{{q[0], q[1], q[2], q[4]}, {q[0], q[4], q[2], q[5]}, {q[0], q[4], q[5], q[3]}}};
}

std::array<Index, 6> in_frame(const Prism& p, int f) {
  std::array<Index, 6> q{};
  for (int i = 0; i < 6; ++i) q[i] = p[kPrismFrames[f][i]];
  return q;
}

bool tet_positive(const std::vector<Vec3>& P, const Tet& t) {
  return exact::orient3d(P[t[0]], P[t[1]], P[t[2]], P[t[3]]) > 0;
}

Tri sorted_tri(Index a, Index b, Index c) {
  Tri t{a, b, c};
  std::sort(t.begin(), t.end());
  return t;
}

std::array<Index, 4> sorted_quad(const Prism& p, int q) {
  std::array<Index, 4> k{};
  for (int i = 0; i < 4; ++i) k[i] = p[mixed::kPrismQuads[q][i]];
  std::sort(k.begin(), k.end());
  return k;
}

std::array<Index, 4> sorted_base(const Pyramid& p) {
  std::array<Index, 4> k{p[0], p[1], p[2], p[3]};
  std::sort(k.begin(), k.end());
  return k;
}

double prism_height(const std::vector<Vec3>& P, const Prism& p) {
  double h = 0;
  for (int i = 0; i < 3; ++i) h += norm(P[p[i + 3]] - P[p[i]]);
  return h / 3;
}

}  // namespace

std::array<Tet, 3> prism_tets(const Prism& p) {
  const int k = static_cast<int>(std::min_element(p.begin(), p.end()) - p.begin());
  const std::array<Index, 6> q = in_frame(p, k);
  return prism_cut(q, std::min(q[1], q[5]) < std::min(q[2], q[4]));
}

std::array<Tet, 2> pyramid_tets(const Pyramid& p) {
  if (std::min(p[0], p[2]) < std::min(p[1], p[3])) return {{{p[0], p[1], p[2], p[4]}, {p[0], p[2], p[3], p[4]}}};
  return {{{p[1], p[2], p[3], p[4]}, {p[1], p[3], p[0], p[4]}}};
}

bool prism_positive(const std::vector<Vec3>& points, const Prism& p) {
  for (int f = 0; f < 6; ++f) {
    const std::array<Index, 6> q = in_frame(p, f);
    for (const bool first : {true, false})
      for (const Tet& t : prism_cut(q, first))
        if (!tet_positive(points, t)) return false;
  }
  return true;
}

bool pyramid_positive(const std::vector<Vec3>& points, const Pyramid& p) {
  const Tet cuts[4] = {{p[0], p[1], p[2], p[4]}, {p[0], p[2], p[3], p[4]}, {p[1], p[2], p[3], p[4]},
                       {p[1], p[3], p[0], p[4]}};
  return std::all_of(std::begin(cuts), std::end(cuts), [&](const Tet& t) { return tet_positive(points, t); });
}

VolumeMesh split_to_tets(const VolumeMesh& mesh) {
  VolumeMesh out;
  out.points = mesh.points;
  out.boundary = mesh.boundary;
  out.boundary_ids = mesh.boundary_ids;
  out.boundary_names = mesh.boundary_names;
  out.tets.reserve(mesh.tets.size() + 3 * mesh.prisms.size() + 2 * mesh.pyramids.size());
  out.tets = mesh.tets;
  for (const Prism& p : mesh.prisms)
    for (const Tet& t : prism_tets(p)) out.tets.push_back(t);
  for (const Pyramid& p : mesh.pyramids)
    for (const Tet& t : pyramid_tets(p)) out.tets.push_back(t);
  // Regions follow the cells, when every kind of cell has them.
  if (mesh.has_regions() && mesh.regions_fit()) {
    out.tet_regions = mesh.tet_regions;
    for (int r : mesh.prism_regions) out.tet_regions.insert(out.tet_regions.end(), 3, r);
    for (int r : mesh.pyramid_regions) out.tet_regions.insert(out.tet_regions.end(), 2, r);
    out.region_names = mesh.region_names;
  }
  return out;
}

Result<MixedCellFaces> mixed_cell_faces(const VolumeMesh& mesh) {
  // Every cell's outward faces with their sorted points as key; equal keys
  // meet after the sort, the lower cell first: a pair is an internal face
  // owned by the lower cell, a single face is on the hull.
  struct Ref {
    std::array<Index, 4> key, face;
    Index cell;
    int local;
  };
  const std::size_t np = mesh.points.size();
  const auto out_of_range = [&](const auto& cells, const char* kind) -> Status {
    for (std::size_t c = 0; c < cells.size(); ++c)
      for (Index v : cells[c])
        if (v >= np) return invalid_input(fmt::format("{} {} refers to point {} of {}", kind, c, v, np));
    return {};
  };
  PDR_TRY(out_of_range(mesh.tets, "tet"));
  PDR_TRY(out_of_range(mesh.prisms, "prism"));
  PDR_TRY(out_of_range(mesh.pyramids, "pyramid"));
  std::vector<Ref> refs;
  refs.reserve(4 * mesh.tets.size() + 5 * (mesh.prisms.size() + mesh.pyramids.size()));
  const auto add = [&](std::array<Index, 4> face, std::size_t cell, int local) {
    std::array<Index, 4> key = face;
    std::sort(key.begin(), key.end());  // kNoIndex, a triangle's fourth, stays last
    refs.push_back({key, face, static_cast<Index>(cell), local});
  };
  const auto tri = [](const auto& cell, const int (&f)[3]) {
    return std::array<Index, 4>{cell[f[0]], cell[f[1]], cell[f[2]], kNoIndex};
  };
  const auto quad = [](const auto& cell, const int (&f)[4]) {
    return std::array<Index, 4>{cell[f[0]], cell[f[1]], cell[f[2]], cell[f[3]]};
  };
  std::size_t c = 0;
  for (const Tet& t : mesh.tets) {
    for (int f = 0; f < 4; ++f) {
      const Tri x = topo::face_of(t, f);
      add({x[0], x[1], x[2], kNoIndex}, c, f);
    }
    ++c;
  }
  for (const Prism& p : mesh.prisms) {
    add(tri(p, mixed::kPrismTriangles[0]), c, 0);
    add(tri(p, mixed::kPrismTriangles[1]), c, 1);
    for (int q = 0; q < 3; ++q) add(quad(p, mixed::kPrismQuads[q]), c, 2 + q);
    ++c;
  }
  for (const Pyramid& p : mesh.pyramids) {
    add(quad(p, mixed::kPyramidBase), c, 0);
    for (int t = 0; t < 4; ++t) add(tri(p, mixed::kPyramidTriangles[t]), c, 1 + t);
    ++c;
  }
  std::sort(refs.begin(), refs.end(), [](const Ref& a, const Ref& b) {
    return std::tie(a.key, a.cell, a.local) < std::tie(b.key, b.cell, b.local);
  });
  std::vector<std::array<std::size_t, 2>> internal;  // (owner ref, neighbour ref)
  std::vector<std::size_t> hull;
  for (std::size_t i = 0; i < refs.size();) {
    std::size_t e = i + 1;
    while (e < refs.size() && refs[e].key == refs[i].key) ++e;
    if (e - i == 1) {
      hull.push_back(i);
    } else if (e - i == 2 && refs[i].cell != refs[i + 1].cell) {
      internal.push_back({i, i + 1});
    } else {
      const auto& k = refs[i].key;
      return invalid_input(fmt::format("face ({}, {}, {}{}) is in {} cell faces (cells {} and {}, ...); a face "
                                       "belongs to one or two cells",
                                       k[0], k[1], k[2], k[3] == kNoIndex ? "" : fmt::format(", {}", k[3]), e - i,
                                       refs[i].cell, refs[i + 1].cell));
    }
    i = e;
  }
  std::sort(internal.begin(), internal.end(), [&](const auto& x, const auto& y) {
    return std::tie(refs[x[0]].cell, refs[x[1]].cell) < std::tie(refs[y[0]].cell, refs[y[1]].cell);
  });
  std::sort(hull.begin(), hull.end(), [&](std::size_t x, std::size_t y) {
    return std::tie(refs[x].cell, refs[x].local) < std::tie(refs[y].cell, refs[y].local);
  });
  MixedCellFaces out;
  out.faces.reserve(internal.size() + hull.size());
  out.owner.reserve(internal.size() + hull.size());
  out.neighbour.reserve(internal.size());
  for (const auto& [o, n] : internal) {
    out.faces.push_back(refs[o].face);
    out.owner.push_back(refs[o].cell);
    out.neighbour.push_back(refs[n].cell);
  }
  for (std::size_t h : hull) {
    out.faces.push_back(refs[h].face);
    out.owner.push_back(refs[h].cell);
  }
  return out;
}

ValidationReport validate_mixed_mesh(const VolumeMesh& mesh, const SurfaceMesh* surface,
                                     const ValidationOptions& options) {
  const std::size_t np = mesh.points.size();
  std::vector<std::string> errors;
  std::size_t error_count = 0;
  const auto add = [&](std::string message) {
    if (error_count++ < options.max_messages_per_check) errors.push_back(std::move(message));
  };
  const auto where = [&](Index v) {
    const Vec3& x = mesh.points[v];
    return fmt::format("({}, {}, {})", x[0], x[1], x[2]);
  };
  // Indices first: nothing below is safe without them.
  const auto check_indices = [&](const auto& cells, const char* kind) {
    for (std::size_t c = 0; c < cells.size(); ++c) {
      auto k = cells[c];
      if (std::any_of(k.begin(), k.end(), [&](Index v) { return v >= np; })) {
        add(fmt::format("index: {} {} refers to a point out of range ({} points)", kind, c, np));
        continue;
      }
      std::sort(k.begin(), k.end());
      if (std::adjacent_find(k.begin(), k.end()) != k.end()) add(fmt::format("index: {} {} repeats a vertex", kind, c));
    }
  };
  check_indices(mesh.prisms, "prism");
  check_indices(mesh.pyramids, "pyramid");
  if (!mesh.regions_fit()) {
    add(fmt::format("regions: {} tet, {} prism and {} pyramid regions for {} tets, {} prisms and {} pyramids",
                    mesh.tet_regions.size(), mesh.prism_regions.size(), mesh.pyramid_regions.size(), mesh.tets.size(),
                    mesh.prisms.size(), mesh.pyramids.size()));
  }
  if (error_count == 0) {
    for (std::size_t c = 0; c < mesh.prisms.size(); ++c)
      if (!prism_positive(mesh.points, mesh.prisms[c]))
        add(fmt::format("orientation: prism {} is inverted or folded near {}", c, where(mesh.prisms[c][0])));
    for (std::size_t c = 0; c < mesh.pyramids.size(); ++c)
      if (!pyramid_positive(mesh.points, mesh.pyramids[c]))
        add(fmt::format("orientation: pyramid {} is inverted or folded near {}", c, where(mesh.pyramids[c][0])));
    // A quad face is shared by two cells or lies on no tet: a quad that met
    // the triangles of tets would be a hanging face for a solver.
    std::map<std::array<Index, 4>, int> quads;
    for (const Prism& p : mesh.prisms)
      for (int q = 0; q < 3; ++q) ++quads[sorted_quad(p, q)];
    for (const Pyramid& p : mesh.pyramids) ++quads[sorted_base(p)];
    std::vector<Tri> tet_faces;
    tet_faces.reserve(4 * mesh.tets.size());
    for (const Tet& t : mesh.tets)
      for (int f = 0; f < 4; ++f) {
        const auto& fv = std::array<int, 3>{(f + 1) % 4, (f + 2) % 4, (f + 3) % 4};
        tet_faces.push_back(sorted_tri(t[fv[0]], t[fv[1]], t[fv[2]]));
      }
    std::sort(tet_faces.begin(), tet_faces.end());
    for (const auto& [q, n] : quads) {
      if (n > 2) add(fmt::format("conformity: quad face ({}, {}, {}, {}) is shared by {} cells", q[0], q[1], q[2], q[3], n));
      if (n != 1) continue;
      // Any three of the quad's points forming a tet face means a tet meets it.
      for (int skip = 0; skip < 4; ++skip) {
        Tri t{};
        for (int i = 0, j = 0; i < 4; ++i)
          if (i != skip) t[j++] = q[i];
        if (std::binary_search(tet_faces.begin(), tet_faces.end(), t)) {
          add(fmt::format("conformity: quad face ({}, {}, {}, {}) at {} meets tet faces", q[0], q[1], q[2], q[3],
                          where(q[0])));
          break;
        }
      }
    }
  }
  ValidationReport report;
  if (error_count == 0) {
    report = validate_mesh(split_to_tets(mesh), surface, options);
    if (!report.ok())
      report.errors.insert(report.errors.begin(),
                           fmt::format("(tets {} on are the prisms' cuts, three a prism, then the pyramids', two each)",
                                       mesh.tets.size()));
  } else {
    report.points = np;
  }
  report.tets = mesh.tets.size();
  report.prisms = mesh.prisms.size();
  report.pyramids = mesh.pyramids.size();
  report.error_count += error_count;
  report.errors.insert(report.errors.begin(), errors.begin(), errors.end());
  return report;
}

LayerReport measure_layers(const VolumeMesh& mesh) {
  LayerReport r;
  r.prisms = mesh.prisms.size();
  r.pyramids = mesh.pyramids.size();
  r.tets = mesh.tets.size();
  if (mesh.prisms.empty()) return r;
  const auto& P = mesh.points;
  // Each triangle face of a prism -> (prism, which: 0 bottom, 1 top).
  std::map<Tri, std::vector<std::pair<Index, int>>> faces;
  for (Index c = 0; c < mesh.prisms.size(); ++c) {
    const Prism& p = mesh.prisms[c];
    faces[sorted_tri(p[0], p[1], p[2])].emplace_back(c, 0);
    faces[sorted_tri(p[3], p[4], p[5])].emplace_back(c, 1);
  }
  constexpr double kInf = std::numeric_limits<double>::infinity();
  r.min_layers = std::numeric_limits<std::size_t>::max();
  r.first_height_min = r.ratio_min = kInf;
  r.first_height_max = r.ratio_max = -kInf;
  std::vector<std::size_t> lengths;
  for (const Tri& b : mesh.boundary) {
    const auto it = faces.find(sorted_tri(b[0], b[1], b[2]));
    if (it == faces.end()) continue;
    auto [cell, entered] = it->second.front();
    std::size_t n = 0;
    double below = 0;
    while (true) {
      const Prism& p = mesh.prisms[cell];
      const double h = prism_height(P, p);
      for (int i = 0; i < 3; ++i) {
        const double e = norm(P[p[(i + 1) % 3]] - P[p[i]]);
        if (h > 0) r.aspect_max = std::max(r.aspect_max, e / h);
      }
      if (n == 0) {
        r.first_height_min = std::min(r.first_height_min, h);
        r.first_height_max = std::max(r.first_height_max, h);
      } else if (below > 0) {
        r.ratio_min = std::min(r.ratio_min, h / below);
        r.ratio_max = std::max(r.ratio_max, h / below);
      }
      below = h;
      if (++n > mesh.prisms.size()) break;  // a cycle in a damaged mesh
      const Tri exit = entered == 0 ? sorted_tri(p[3], p[4], p[5]) : sorted_tri(p[0], p[1], p[2]);
      const auto next = faces.find(exit);
      if (next == faces.end() || next->second.size() != 2) break;
      const auto& other = next->second[0].first == cell ? next->second[1] : next->second[0];
      cell = other.first;
      entered = other.second;
    }
    lengths.push_back(n);
  }
  r.stacks = lengths.size();
  if (lengths.empty()) {
    r = LayerReport{r.prisms, r.pyramids, r.tets};
    return r;
  }
  r.min_layers = *std::min_element(lengths.begin(), lengths.end());
  r.max_layers = *std::max_element(lengths.begin(), lengths.end());
  r.full_stacks = static_cast<std::size_t>(std::count(lengths.begin(), lengths.end(), r.max_layers));
  if (r.ratio_min == kInf) r.ratio_min = r.ratio_max = 0;
  return r;
}

std::string format_layers(const LayerReport& r) {
  if (r.prisms == 0 && r.pyramids == 0) return {};
  std::string s = fmt::format("cells: {} tets, {} prisms, {} pyramids\n", r.tets, r.prisms, r.pyramids);
  if (r.stacks == 0) return s + "prism layers: no prism stands on a boundary triangle\n";
  s += fmt::format("prism layers: {} wall triangles with {} to {} layers; {} of them ({:.1f}%) reach {}\n", r.stacks,
                   r.min_layers, r.max_layers, r.full_stacks,
                   100.0 * static_cast<double>(r.full_stacks) / static_cast<double>(r.stacks), r.max_layers);
  s += fmt::format("first layer height {:.4g} to {:.4g}; height ratio between layers {:.4g} to {:.4g}; "
                   "largest aspect ratio (edge / height) {:.4g}\n",
                   r.first_height_min, r.first_height_max, r.ratio_min, r.ratio_max, r.aspect_max);
  return s;
}

std::string layers_to_json(const LayerReport& r) {
  const nlohmann::json j = {{"tets", r.tets},
                            {"prisms", r.prisms},
                            {"pyramids", r.pyramids},
                            {"wall_triangles", r.stacks},
                            {"min_layers", r.min_layers},
                            {"max_layers", r.max_layers},
                            {"full_stacks", r.full_stacks},
                            {"first_height_min", r.first_height_min},
                            {"first_height_max", r.first_height_max},
                            {"height_ratio_min", r.ratio_min},
                            {"height_ratio_max", r.ratio_max},
                            {"aspect_max", r.aspect_max}};
  return j.dump();
}

}  // namespace pdrmesh
