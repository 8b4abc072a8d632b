// SPDX-License-Identifier: AGPL-3.0-or-later
// VTK XML UnstructuredGrid (.vtu) volume meshes, for ParaView and friends.
//
// Cells are the tets (VTK_TETRA, 10) followed by the boundary triangles
// (VTK_TRIANGLE, 5). Cell data: `min_dihedral` (Float64, degrees; meaningful
// for tets only, 0 for triangles), `surface_id` (Int32, 0 for tets) and, when
// the mesh has regions, `region` (Int32, 0 for triangles). min_dihedral is
// what dihedral_range gives (NaN where a tet's geometry overflows doubles);
// it is output only and not read back. Everything is written as
// format="ascii" with shortest round-trip numbers, which is exact (checked
// bit-exact through VTK 9.1's vtkXMLUnstructuredGridReader).
// The reader is not a general XML parser: it reads ascii DataArrays of an
// UnstructuredGrid with one Piece (what we write, and what VTK/ParaView write
// in ascii mode) and reports anything else clearly.
#include <fmt/compile.h>
#include <oneapi/tbb/parallel_for.h>

#include <optional>
#include <vector>

#include "pdrmesh/quality.hpp"
#include "volume_io_detail.hpp"

namespace pdrmesh::volio {
namespace {

constexpr int kVtkTriangle = 5;
constexpr int kVtkTetra = 10;

/// One DataArray of `n` values, `fn(out_iterator, i)` writing value i (it
/// must only read shared data). Eight values a line. The lines are formatted
/// in parallel, a chunk of them to a buffer each, and written in order: the
/// same bytes for any thread count.
template <class Fn>
Status write_array(OutputFile& out, std::string_view header, std::size_t n, Fn&& fn) {
  auto it = std::back_inserter(out.buf());
  fmt::format_to(it, "        {}\n", header);
  constexpr std::size_t kChunk = 8 * 2048;  // values a chunk (whole lines)
  constexpr std::size_t kBatch = 64;        // chunks formatted at once (bounded memory)
  std::vector<fmt::memory_buffer> chunks(std::min(kBatch, (n + kChunk - 1) / kChunk));
  for (std::size_t first = 0; first < n; first += kChunk * kBatch) {
    const std::size_t count = std::min(kBatch, (n - first + kChunk - 1) / kChunk);
    tbb::parallel_for(std::size_t{0}, count, [&](std::size_t c) {
      fmt::memory_buffer& b = chunks[c];
      b.clear();
      auto o = std::back_inserter(b);
      const std::size_t lo = first + c * kChunk, hi = std::min(n, lo + kChunk);
      for (std::size_t i = lo; i < hi; ++i) {
        fn(o, i);
        if ((i + 1) % 8 == 0 || i + 1 == n) b.push_back('\n');
      }
    });
    for (std::size_t c = 0; c < count; ++c) {
      out.buf().append(chunks[c].data(), chunks[c].data() + chunks[c].size());
      PDR_TRY(out.maybe_flush());
    }
  }
  fmt::format_to(it, "        </DataArray>\n");
  return {};
}

/// The value of attribute `key` in an XML start tag, if present.
std::optional<std::string_view> attribute(std::string_view tag, std::string_view key) {
  std::size_t from = 0;
  while (true) {
    const std::size_t at = tag.find(key, from);
    if (at == std::string_view::npos) return std::nullopt;
    from = at + key.size();
    if (at == 0 || (tag[at - 1] != ' ' && tag[at - 1] != '\t' && tag[at - 1] != '\n' && tag[at - 1] != '\r'))
      continue;
    std::size_t p = from;
    while (p < tag.size() && (tag[p] == ' ' || tag[p] == '\t')) ++p;
    if (p >= tag.size() || tag[p] != '=') continue;
    ++p;
    while (p < tag.size() && (tag[p] == ' ' || tag[p] == '\t')) ++p;
    if (p >= tag.size() || (tag[p] != '"' && tag[p] != '\'')) continue;
    const char quote = tag[p];
    const std::size_t close = tag.find(quote, p + 1);
    if (close == std::string_view::npos) return std::nullopt;
    return tag.substr(p + 1, close - p - 1);
  }
}

struct Element {
  std::size_t start = 0;  ///< position of '<'
  std::string_view tag;   ///< the start tag, '<' to '>'
  std::size_t content_begin = 0, content_end = 0;
};

class VtuReader {
 public:
  VtuReader(std::string_view text, const std::string& name) : text_(text), in_(text, name) {}

  Result<VolumeMesh> read();

 private:
  /// Finds the first element `<name` in [from, to); its content ends at `</name>`.
  Result<std::optional<Element>> find(std::string_view name, std::size_t from, std::size_t to);
  Result<std::size_t> attribute_count(const Element& e, std::string_view key);
  Status check_ascii(const Element& e);
  template <class T>
  Status parse_array(const Element& e, std::size_t n, std::vector<T>& out, std::string_view what);
  Result<std::optional<Element>> named_array(const Element& section, std::string_view name);

  std::string_view text_;
  TextScanner in_;
};

Result<std::optional<Element>> VtuReader::find(std::string_view name, std::size_t from, std::size_t to) {
  std::size_t at = from;
  for (;;) {
    at = text_.find(fmt::format("<{}", name), at);
    if (at == std::string_view::npos || at >= to) return std::optional<Element>{};
    const char after = at + 1 + name.size() < text_.size() ? text_[at + 1 + name.size()] : '\0';
    if (after == ' ' || after == '>' || after == '/' || after == '\n' || after == '\t' || after == '\r') break;
    at += 1 + name.size();
  }
  const std::size_t close = text_.find('>', at);
  if (close == std::string_view::npos || close >= to)
    return in_.error_at(at, fmt::format("unterminated <{}> tag", name));
  Element e;
  e.start = at;
  e.tag = text_.substr(at, close + 1 - at);
  e.content_begin = close + 1;
  if (text_[close - 1] == '/') {
    e.content_end = e.content_begin;
  } else {
    const std::size_t end = text_.find(fmt::format("</{}>", name), e.content_begin);
    if (end == std::string_view::npos || end > to) return in_.error_at(at, fmt::format("<{}> is not closed", name));
    e.content_end = end;
  }
  return std::optional<Element>{e};
}

Result<std::size_t> VtuReader::attribute_count(const Element& e, std::string_view key) {
  const auto v = attribute(e.tag, key);
  if (!v) return in_.error_at(e.start, fmt::format("missing attribute {}", key));
  std::int64_t n = 0;
  const auto [p, ec] = std::from_chars(v->data(), v->data() + v->size(), n);
  if (ec != std::errc() || p != v->data() + v->size() || n < 0 || static_cast<std::uint64_t>(n) >= kNoIndex)
    return in_.error_at(e.start, fmt::format("attribute {}=\"{}\" is not a valid count", key, *v));
  return static_cast<std::size_t>(n);
}

Status VtuReader::check_ascii(const Element& e) {
  const auto format = attribute(e.tag, "format");
  if (!format || *format != "ascii")
    return unsupported(fmt::format("{}:{}: DataArray '{}' has format=\"{}\"; only ascii VTU files are read",
                                   in_.name(), in_.line_at(e.start), attribute(e.tag, "Name").value_or(""),
                                   format.value_or("")));
  return {};
}

template <class T>
Status VtuReader::parse_array(const Element& e, std::size_t n, std::vector<T>& out, std::string_view what) {
  PDR_TRY(check_ascii(e));
  // The values end where nested markup (VTK's <InformationKey>) begins.
  const std::size_t end = std::min(e.content_end, text_.find('<', e.content_begin));
  const std::size_t length = end - e.content_begin;
  if (static_cast<std::uint64_t>(n) * 2 > length + 1)
    return in_.error_at(e.start, fmt::format("{} needs {} values but holds only {} bytes", what, n, length));
  in_.set_range(e.content_begin, end);
  out.resize(n);
  for (T& v : out) {
    if constexpr (std::is_same_v<T, double>) {
      PDR_TRY(in_.real(v, what));
    } else {
      std::int64_t w = 0;
      PDR_TRY(in_.integer(w, what));
      if (w < std::numeric_limits<T>::min() || w > std::numeric_limits<T>::max())
        return in_.error(fmt::format("{} value {} is out of range", what, w));
      v = static_cast<T>(w);
    }
  }
  if (!in_.next().empty()) return in_.error(fmt::format("{} has more than the {} values expected", what, n));
  return {};
}

Result<std::optional<Element>> VtuReader::named_array(const Element& section, std::string_view name) {
  std::size_t at = section.content_begin;
  for (;;) {
    PDR_ASSIGN_OR_RETURN(std::optional<Element> e, find("DataArray", at, section.content_end));
    if (!e) return std::optional<Element>{};
    if (attribute(e->tag, "Name") == name) return e;
    at = e->content_end;
  }
}

Result<VolumeMesh> VtuReader::read() {
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> file, find("VTKFile", 0, text_.size()));
  if (!file) return in_.error_at(0, "not a VTK XML file (no <VTKFile>)");
  if (attribute(file->tag, "type") != "UnstructuredGrid")
    return unsupported(fmt::format("{}: VTKFile type=\"{}\"; only UnstructuredGrid is read", in_.name(),
                                   attribute(file->tag, "type").value_or("")));
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> piece, find("Piece", file->content_begin, file->content_end));
  if (!piece) return in_.error_at(file->start, "no <Piece>");
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> second, find("Piece", piece->content_end, file->content_end));
  if (second) return unsupported(fmt::format("{}:{}: more than one <Piece>", in_.name(), in_.line_at(second->start)));
  PDR_ASSIGN_OR_RETURN(const std::size_t np, attribute_count(*piece, "NumberOfPoints"));
  PDR_ASSIGN_OR_RETURN(const std::size_t nc, attribute_count(*piece, "NumberOfCells"));

  VolumeMesh mesh;
  // Points: the first DataArray inside <Points>.
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> points, find("Points", piece->content_begin, piece->content_end));
  if (!points) return in_.error_at(piece->start, "no <Points>");
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> xyz, find("DataArray", points->content_begin, points->content_end));
  if (!xyz) return in_.error_at(points->start, "<Points> has no DataArray");
  if (attribute(xyz->tag, "NumberOfComponents") != "3")
    return in_.error_at(xyz->start, "points must have NumberOfComponents=\"3\"");
  std::vector<double> coords;
  PDR_TRY(parse_array(*xyz, 3 * np, coords, "point coordinate"));
  mesh.points.resize(np);
  for (std::size_t i = 0; i < np; ++i) mesh.points[i] = {coords[3 * i], coords[3 * i + 1], coords[3 * i + 2]};
  coords = {};

  // Cells.
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> cells, find("Cells", piece->content_begin, piece->content_end));
  if (!cells) return in_.error_at(piece->start, "no <Cells>");
  std::vector<std::int64_t> connectivity, offsets;
  std::vector<std::uint8_t> types;
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> types_el, named_array(*cells, "types"));
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> offsets_el, named_array(*cells, "offsets"));
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> conn_el, named_array(*cells, "connectivity"));
  if (!types_el || !offsets_el || !conn_el)
    return in_.error_at(cells->start, "<Cells> needs DataArrays named connectivity, offsets and types");
  PDR_TRY(parse_array(*types_el, nc, types, "cell type"));
  PDR_TRY(parse_array(*offsets_el, nc, offsets, "cell offset"));
  std::int64_t previous = 0;
  for (std::size_t c = 0; c < nc; ++c) {
    const std::int64_t size = types[c] == kVtkTetra ? 4 : types[c] == kVtkTriangle ? 3 : -1;
    if (size < 0)
      return unsupported(fmt::format("{}:{}: cell {} has VTK type {}; only tetrahedra (10) and triangles (5) are read",
                                     in_.name(), in_.line_at(types_el->start), c, types[c]));
    if (offsets[c] != previous + size)
      return in_.error_at(offsets_el->start, fmt::format("cell {} (type {}) has offset {}, expected {}", c, types[c],
                                                         offsets[c], previous + size));
    previous = offsets[c];
  }
  PDR_TRY(parse_array(*conn_el, static_cast<std::size_t>(previous), connectivity, "cell connectivity"));
  for (std::size_t k = 0; k < connectivity.size(); ++k)
    if (connectivity[k] < 0 || connectivity[k] >= static_cast<std::int64_t>(np))
      return in_.error_at(conn_el->start, fmt::format("connectivity entry {} is {}, out of range for {} points", k,
                                                      connectivity[k], np));

  // Cell data (optional).
  std::vector<std::int32_t> surface_id, region;
  bool have_region = false;
  PDR_ASSIGN_OR_RETURN(const std::optional<Element> cell_data,
                       find("CellData", piece->content_begin, piece->content_end));
  if (cell_data) {
    PDR_ASSIGN_OR_RETURN(const std::optional<Element> ids_el, named_array(*cell_data, "surface_id"));
    if (ids_el) PDR_TRY(parse_array(*ids_el, nc, surface_id, "surface_id"));
    PDR_ASSIGN_OR_RETURN(const std::optional<Element> region_el, named_array(*cell_data, "region"));
    if (region_el) {
      PDR_TRY(parse_array(*region_el, nc, region, "region"));
      have_region = true;
    }
  }

  std::size_t k = 0;
  for (std::size_t c = 0; c < nc; ++c) {
    if (types[c] == kVtkTetra) {
      mesh.tets.push_back({static_cast<Index>(connectivity[k]), static_cast<Index>(connectivity[k + 1]),
                           static_cast<Index>(connectivity[k + 2]), static_cast<Index>(connectivity[k + 3])});
      if (have_region) mesh.tet_regions.push_back(region[c]);
      k += 4;
    } else {
      mesh.boundary.push_back({static_cast<Index>(connectivity[k]), static_cast<Index>(connectivity[k + 1]),
                               static_cast<Index>(connectivity[k + 2])});
      mesh.boundary_ids.push_back(surface_id.empty() ? 1 : surface_id[c]);
      k += 3;
    }
  }
  return mesh;
}

}  // namespace

Status write_vtu(const VolumeMesh& mesh, const std::filesystem::path& path) {
  const std::size_t nt = mesh.tets.size(), nb = mesh.boundary.size(), nc = nt + nb;
  const std::vector<double> min_dihedral = min_dihedral_per_tet(mesh);
  OutputFile out(path);
  PDR_TRY(out.open());
  auto it = std::back_inserter(out.buf());
  using It = decltype(it);
  fmt::format_to(it,
                 "<?xml version=\"1.0\"?>\n"
                 "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
                 "header_type=\"UInt64\">\n"
                 "  <UnstructuredGrid>\n"
                 "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n"
                 "      <Points>\n",
                 mesh.points.size(), nc);
  PDR_TRY(write_array(out, "<DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"ascii\">",
                      mesh.points.size(), [&](It& o, std::size_t i) {
                        const Vec3& p = mesh.points[i];
                        fmt::format_to(o, FMT_COMPILE("{} {} {} "), p[0], p[1], p[2]);
                      }));
  fmt::format_to(it, "      </Points>\n      <Cells>\n");
  PDR_TRY(write_array(out, "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">", nc,
                      [&](It& o, std::size_t c) {
                        if (c < nt) {
                          const Tet& t = mesh.tets[c];
                          fmt::format_to(o, FMT_COMPILE("{} {} {} {} "), t[0], t[1], t[2], t[3]);
                        } else {
                          const Tri& t = mesh.boundary[c - nt];
                          fmt::format_to(o, FMT_COMPILE("{} {} {} "), t[0], t[1], t[2]);
                        }
                      }));
  PDR_TRY(write_array(out, "<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">", nc,
                      [&](It& o, std::size_t c) {
                        fmt::format_to(o, FMT_COMPILE("{} "), c < nt ? 4 * (c + 1) : 4 * nt + 3 * (c - nt + 1));
                      }));
  PDR_TRY(write_array(out, "<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">", nc,
                      [&](It& o, std::size_t c) { fmt::format_to(o, FMT_COMPILE("{} "), c < nt ? kVtkTetra : kVtkTriangle); }));
  fmt::format_to(it, "      </Cells>\n      <CellData Scalars=\"min_dihedral\">\n");
  PDR_TRY(write_array(out, "<DataArray type=\"Float64\" Name=\"min_dihedral\" format=\"ascii\">", nc,
                      [&](It& o, std::size_t c) { fmt::format_to(o, FMT_COMPILE("{} "), c < nt ? min_dihedral[c] : 0.0); }));
  PDR_TRY(write_array(out, "<DataArray type=\"Int32\" Name=\"surface_id\" format=\"ascii\">", nc,
                      [&](It& o, std::size_t c) {
                        fmt::format_to(o, FMT_COMPILE("{} "), c < nt ? 0 : mesh.boundary_ids[c - nt]);
                      }));
  if (!mesh.tet_regions.empty()) {
    PDR_TRY(write_array(out, "<DataArray type=\"Int32\" Name=\"region\" format=\"ascii\">", nc,
                        [&](It& o, std::size_t c) { fmt::format_to(o, FMT_COMPILE("{} "), c < nt ? mesh.tet_regions[c] : 0); }));
  }
  fmt::format_to(it, "      </CellData>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
  return out.close();
}

Result<VolumeMesh> read_vtu(std::string_view text, const std::string& name) { return VtuReader(text, name).read(); }

}  // namespace pdrmesh::volio
