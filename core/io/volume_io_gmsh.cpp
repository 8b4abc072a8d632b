// SPDX-License-Identifier: AGPL-3.0-or-later
// Gmsh 4.1 ASCII (.msh) volume meshes; 2.2 (ASCII and binary) is read too.
//
// Written: one surface entity and physical surface per surface id (named by
// the mesh's boundary_names, else "surface_<id>"), one volume entity and physical volume per region (named
// by the mesh's region_names, else "region_<r>"; a single one named "volume" when the mesh has no regions),
// all nodes in one block (tags 1..N in mesh order), elements grouped by
// entity with element tag = position in the mesh (tets 1..T, then boundary
// triangles T+1..T+B), so that reading back restores the original order.
// Physical tags equal the ids (regions) when those are all positive, else
// they count 1, 2, ... and the names carry the ids (a named surface then
// keeps its name, not its id).
// Read: Gmsh 4.1 ASCII and 2.2 (ASCII and binary) with 3-node triangles (type 2) and 4-node tets
// (type 4); points and lines are skipped, other element kinds are refused.
// A surface's id is its physical tag (4.1: its entity's first one), or the
// <id> of a physical name "surface_<id>"; any other physical name of a
// surface becomes the id's boundary name, and of a volume the region's name. Gmsh tets have the same positive
// orientation as VTK.
#include <fmt/compile.h>

#include <algorithm>
#include <map>
#include <numeric>

#include "volume_io_detail.hpp"

namespace pdrmesh::volio {
namespace {

constexpr int kGmshTriangle = 2;
constexpr int kGmshTetra = 4;
constexpr int kGmshPrism = 6;    ///< our vertex order (mixed_cells.hpp), as VTK's wedge
constexpr int kGmshPyramid = 7;  ///< our vertex order, as VTK's pyramid

/// Nodes per element of the Gmsh element types we may meet; 0 for unknown.
int gmsh_nodes(int type) {
  switch (type) {
    case 1: return 2;    // line
    case 2: return 3;    // triangle
    case 3: return 4;    // quad
    case 4: return 4;    // tet
    case 5: return 8;    // hex
    case 6: return 6;    // prism
    case 7: return 5;    // pyramid
    case 8: return 3;    // line3
    case 9: return 6;    // triangle6
    case 10: return 9;   // quad9
    case 11: return 10;  // tet10
    case 15: return 1;   // point
    case 16: return 8;   // quad8
    case 26: return 4;   // line4
    case 27: return 5;   // line5
    default: return 0;
  }
}
bool skippable(int type) { return type == 15 || type == 1 || type == 8 || type == 26 || type == 27; }
/// The element types a volume mesh is made of: triangles (its boundary), tets, prisms, pyramids.
bool readable(int type) {
  return type == kGmshTriangle || type == kGmshTetra || type == kGmshPrism || type == kGmshPyramid;
}
constexpr const char* kReadTypes = "3-node triangles, 4-node tetrahedra, 6-node prisms and 5-node pyramids";

/// Entity (1-based) of each value among the sorted distinct values.
std::vector<int> entity_of(const std::vector<int>& values, const std::vector<int>& keys) {
  std::vector<int> out(values.size());
  for (std::size_t i = 0; i < values.size(); ++i)
    out[i] = static_cast<int>(std::lower_bound(keys.begin(), keys.end(), values[i]) - keys.begin()) + 1;
  return out;
}

/// Element indices grouped by entity (stable within an entity).
std::vector<std::size_t> group_by(const std::vector<int>& entity, std::size_t n_entities) {
  std::vector<std::size_t> start(n_entities + 2, 0);
  for (int e : entity) ++start[static_cast<std::size_t>(e) + 1];
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<std::size_t> order(entity.size());
  for (std::size_t i = 0; i < entity.size(); ++i) order[start[static_cast<std::size_t>(entity[i])]++] = i;
  return order;
}

template <std::size_t K>
Box bounds_of(const VolumeMesh& mesh, const std::vector<std::array<Index, K>>& elements,
              const std::vector<std::size_t>& order, std::size_t begin, std::size_t end) {
  Box b;
  for (std::size_t k = begin; k < end; ++k)
    for (Index v : elements[order[k]]) b.add(mesh.points[v]);
  if (b.empty()) b.lo = b.hi = {0, 0, 0};
  return b;
}

struct Group {
  int tag;       // entity tag
  int physical;  // physical tag
  std::string name;
  std::size_t begin, end;  // range in the grouped order
  Box box;
};

/// A physical name as Gmsh reads it back: no double quotes, no line breaks.
std::string quotable(std::string name) {
  for (char& c : name)
    if (c == '"') c = '\'';
    else if (c == '\n' || c == '\r') c = ' ';
  return name;
}

template <std::size_t K, class NameOf>
std::vector<Group> make_groups(const VolumeMesh& mesh, const std::vector<std::array<Index, K>>& elements,
                               const std::vector<int>& values, NameOf&& name_of, std::vector<std::size_t>& order) {
  const std::vector<int> keys = distinct(values);
  const std::vector<int> entity = entity_of(values, keys);
  order = group_by(entity, keys.size());
  const bool positive = std::all_of(keys.begin(), keys.end(), [](int k) { return k > 0; });
  std::vector<std::size_t> counts(keys.size(), 0);
  for (int e : entity) ++counts[static_cast<std::size_t>(e) - 1];
  std::vector<Group> groups;
  std::size_t at = 0;
  for (std::size_t e = 0; e < keys.size(); ++e) {
    const std::size_t n = counts[e];
    const int tag = static_cast<int>(e) + 1;
    groups.push_back({tag, positive ? keys[e] : tag, quotable(name_of(keys[e])), at, at + n,
                      bounds_of(mesh, elements, order, at, at + n)});
    at += n;
  }
  return groups;
}

}  // namespace

Status write_gmsh(const VolumeMesh& mesh, const std::filesystem::path& path) {
  const std::size_t np = mesh.points.size(), nt = mesh.tets.size(), nb = mesh.boundary.size();
  std::vector<std::size_t> tri_order, tet_order;
  const std::vector<Group> surfaces = make_groups(
      mesh, mesh.boundary, mesh.boundary_ids, [&](int id) { return boundary_name(mesh.boundary_names, id); }, tri_order);
  std::vector<Group> volumes;
  if (mesh.tet_regions.empty()) {
    tet_order.resize(nt);
    std::iota(tet_order.begin(), tet_order.end(), std::size_t{0});
    volumes.push_back({1, 1, "volume", 0, nt, bounds_of(mesh, mesh.tets, tet_order, 0, nt)});
  } else {
    volumes = make_groups(
        mesh, mesh.tets, mesh.tet_regions, [&](int r) { return region_name(mesh.region_names, r); }, tet_order);
  }

  const std::array<const std::vector<Group>*, 2> lists{&surfaces, &volumes};

  OutputFile out(path);
  PDR_TRY(out.open());
  auto it = std::back_inserter(out.buf());
  fmt::format_to(it, "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n{}\n", surfaces.size() + volumes.size());
  for (const Group& g : surfaces) fmt::format_to(it, "2 {} \"{}\"\n", g.physical, g.name);
  for (const Group& g : volumes) fmt::format_to(it, "3 {} \"{}\"\n", g.physical, g.name);
  fmt::format_to(it, "$EndPhysicalNames\n$Entities\n0 0 {} {}\n", surfaces.size(), volumes.size());
  for (const std::vector<Group>* list : lists)
    for (const Group& g : *list)
      fmt::format_to(it, "{} {} {} {} {} {} {} 1 {} 0\n", g.tag, g.box.lo[0], g.box.lo[1], g.box.lo[2], g.box.hi[0],
                     g.box.hi[1], g.box.hi[2], g.physical);
  fmt::format_to(it, "$EndEntities\n$Nodes\n{} {} {} {}\n", np > 0 ? 1 : 0, np, np > 0 ? 1 : 0, np);
  if (np > 0) {
    fmt::format_to(it, "3 {} 0 {}\n", volumes.front().tag, np);
    for (std::size_t i = 1; i <= np; ++i) {
      fmt::format_to(it, FMT_COMPILE("{}\n"), i);
      PDR_TRY(out.maybe_flush());
    }
    for (const Vec3& p : mesh.points) {
      fmt::format_to(it, FMT_COMPILE("{} {} {}\n"), p[0], p[1], p[2]);
      PDR_TRY(out.maybe_flush());
    }
  }
  std::size_t blocks = 0;
  for (const std::vector<Group>* list : lists)
    for (const Group& g : *list) blocks += g.end > g.begin ? 1 : 0;
  fmt::format_to(it, "$EndNodes\n$Elements\n{} {} {} {}\n", blocks, nt + nb, nt + nb > 0 ? 1 : 0, nt + nb);
  for (const Group& g : volumes) {
    if (g.end == g.begin) continue;
    fmt::format_to(it, "3 {} {} {}\n", g.tag, kGmshTetra, g.end - g.begin);
    for (std::size_t k = g.begin; k < g.end; ++k) {
      const std::size_t t = tet_order[k];
      const Tet& e = mesh.tets[t];
      fmt::format_to(it, FMT_COMPILE("{} {} {} {} {}\n"), t + 1, e[0] + 1, e[1] + 1, e[2] + 1, e[3] + 1);
      PDR_TRY(out.maybe_flush());
    }
  }
  for (const Group& g : surfaces) {
    fmt::format_to(it, "2 {} {} {}\n", g.tag, kGmshTriangle, g.end - g.begin);
    for (std::size_t k = g.begin; k < g.end; ++k) {
      const std::size_t t = tri_order[k];
      const Tri& e = mesh.boundary[t];
      fmt::format_to(it, FMT_COMPILE("{} {} {} {}\n"), nt + t + 1, e[0] + 1, e[1] + 1, e[2] + 1);
      PDR_TRY(out.maybe_flush());
    }
  }
  fmt::format_to(it, "$EndElements\n");
  return out.close();
}

namespace {

class GmshReader {
 public:
  GmshReader(std::string_view text, const std::string& name) : text_(text), in_(text, name), bytes_(text, name) {}
  Result<VolumeMesh> read();

 private:
  Status read_format();
  Status read_physical_names();
  Status read_entities();
  /// "numEntityBlocks numItems minTag maxTag", opening $Nodes and $Elements.
  Status read_block_header(std::string_view what, std::size_t item_tokens, std::size_t& blocks, std::size_t& total);
  /// "entityDim entityTag <third>" opening a block of nodes or elements.
  Status read_block_start(int& dim, int& entity, int& third, std::string_view third_what);
  Status read_nodes();
  Status read_elements();
  /// Format 2.2: "count", then "tag x y z" lines (binary: int32 tag, 3 float64).
  Status read_nodes_v2();
  /// Where binary data begins: after the newline that ends the last token.
  Result<std::size_t> binary_start();
  /// Format 2.2: "count", then "tag type ntags tags... nodes..." lines.
  Status read_elements_v2();
  /// Binary 2.2: blocks of "type count ntags" and count records of int32
  /// "tag tags... nodes...".
  Status read_elements_v2_binary(std::size_t n);
  /// Sorts the points by tag when the tags are not 1..N in order.
  Status index_nodes();
  Status node_index(std::int64_t tag, Index& out);
  struct Raw;
  /// The id of a surface (dim 2) or volume (dim 3) element; `named` says
  /// whether a physical name "<prefix><int>" gave it. Other physical names of
  /// surfaces go to names_.
  int resolve(int dim, const Raw& raw, std::string_view prefix, bool& named);

  std::string_view text_;
  TextScanner in_;
  ByteReader bytes_;    ///< binary 2.2 sections
  bool binary_ = false;  ///< binary 2.2
  int major_ = 4;  ///< format version 4 (4.1) or 2 (2.2)
  bool have_format_ = false, have_nodes_ = false;
  std::map<std::pair<int, int>, std::string> physical_names_;
  std::map<std::pair<int, int>, int> entity_physical_;  // (dim, entity) -> first physical tag
  std::vector<std::int64_t> node_tags_;                 // sorted when !identity_
  bool identity_ = true;
  std::vector<Vec3> points_;
  struct Raw {
    std::int64_t tag;
    int entity;    ///< 4.1: the entity tag; 2.2: the elementary tag (0: none)
    int physical;  ///< 2.2: the physical tag (0: none); 4.1: unused
  };
  std::map<int, std::string> names_;
  std::map<int, std::string> region_names_;
  /// Keeps one element of a readable type; v holds its nodes (as many as the type has).
  void add_element(int type, const Raw& raw, const std::array<Index, 6>& v);

  std::vector<Raw> tet_raw_, tri_raw_, prism_raw_, pyramid_raw_;
  std::vector<Tet> tets_;
  std::vector<Tri> tris_;
  std::vector<Prism> prisms_;
  std::vector<Pyramid> pyramids_;
};

Status GmshReader::read_format() {
  const std::string_view version = in_.next();
  double v = 0;
  PDR_TRY(in_.parse_real(version, v, "format version"));
  if (v != 4.1 && v != 2.2 && v != 2.1 && v != 2.0)
    return unsupported(fmt::format("{}:{}: Gmsh format {}; 4.1 and 2.2 are read", in_.name(),
                                   in_.line_at(in_.last_token_start()), std::string(version)));
  major_ = v < 3 ? 2 : 4;
  int file_type = 0, data_size = 0;
  PDR_TRY(in_.integer(file_type, "file type"));
  if (file_type != 0 && (file_type != 1 || major_ != 2))
    return unsupported(fmt::format("{}: binary Gmsh {} files are not read (ASCII 4.1 and 2.2, binary 2.2 are)",
                                   in_.name(), std::string(version)));
  PDR_TRY(in_.integer(data_size, "data size"));
  if (data_size != 8) return in_.error(fmt::format("data size {}: only 8-byte reals are read", data_size));
  have_format_ = true;
  if (file_type == 1) {
    // The integer 1 in the writer's byte order.
    binary_ = true;
    PDR_ASSIGN_OR_RETURN(const std::size_t at, binary_start());
    PDR_TRY(bytes_.seek(at, "byte-order mark"));
    std::int32_t one = 0;
    PDR_TRY(bytes_.get(one, "byte-order mark"));
    if (one != 1 && byteswap_value(one) != 1) return bytes_.error_at(at, fmt::format("byte-order mark is {}, not 1", one));
    bytes_.set_swap(one != 1);
    in_.set_range(bytes_.pos(), text_.size());
  }
  return in_.expect("$EndMeshFormat");
}

Status GmshReader::read_physical_names() {
  std::size_t n = 0;
  PDR_TRY(in_.count(n, 3, "physical name count"));
  for (std::size_t i = 0; i < n; ++i) {
    int dim = 0, tag = 0;
    std::string name;
    PDR_TRY(in_.integer(dim, "physical dimension"));
    PDR_TRY(in_.integer(tag, "physical tag"));
    PDR_TRY(in_.quoted(name, "physical name"));
    physical_names_[{dim, tag}] = std::move(name);
  }
  return in_.expect("$EndPhysicalNames");
}

Status GmshReader::read_entities() {
  std::size_t counts[4] = {0, 0, 0, 0};
  for (std::size_t& c : counts) PDR_TRY(in_.count(c, 5, "entity count"));
  for (int dim = 0; dim < 4; ++dim) {
    for (std::size_t e = 0; e < counts[dim]; ++e) {
      int tag = 0;
      PDR_TRY(in_.integer(tag, "entity tag"));
      double x = 0;
      for (int k = 0; k < (dim == 0 ? 3 : 6); ++k) PDR_TRY(in_.real(x, "entity coordinate"));
      std::size_t nphys = 0;
      PDR_TRY(in_.count(nphys, 1, "physical tag count"));
      for (std::size_t k = 0; k < nphys; ++k) {
        int phys = 0;
        PDR_TRY(in_.integer(phys, "physical tag"));
        if (k == 0) entity_physical_[{dim, tag}] = phys;
      }
      if (dim > 0) {
        std::size_t nbound = 0;
        PDR_TRY(in_.count(nbound, 1, "bounding entity count"));
        std::int64_t b = 0;
        for (std::size_t k = 0; k < nbound; ++k) PDR_TRY(in_.integer(b, "bounding entity tag"));
      }
    }
  }
  return in_.expect("$EndEntities");
}

Status GmshReader::read_block_header(std::string_view what, std::size_t item_tokens, std::size_t& blocks,
                                     std::size_t& total) {
  std::int64_t min_tag = 0, max_tag = 0;
  PDR_TRY(in_.count(blocks, 4, fmt::format("{} block count", what)));
  PDR_TRY(in_.count(total, item_tokens, fmt::format("{} count", what)));
  PDR_TRY(in_.integer(min_tag, fmt::format("minimum {} tag", what)));
  return in_.integer(max_tag, fmt::format("maximum {} tag", what));
}

Status GmshReader::read_block_start(int& dim, int& entity, int& third, std::string_view third_what) {
  PDR_TRY(in_.integer(dim, "entity dimension"));
  PDR_TRY(in_.integer(entity, "entity tag"));
  return in_.integer(third, third_what);
}

Status GmshReader::read_nodes() {
  if (have_nodes_) return in_.error("second $Nodes section");
  have_nodes_ = true;
  std::size_t blocks = 0, total = 0;
  PDR_TRY(read_block_header("node", 4, blocks, total));
  node_tags_.reserve(total);
  points_.reserve(total);
  for (std::size_t b = 0; b < blocks; ++b) {
    int dim = 0, entity = 0, parametric = 0;
    std::size_t n = 0;
    PDR_TRY(read_block_start(dim, entity, parametric, "parametric flag"));
    PDR_TRY(in_.count(n, 4, "nodes in block"));
    if (node_tags_.size() + n > total)
      return in_.error(fmt::format("node blocks hold more than the {} nodes announced", total));
    const std::size_t first = node_tags_.size();
    for (std::size_t i = 0; i < n; ++i) {
      std::int64_t tag = 0;
      PDR_TRY(in_.integer(tag, "node tag"));
      if (tag < 1) return in_.error(fmt::format("node tag {} is not positive", tag));
      node_tags_.push_back(tag);
    }
    const int params = parametric != 0 ? std::clamp(dim, 0, 3) : 0;
    for (std::size_t i = 0; i < n; ++i) {
      Vec3 p;
      PDR_TRY(in_.real(p[0], "node x"));
      PDR_TRY(in_.real(p[1], "node y"));
      PDR_TRY(in_.real(p[2], "node z"));
      double u = 0;
      for (int k = 0; k < params; ++k) PDR_TRY(in_.real(u, "node parameter"));
      points_.push_back(p);
    }
    for (std::size_t i = first; i < node_tags_.size(); ++i) identity_ = identity_ && node_tags_[i] == static_cast<std::int64_t>(i) + 1;
  }
  if (node_tags_.size() != total)
    return in_.error(fmt::format("node blocks hold {} nodes, the header announced {}", node_tags_.size(), total));
  PDR_TRY(in_.expect("$EndNodes"));
  return index_nodes();
}

Result<std::size_t> GmshReader::binary_start() {
  std::size_t at = in_.pos();
  if (at < text_.size() && text_[at] == '\r') ++at;
  if (at >= text_.size() || text_[at] != '\n') return in_.error("expected a line break before binary data");
  return at + 1;
}

Status GmshReader::read_nodes_v2() {
  if (have_nodes_) return in_.error("second $Nodes section");
  have_nodes_ = true;
  std::size_t n = 0;
  PDR_TRY(in_.count(n, binary_ ? 1 : 4, "node count"));
  node_tags_.resize(n);
  points_.resize(n);
  if (binary_) {
    PDR_ASSIGN_OR_RETURN(const std::size_t at, binary_start());
    PDR_TRY(bytes_.seek(at, "nodes"));
    PDR_TRY(bytes_.fits(n, 28, text_.size() - at, "nodes"));
    for (std::size_t i = 0; i < n; ++i) {
      std::int64_t tag = 0;
      PDR_TRY(bytes_.integer(tag, 4, "node tag"));
      if (tag < 1) return bytes_.error(fmt::format("node tag {} is not positive", tag));
      node_tags_[i] = tag;
      identity_ = identity_ && tag == static_cast<std::int64_t>(i) + 1;
      for (double& c : points_[i]) PDR_TRY(bytes_.real(c, 8, "node coordinate"));
    }
    in_.set_range(bytes_.pos(), text_.size());
    PDR_TRY(in_.expect("$EndNodes"));
    return index_nodes();
  }
  for (std::size_t i = 0; i < n; ++i) {
    PDR_TRY(in_.integer(node_tags_[i], "node tag"));
    if (node_tags_[i] < 1) return in_.error(fmt::format("node tag {} is not positive", node_tags_[i]));
    identity_ = identity_ && node_tags_[i] == static_cast<std::int64_t>(i) + 1;
    PDR_TRY(in_.real(points_[i][0], "node x"));
    PDR_TRY(in_.real(points_[i][1], "node y"));
    PDR_TRY(in_.real(points_[i][2], "node z"));
  }
  PDR_TRY(in_.expect("$EndNodes"));
  return index_nodes();
}

Status GmshReader::index_nodes() {
  const std::size_t total = node_tags_.size();
  if (!identity_) {
    // Points in ascending tag order; lookups by binary search.
    std::vector<std::size_t> order(total);
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return node_tags_[a] < node_tags_[b]; });
    std::vector<std::int64_t> tags(total);
    std::vector<Vec3> points(total);
    for (std::size_t i = 0; i < total; ++i) {
      tags[i] = node_tags_[order[i]];
      points[i] = points_[order[i]];
      if (i > 0 && tags[i] == tags[i - 1]) return invalid_input(fmt::format("{}: node tag {} appears twice", in_.name(), tags[i]));
    }
    node_tags_ = std::move(tags);
    points_ = std::move(points);
  }
  return {};
}

Status GmshReader::node_index(std::int64_t tag, Index& out) {
  if (identity_) {
    if (tag < 1 || tag > static_cast<std::int64_t>(points_.size()))
      return in_.error(fmt::format("node tag {} is out of range: {} nodes", tag, points_.size()));
    out = static_cast<Index>(tag - 1);
    return {};
  }
  const auto it = std::lower_bound(node_tags_.begin(), node_tags_.end(), tag);
  if (it == node_tags_.end() || *it != tag) return in_.error(fmt::format("node tag {} is not in $Nodes", tag));
  out = static_cast<Index>(it - node_tags_.begin());
  return {};
}

Status GmshReader::read_elements() {
  if (!have_nodes_) return in_.error("$Elements before $Nodes");
  std::size_t blocks = 0, total = 0;
  PDR_TRY(read_block_header("element", 2, blocks, total));
  std::size_t seen = 0;
  for (std::size_t b = 0; b < blocks; ++b) {
    int dim = 0, entity = 0, type = 0;
    std::size_t n = 0;
    PDR_TRY(read_block_start(dim, entity, type, "element type"));
    const std::size_t type_at = in_.last_token_start();
    const int nodes = gmsh_nodes(type);
    if (nodes == 0) return in_.error(fmt::format("unknown element type {}", type));
    PDR_TRY(in_.count(n, 1, "elements in block"));
    if (!skippable(type) && !readable(type))
      return unsupported(fmt::format("{}:{}: {} elements of Gmsh type {}: only {} are read", in_.name(),
                                     in_.line_at(type_at), n, type, kReadTypes));
    if (static_cast<std::uint64_t>(n) * 2 * (static_cast<std::uint64_t>(nodes) + 1) > in_.remaining() + 1)
      return in_.error(fmt::format("{} elements of type {} are more than the rest of the file can hold", n, type));
    seen += n;
    if (seen > total) return in_.error(fmt::format("element blocks hold more than the {} elements announced", total));
    if (skippable(type)) {
      std::int64_t x = 0;
      for (std::size_t i = 0; i < n * (static_cast<std::size_t>(nodes) + 1); ++i) PDR_TRY(in_.integer(x, "element entry"));
      continue;
    }
    for (std::size_t i = 0; i < n; ++i) {
      std::int64_t tag = 0, node = 0;
      PDR_TRY(in_.integer(tag, "element tag"));
      std::array<Index, 6> v{};
      for (int k = 0; k < nodes; ++k) {
        PDR_TRY(in_.integer(node, "element node"));
        PDR_TRY(node_index(node, v[static_cast<std::size_t>(k)]));
      }
      add_element(type, {tag, entity, 0}, v);
    }
  }
  if (seen != total) return in_.error(fmt::format("element blocks hold {} elements, the header announced {}", seen, total));
  return in_.expect("$EndElements");
}

Status GmshReader::read_elements_v2() {
  if (!have_nodes_) return in_.error("$Elements before $Nodes");
  std::size_t n = 0;
  PDR_TRY(in_.count(n, binary_ ? 1 : 4, "element count"));
  if (binary_) return read_elements_v2_binary(n);
  for (std::size_t i = 0; i < n; ++i) {
    std::int64_t tag = 0;
    int type = 0, ntags = 0;
    PDR_TRY(in_.integer(tag, "element tag"));
    PDR_TRY(in_.integer(type, "element type"));
    const std::size_t type_at = in_.last_token_start();
    const int nodes = gmsh_nodes(type);
    if (nodes == 0) return in_.error(fmt::format("unknown element type {}", type));
    if (!skippable(type) && !readable(type))
      return unsupported(fmt::format("{}:{}: an element of Gmsh type {}: only {} are read", in_.name(),
                                     in_.line_at(type_at), type, kReadTypes));
    PDR_TRY(in_.integer(ntags, "tag count"));
    if (ntags < 0 || static_cast<std::size_t>(ntags) * 2 > in_.remaining() + 1)
      return in_.error(fmt::format("tag count {} is not valid", ntags));
    int tags[2] = {0, 0};
    for (int k = 0; k < ntags; ++k) {
      int t = 0;
      PDR_TRY(in_.integer(t, "element tag"));
      if (k < 2) tags[k] = t;
    }
    std::array<Index, 6> v{};
    for (int k = 0; k < nodes; ++k) {
      std::int64_t node = 0;
      PDR_TRY(in_.integer(node, "element node"));
      if (!skippable(type)) PDR_TRY(node_index(node, v[static_cast<std::size_t>(k)]));
    }
    if (!skippable(type)) add_element(type, {tag, tags[1], tags[0]}, v);
  }
  return in_.expect("$EndElements");
}

void GmshReader::add_element(int type, const Raw& raw, const std::array<Index, 6>& v) {
  switch (type) {
    case kGmshTriangle:
      tris_.push_back({v[0], v[1], v[2]});
      tri_raw_.push_back(raw);
      break;
    case kGmshTetra:
      tets_.push_back({v[0], v[1], v[2], v[3]});
      tet_raw_.push_back(raw);
      break;
    case kGmshPrism:
      prisms_.push_back(v);
      prism_raw_.push_back(raw);
      break;
    case kGmshPyramid:
      pyramids_.push_back({v[0], v[1], v[2], v[3], v[4]});
      pyramid_raw_.push_back(raw);
      break;
    default: break;
  }
}

Status GmshReader::read_elements_v2_binary(std::size_t n) {
  PDR_ASSIGN_OR_RETURN(const std::size_t at, binary_start());
  PDR_TRY(bytes_.seek(at, "elements"));
  for (std::size_t seen = 0; seen < n;) {
    std::int64_t type = 0, count = 0, ntags = 0;
    const std::size_t block_at = bytes_.pos();
    PDR_TRY(bytes_.integer(type, 4, "element type"));
    PDR_TRY(bytes_.integer(count, 4, "element count"));
    PDR_TRY(bytes_.integer(ntags, 4, "tag count"));
    const int nodes = type > 0 && type < 100 ? gmsh_nodes(static_cast<int>(type)) : 0;
    if (nodes == 0) return bytes_.error_at(block_at, fmt::format("unknown element type {}", type));
    if (!skippable(static_cast<int>(type)) && !readable(static_cast<int>(type)))
      return unsupported(fmt::format("{}: byte offset {}: elements of Gmsh type {}: only {} are read", in_.name(),
                                     block_at, type, kReadTypes));
    if (count < 1 || static_cast<std::uint64_t>(count) > n - seen || ntags < 0 || ntags > 1000)
      return bytes_.error_at(block_at, fmt::format("element block of {} elements with {} tags is not valid", count, ntags));
    const std::uint64_t record = 4 * (1 + static_cast<std::uint64_t>(ntags) + static_cast<std::uint64_t>(nodes));
    PDR_TRY(bytes_.fits(static_cast<std::uint64_t>(count), record, text_.size() - bytes_.pos(), "elements"));
    for (std::int64_t e = 0; e < count; ++e) {
      std::int64_t tag = 0, x = 0;
      PDR_TRY(bytes_.integer(tag, 4, "element tag"));
      int tags[2] = {0, 0};
      for (std::int64_t k = 0; k < ntags; ++k) {
        PDR_TRY(bytes_.integer(x, 4, "element tag"));
        if (k < 2) tags[k] = static_cast<int>(x);
      }
      std::array<Index, 6> v{};
      for (int k = 0; k < nodes; ++k) {
        PDR_TRY(bytes_.integer(x, 4, "element node"));
        if (!skippable(static_cast<int>(type))) {
          if (Status s = node_index(x, v[static_cast<std::size_t>(k)]); !s.ok())
            return bytes_.error(fmt::format("node tag {} is not in $Nodes", x));
        }
      }
      if (!skippable(static_cast<int>(type))) add_element(static_cast<int>(type), {tag, tags[1], tags[0]}, v);
    }
    seen += static_cast<std::size_t>(count);
  }
  in_.set_range(bytes_.pos(), text_.size());
  return in_.expect("$EndElements");
}

int GmshReader::resolve(int dim, const Raw& raw, std::string_view prefix, bool& named) {
  named = false;
  int phys = raw.physical;
  if (major_ == 4) {
    const auto it = entity_physical_.find({dim, raw.entity});
    if (it == entity_physical_.end()) return raw.entity;
    phys = it->second;
  } else if (phys == 0) {
    return raw.entity;
  }
  const auto name = physical_names_.find({dim, phys});
  if (name == physical_names_.end()) return phys;
  int id = 0;
  if (parse_suffixed_int(name->second, prefix, id)) {
    named = true;
    return id;
  }
  (dim == 2 ? names_ : region_names_).emplace(phys, name->second);
  return phys;
}

/// Element order by element tag (stable), as written.
template <class Raw>
std::vector<std::size_t> by_tag(const std::vector<Raw>& raw) {
  std::vector<std::size_t> order(raw.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  if (!std::is_sorted(raw.begin(), raw.end(), [](const Raw& a, const Raw& b) { return a.tag < b.tag; }))
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return raw[a].tag < raw[b].tag; });
  return order;
}

Result<VolumeMesh> GmshReader::read() {
  for (;;) {
    const std::string_view section = in_.next();
    if (section.empty()) break;
    if (section == "$MeshFormat") {
      PDR_TRY(read_format());
    } else if (!have_format_) {
      return in_.error(fmt::format("expected $MeshFormat, got {}", show(section)));
    } else if (section == "$PhysicalNames") {
      PDR_TRY(read_physical_names());
    } else if (section == "$Entities") {
      PDR_TRY(read_entities());
    } else if (section == "$Nodes") {
      PDR_TRY(major_ == 2 ? read_nodes_v2() : read_nodes());
    } else if (section == "$Elements") {
      PDR_TRY(major_ == 2 ? read_elements_v2() : read_elements());
    } else if (section.size() > 1 && section[0] == '$') {
      const std::string end = fmt::format("$End{}", section.substr(1));
      for (std::string_view t = in_.next(); t != end; t = in_.next())
        if (t.empty()) return in_.end_error(fmt::format("'{}'", end));
    } else {
      return in_.error(fmt::format("expected a $Section, got {}", show(section)));
    }
  }
  if (!have_format_) return invalid_input(fmt::format("{}: not a Gmsh file (no $MeshFormat)", in_.name()));
  if (!have_nodes_) return invalid_input(fmt::format("{}: no $Nodes section", in_.name()));

  VolumeMesh mesh;
  mesh.points = std::move(points_);
  const std::vector<std::size_t> tri_order = by_tag(tri_raw_);
  mesh.boundary.reserve(tris_.size());
  mesh.boundary_ids.reserve(tris_.size());
  bool named = false;
  for (std::size_t i : tri_order) {
    mesh.boundary.push_back(tris_[i]);
    mesh.boundary_ids.push_back(resolve(2, tri_raw_[i], "surface_", named));
  }
  // Cells of each kind in tag order, with the region of their volume.
  std::vector<int> entities;
  bool any_named = false;
  const auto cells = [&](const auto& list, const std::vector<Raw>& raw, auto& to, std::vector<int>& regions) {
    for (std::size_t i : by_tag(raw)) {
      to.push_back(list[i]);
      regions.push_back(resolve(3, raw[i], "region_", named));
      any_named = any_named || named;
      entities.push_back(major_ == 2 ? regions.back() : raw[i].entity);
    }
  };
  cells(tets_, tet_raw_, mesh.tets, mesh.tet_regions);
  cells(prisms_, prism_raw_, mesh.prisms, mesh.prism_regions);
  cells(pyramids_, pyramid_raw_, mesh.pyramids, mesh.pyramid_regions);
  // One unnamed volume means "no regions" (what we write for a mesh without them).
  if (any_named || distinct(std::move(entities)).size() > 1) {
    mesh.region_names = std::move(region_names_);
  } else {
    mesh.tet_regions.clear();
    mesh.prism_regions.clear();
    mesh.pyramid_regions.clear();
  }
  mesh.boundary_names = std::move(names_);
  return mesh;
}

}  // namespace

Result<VolumeMesh> read_gmsh(std::string_view text, const std::string& name) { return GmshReader(text, name).read(); }

}  // namespace pdrmesh::volio
