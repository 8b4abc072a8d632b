// SPDX-License-Identifier: AGPL-3.0-or-later
// The surface check's report (surface_check.hpp) as text for people, as JSON
// for scripts, and as the status that refuses an unmeshable surface.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pdrmesh/surface_check.hpp"

namespace pdrmesh {

namespace {

std::string json_key(DefectKind k) {
  std::string s(to_string(k));
  std::replace(s.begin(), s.end(), ' ', '_');
  std::replace(s.begin(), s.end(), '-', '_');
  return s;
}

/// "1 hole", "3 holes": a count and its noun.
std::string counted(std::size_t n, std::string_view noun) {
  return fmt::format("{} {}{}", n, noun, n == 1 ? "" : "s");
}

/// "3 holes (9 open edges), 1 non-manifold vertex": open edges are counted as the holes they form.
std::string counts_summary(const SurfaceReport& r) {
  std::vector<std::string> parts;
  for (std::size_t k = 0; k < kDefectKinds; ++k) {
    const auto kind = static_cast<DefectKind>(k);
    if (r.defect_counts[k] == 0) continue;
    if (kind == DefectKind::kOpenEdge && r.hole_count > 0) {
      parts.push_back(fmt::format("{} ({})", counted(r.hole_count, "hole"), counted(r.defect_counts[k], "open edge")));
    } else {
      parts.push_back(counted(r.defect_counts[k], to_string(kind)));
    }
  }
  return fmt::format("{}", fmt::join(parts, ", "));
}

/// One line per defect kept ("  open edge: ..."), the open edges as holes with the first edge of each.
void format_defects(const SurfaceReport& r, fmt::memory_buffer& out) {
  auto it = std::back_inserter(out);
  for (std::size_t k = 0; k < kDefectKinds; ++k) {
    const auto kind = static_cast<DefectKind>(k);
    if (kind == DefectKind::kOpenEdge && r.hole_count > 0) {
      for (std::size_t h = 0; h < r.holes.size(); ++h)
        fmt::format_to(it, "  hole {} ({}): {}\n", h + 1, counted(r.holes[h].open_edges, "open edge"),
                       r.holes[h].first.message);
      if (r.hole_count > r.holes.size()) fmt::format_to(it, "  ... and {} more holes\n", r.hole_count - r.holes.size());
      continue;
    }
    std::size_t shown = 0;
    for (const Defect& d : r.defects)
      if (d.kind == kind) {
        fmt::format_to(it, "  {}: {}\n", to_string(kind), d.message);
        ++shown;
      }
    if (r.defect_counts[k] > shown)
      fmt::format_to(it, "  ... and {} more {}{}\n", r.defect_counts[k] - shown, to_string(kind),
                     r.defect_counts[k] - shown == 1 ? "" : "s");
  }
}

}  // namespace

std::string format_report(const SurfaceReport& r, std::string_view name) {
  fmt::memory_buffer out;
  auto it = std::back_inserter(out);
  fmt::format_to(it, "{}: {} points, {} triangles, {} component{}: {}\n", name, r.points,
                 r.triangles, r.components.size(), r.components.size() == 1 ? "" : "s",
                 r.meshable() ? std::string("meshable") : fmt::format("NOT meshable: {}", counts_summary(r)));
  constexpr std::size_t kMaxComponents = 20;
  for (std::size_t c = 0; c < r.components.size() && c < kMaxComponents; ++c) {
    const ComponentReport& k = r.components[c];
    fmt::format_to(
        it,
        "  component {}: {} triangles, {} points, {}, {}, {}, euler {}{}, volume {:.6g}, "
        "{}\n",
        c, k.triangles, k.points, k.closed ? "closed" : "open",
        k.manifold ? "manifold" : "non-manifold",
        k.consistently_oriented ? "oriented" : "not oriented", k.euler,
        k.genus >= 0 ? fmt::format(", genus {}", k.genus) : std::string(), k.volume,
        k.closed && k.manifold && k.consistently_oriented
            ? fmt::format("depth {}{}{}", k.nesting_depth, k.outward ? ", outward" : "",
                          k.interface ? ", a region interface" : k.outward && k.volume < 0 ? ", a cavity" : "")
            : std::string("nesting not analysed"));
  }
  if (r.components.size() > kMaxComponents)
    fmt::format_to(it, "  ... and {} more components\n", r.components.size() - kMaxComponents);
  format_defects(r, out);
  return fmt::to_string(out);
}

std::string report_to_json(const SurfaceReport& r, std::string_view name) {
  nlohmann::json j;
  j["name"] = std::string(name);
  j["points"] = r.points;
  j["triangles"] = r.triangles;
  j["meshable"] = r.meshable();
  j["total_defects"] = r.total_defects();
  nlohmann::json counts = nlohmann::json::object();
  for (std::size_t k = 0; k < kDefectKinds; ++k)
    counts[json_key(static_cast<DefectKind>(k))] = r.defect_counts[k];
  j["defect_counts"] = counts;
  nlohmann::json comps = nlohmann::json::array();
  for (const ComponentReport& c : r.components) {
    comps.push_back({{"triangles", c.triangles},
                     {"points", c.points},
                     {"closed", c.closed},
                     {"manifold", c.manifold},
                     {"consistently_oriented", c.consistently_oriented},
                     {"euler", c.euler},
                     {"genus", c.genus},
                     {"volume", c.volume},
                     {"nesting_depth", c.nesting_depth},
                     {"outward", c.outward},
                     {"parent", c.parent == kNoIndex ? nlohmann::json(nullptr) : nlohmann::json(c.parent)},
                     {"interface", c.interface},
                     {"first_triangle", c.first_triangle}});
  }
  j["components"] = comps;
  nlohmann::json defects = nlohmann::json::array();
  for (const Defect& d : r.defects) {
    defects.push_back({{"kind", json_key(d.kind)},
                       {"triangles", d.triangles},
                       {"points", d.points},
                       {"where", d.where},
                       {"message", d.message}});
  }
  j["defects"] = defects;
  j["hole_count"] = r.hole_count;
  nlohmann::json holes = nlohmann::json::array();
  for (const HoleReport& h : r.holes)
    holes.push_back({{"open_edges", h.open_edges},
                     {"first_edge", {{"points", h.first.points}, {"triangles", h.first.triangles},
                                     {"where", h.first.where}, {"message", h.first.message}}}});
  j["holes"] = holes;
  return j.dump();
}

Status require_meshable(const SurfaceReport& r, std::string_view name) {
  if (r.meshable()) return Status::ok_status();
  constexpr std::size_t kShown = 3;
  std::vector<std::string> first;
  for (std::size_t i = 0; i < r.defects.size() && first.size() < kShown; ++i) {
    const Defect& d = r.defects[i];
    if (d.kind == DefectKind::kOpenEdge && r.hole_count > 0) continue;
    first.push_back(fmt::format("{}: {}", to_string(d.kind), d.message));
  }
  for (std::size_t h = 0; h < r.holes.size() && first.size() < kShown; ++h)
    first.push_back(fmt::format("hole ({}): {}", counted(r.holes[h].open_edges, "open edge"), r.holes[h].first.message));
  // Defects to list, each hole standing for its open edges.
  const std::size_t listed = r.total_defects() - r.count(DefectKind::kOpenEdge) + r.hole_count;
  return invalid_input(fmt::format("{}: the surface cannot be meshed: {}; {}{}", name, counts_summary(r),
                                   fmt::join(first, "; "), listed > first.size() ? "; ..." : ""));
}

}  // namespace pdrmesh
