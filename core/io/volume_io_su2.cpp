// SPDX-License-Identifier: AGPL-3.0-or-later
// SU2 native ASCII (.su2) volume meshes.
//
//   NDIME= 3
//   NELEM= <cells>       then "10 a b c d <element index>" (0-based points) per
//                        tet, then "13 a b c d e f <index>" per prism and
//                        "14 a b c d e <index>" per pyramid (mixed meshes)
//   NPOIN= <points>      then "x y z <point index>"
//   NMARK= <markers>     then per marker "MARKER_TAG= <name>",
//                        "MARKER_ELEMS= <n>" and "5 a b c" per triangle
// SU2 uses VTK's cell types, orientation and vertex order (ours, mixed_cells.hpp). Markers are written in ascending surface
// id, tagged with the id's boundary name ("surface_<id>" when it has none).
// Reading maps "surface_<id>" back to <id> with no name, and gives any other
// tag the next unused id 1, 2, ... in order of first appearance, named by the
// tag (sanitize_boundary_name; markers of one tag share the id). So a named
// id keeps its name but may come back as another number. The boundary comes
// back grouped by marker, so only a boundary already sorted by id
// round-trips in order.
// SU2 holds no regions. '%' starts a comment.
#include <fmt/compile.h>

#include <algorithm>
#include <limits>
#include <map>
#include <set>
#include <type_traits>

#include "pdrmesh/boundary_names.hpp"
#include "volume_io_detail.hpp"

namespace pdrmesh::volio {
namespace {

constexpr int kSu2Triangle = 5;
constexpr int kSu2Tetra = 10;
constexpr int kSu2Prism = 13;
constexpr int kSu2Pyramid = 14;

}  // namespace

Status write_su2(const VolumeMesh& mesh, const std::filesystem::path& path) {
  OutputFile out(path);
  PDR_TRY(out.open());
  auto it = std::back_inserter(out.buf());
  fmt::format_to(it, "% SU2 mesh written by pdrmesh\nNDIME= 3\nNELEM= {}\n",
                 mesh.tets.size() + mesh.prisms.size() + mesh.pyramids.size());
  for (std::size_t i = 0; i < mesh.tets.size(); ++i) {
    const Tet& t = mesh.tets[i];
    fmt::format_to(it, FMT_COMPILE("{} {} {} {} {} {}\n"), kSu2Tetra, t[0], t[1], t[2], t[3], i);
    PDR_TRY(out.maybe_flush());
  }
  std::size_t index = mesh.tets.size();
  const auto cells = [&](int type, const auto& list) -> Status {
    for (const auto& c : list) {
      fmt::format_to(it, FMT_COMPILE("{} "), type);
      put_cell(out.buf(), c, 0);
      fmt::format_to(it, FMT_COMPILE(" {}\n"), index++);
      PDR_TRY(out.maybe_flush());
    }
    return {};
  };
  PDR_TRY(cells(kSu2Prism, mesh.prisms));
  PDR_TRY(cells(kSu2Pyramid, mesh.pyramids));
  fmt::format_to(it, "NPOIN= {}\n", mesh.points.size());
  for (std::size_t i = 0; i < mesh.points.size(); ++i) {
    const Vec3& p = mesh.points[i];
    fmt::format_to(it, FMT_COMPILE("{} {} {} {}\n"), p[0], p[1], p[2], i);
    PDR_TRY(out.maybe_flush());
  }
  // Triangles per id, in mesh order within an id.
  std::vector<std::size_t> order(mesh.boundary.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return mesh.boundary_ids[a] < mesh.boundary_ids[b]; });
  const std::vector<int> ids = distinct(mesh.boundary_ids);
  fmt::format_to(it, "NMARK= {}\n", ids.size());
  std::size_t k = 0;
  for (int id : ids) {
    const std::size_t begin = k;
    while (k < order.size() && mesh.boundary_ids[order[k]] == id) ++k;
    fmt::format_to(it, "MARKER_TAG= {}\nMARKER_ELEMS= {}\n", boundary_name(mesh.boundary_names, id), k - begin);
    for (std::size_t j = begin; j < k; ++j) {
      const Tri& t = mesh.boundary[order[j]];
      fmt::format_to(it, FMT_COMPILE("{} {} {} {}\n"), kSu2Triangle, t[0], t[1], t[2]);
      PDR_TRY(out.maybe_flush());
    }
  }
  return out.close();
}

namespace {

class Su2Reader {
 public:
  Su2Reader(std::string_view text, const std::string& name) : in_(text, name, '%') {}
  Result<VolumeMesh> read();

 private:
  /// "KEY= value", "KEY=value" or "KEY = value" starting at token `t`.
  Status key_value(std::string_view t, std::string_view& key, std::string_view& value);
  Status expect_key(std::string_view want, std::string_view& value);
  /// A 0-based point index; checked against NPOIN once that is known.
  Status raw_index(Index& v, std::string_view what);

  TextScanner in_;
  std::int64_t max_index_ = -1;
  std::size_t max_index_pos_ = 0;
};

Status Su2Reader::key_value(std::string_view t, std::string_view& key, std::string_view& value) {
  const std::size_t eq = t.find('=');
  if (eq != std::string_view::npos) {
    key = t.substr(0, eq);
    value = t.substr(eq + 1);
    if (value.empty()) value = in_.next_in_line();
    return {};
  }
  key = t;
  const std::string_view n = in_.next_in_line();
  if (n == "=") {
    value = in_.next_in_line();
  } else if (!n.empty() && n[0] == '=') {
    value = n.substr(1);
  } else {
    return in_.error(fmt::format("expected '{}= value'", std::string(key)));
  }
  return {};
}

Status Su2Reader::expect_key(std::string_view want, std::string_view& value) {
  const std::string_view t = in_.next();
  std::string_view key;
  if (t.empty()) return in_.end_error(fmt::format("{}=", want));
  PDR_TRY(key_value(t, key, value));
  if (key != want) return in_.error(fmt::format("expected {}=, got {}", want, show(key)));
  return {};
}

Status Su2Reader::raw_index(Index& v, std::string_view what) {
  std::int64_t w = 0;
  PDR_TRY(in_.integer(w, what));
  if (w < 0 || w >= static_cast<std::int64_t>(kNoIndex)) return in_.error(fmt::format("{} {} is out of range", what, w));
  if (w > max_index_) {
    max_index_ = w;
    max_index_pos_ = in_.last_token_start();
  }
  v = static_cast<Index>(w);
  return {};
}

Result<VolumeMesh> Su2Reader::read() {
  VolumeMesh mesh;
  bool have_dim = false, have_points = false;
  struct Marker {
    std::string tag;
    std::size_t begin, end;
  };
  std::vector<Marker> markers;
  for (;;) {
    const std::string_view t = in_.next();
    if (t.empty()) break;
    std::string_view key, value;
    PDR_TRY(key_value(t, key, value));
    if (key == "NDIME") {
      std::int64_t dim = 0;
      PDR_TRY(in_.parse_integer(value, dim, "NDIME"));
      if (dim != 3) return unsupported(fmt::format("{}:{}: NDIME= {}: only 3D meshes are read", in_.name(),
                                                   in_.line_at(in_.last_token_start()), dim));
      have_dim = true;
    } else if (key == "NZONE") {
      std::int64_t zones = 0;
      PDR_TRY(in_.parse_integer(value, zones, "NZONE"));
      if (zones != 1) return unsupported(fmt::format("{}: NZONE= {}: multi-zone meshes are not read", in_.name(), zones));
    } else if (key == "NELEM") {
      std::size_t n = 0;
      PDR_TRY(in_.parse_count(value, n, 6, "NELEM"));
      mesh.tets.reserve(n);
      // Cells in VTK's vertex order, which is ours (mixed_cells.hpp).
      const auto cell = [&](auto& list) -> Status {
        typename std::remove_reference_t<decltype(list)>::value_type k{};
        for (Index& v : k) PDR_TRY(raw_index(v, "element point"));
        list.push_back(k);
        return {};
      };
      for (std::size_t i = 0; i < n; ++i) {
        int type = 0;
        PDR_TRY(in_.integer(type, "element type"));
        if (type == kSu2Tetra) {
          PDR_TRY(cell(mesh.tets));
        } else if (type == kSu2Prism) {
          PDR_TRY(cell(mesh.prisms));
        } else if (type == kSu2Pyramid) {
          PDR_TRY(cell(mesh.pyramids));
        } else {
          return unsupported(fmt::format("{}:{}: element of VTK type {}: only tetrahedra (10), prisms (13) and "
                                         "pyramids (14) are read", in_.name(), in_.line_at(in_.last_token_start()), type));
        }
        in_.skip_line();  // the optional element index
      }
    } else if (key == "NPOIN") {
      std::size_t n = 0;
      PDR_TRY(in_.parse_count(value, n, 3, "NPOIN"));
      in_.skip_line();  // an optional count of domain points
      mesh.points.resize(n);
      for (Vec3& p : mesh.points) {
        PDR_TRY(in_.real(p[0], "point x"));
        PDR_TRY(in_.real(p[1], "point y"));
        PDR_TRY(in_.real(p[2], "point z"));
        in_.skip_line();  // the optional point index
      }
      have_points = true;
    } else if (key == "NMARK") {
      std::size_t n = 0;
      PDR_TRY(in_.parse_count(value, n, 4, "NMARK"));
      for (std::size_t m = 0; m < n; ++m) {
        std::string_view tag, elems;
        PDR_TRY(expect_key("MARKER_TAG", tag));
        if (tag.empty()) return in_.error("empty MARKER_TAG");
        Marker marker{std::string(tag), mesh.boundary.size(), 0};
        PDR_TRY(expect_key("MARKER_ELEMS", elems));
        std::size_t ne = 0;
        PDR_TRY(in_.parse_count(elems, ne, 4, "MARKER_ELEMS"));
        for (std::size_t i = 0; i < ne; ++i) {
          int type = 0;
          PDR_TRY(in_.integer(type, "marker element type"));
          if (type != kSu2Triangle)
            return unsupported(fmt::format("{}:{}: marker element of VTK type {}: only triangles (5) are read",
                                           in_.name(), in_.line_at(in_.last_token_start()), type));
          Tri k{};
          for (Index& v : k) PDR_TRY(raw_index(v, "marker element point"));
          mesh.boundary.push_back(k);
          in_.skip_line();
        }
        marker.end = mesh.boundary.size();
        markers.push_back(std::move(marker));
      }
    } else {
      in_.skip_line();  // a key we do not need
    }
  }
  if (!have_dim) return invalid_input(fmt::format("{}: no NDIME= line", in_.name()));
  if (!have_points) return invalid_input(fmt::format("{}: no NPOIN= section", in_.name()));
  if (max_index_ >= static_cast<std::int64_t>(mesh.points.size()))
    return in_.error_at(max_index_pos_, fmt::format("point index {} is out of range: {} points numbered from 0",
                                                    max_index_, mesh.points.size()));
  // Marker tags to ids: "surface_<id>" -> id, others the next unused 1, 2, ...
  // (one per distinct tag), named by the tag.
  std::vector<int> marker_id(markers.size(), 0);
  std::vector<bool> parsed(markers.size(), false);
  std::set<int> used;
  for (std::size_t m = 0; m < markers.size(); ++m) {
    parsed[m] = parse_suffixed_int(markers[m].tag, "surface_", marker_id[m]);
    if (parsed[m]) used.insert(marker_id[m]);
  }
  int next = 1;
  std::map<std::string_view, int> tag_id;
  std::map<std::string, std::string_view> tag_of_name;  // boundary name -> the tag that gave it
  for (std::size_t m = 0; m < markers.size(); ++m) {
    if (parsed[m]) continue;
    const std::string& tag = markers[m].tag;
    if (const auto known = tag_id.find(tag); known != tag_id.end()) {
      marker_id[m] = known->second;
      continue;
    }
    while (used.count(next) != 0) ++next;
    marker_id[m] = next++;
    tag_id.emplace(tag, marker_id[m]);
    std::string name = sanitize_boundary_name(tag);
    if (!check_boundary_name(marker_id[m], name).ok()) continue;  // "surface_-3" and the like: no name
    const auto [first, fresh] = tag_of_name.try_emplace(name, tag);
    if (!fresh)
      return invalid_input(fmt::format("{}: the marker tags {} and {} both give the boundary name '{}'", in_.name(),
                                       show(first->second), show(tag), name));
    mesh.boundary_names.emplace(marker_id[m], std::move(name));
  }
  mesh.boundary_ids.resize(mesh.boundary.size());
  for (std::size_t m = 0; m < markers.size(); ++m)
    std::fill(mesh.boundary_ids.begin() + static_cast<std::ptrdiff_t>(markers[m].begin),
              mesh.boundary_ids.begin() + static_cast<std::ptrdiff_t>(markers[m].end), marker_id[m]);
  return mesh;
}

}  // namespace

Result<VolumeMesh> read_su2(std::string_view text, const std::string& name) { return Su2Reader(text, name).read(); }

}  // namespace pdrmesh::volio
