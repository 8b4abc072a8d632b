// SPDX-License-Identifier: AGPL-3.0-or-later
// CGNS output (.cgns) through libcgns (HDF5 files): one base "Base" (3-D),
// one unstructured zone "Zone" holding the points (CoordinateX/Y/Z, doubles),
// a TETRA_4 section "Tetrahedra" numbering the tets 1..T in mesh order, and
// per boundary id (ascending) a TRI_3 section with that id's triangles (mesh
// order) numbered after the tets. Each section has a boundary condition (BC_t)
// of the same name over its element range (PointRange, GridLocation
// FaceCenter), of type BCTypeUserDefined, and a family of that name (FamilyName),
// which is where SU2 and most CGNS readers take the marker name from.
// Names are boundary_name(), cut to CGNS's 32 characters and made unique.
// A mesh with regions has one TETRA_4 section per region instead (ascending
// id, named by region_name(), its tets in mesh order; the tets are numbered
// in that order). A mixed mesh (prism layers) has a PENTA_6 section "Prisms"
// and a PYRA_5 section "Pyramids" after the tets, numbered after them (with
// regions one of each per region, "<region>_Prisms", "<region>_Pyramids", as
// for the tets); CGNS's vertex orders are ours (mixed_cells.hpp: a prism's
// bottom, then the top above it; a pyramid's base, then its apex; each base
// facing the rest). The file is byte-identical for one mesh: what HDF5 and
// libcgns write that changes from write to write (object times, unset bytes
// in fixed-size strings) is cleared afterwards (clear_hdf5_noise).
#include <cgnslib.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <fstream>
#include <mutex>
#include <string_view>
#include <utility>
#include <set>
#include <string>

#include "volume_io_detail.hpp"

namespace pdrmesh::volio {
namespace {

// libcgns keeps its open files and error text in globals: one writer at a time.
std::mutex cgns_mutex;

constexpr std::size_t kCgnsNameMax = 32;

/// A CGNS node name: at most 32 characters, no '/' (the path separator), and
/// not "." or ".." ; unique among `used` (a suffix "_<id>" otherwise).
std::string cgns_name(std::string name, int id, std::set<std::string>& used) {
  std::replace(name.begin(), name.end(), '/', '_');
  if (name.empty() || name == "." || name == "..") name = fmt::format("surface_{}", id);
  if (name.size() > kCgnsNameMax) name.resize(kCgnsNameMax);
  if (used.count(name) != 0 || name == "Tetrahedra") {
    const std::string suffix = fmt::format("_{}", id);
    name = name.substr(0, kCgnsNameMax - suffix.size()) + suffix;
  }
  used.insert(name);
  return name;
}

/// Bob Jenkins' lookup3 hashlittle() with initial value 0: the checksum of
/// HDF5's version-2 metadata (HDF5 file format specification, "Checksum").
std::uint32_t lookup3(const unsigned char* k, std::size_t length) {
  const auto rot = [](std::uint32_t x, int r) { return (x << r) | (x >> (32 - r)); };
  const auto word = [&](std::size_t i) {
    return static_cast<std::uint32_t>(k[i]) | static_cast<std::uint32_t>(k[i + 1]) << 8 |
           static_cast<std::uint32_t>(k[i + 2]) << 16 | static_cast<std::uint32_t>(k[i + 3]) << 24;
  };
  std::uint32_t a = 0xdeadbeef + static_cast<std::uint32_t>(length), b = a, c = a;
  std::size_t i = 0;
  for (; length > 12; length -= 12, i += 12) {
    a += word(i), b += word(i + 4), c += word(i + 8);
    a -= c, a ^= rot(c, 4), c += b;
    b -= a, b ^= rot(a, 6), a += c;
    c -= b, c ^= rot(b, 8), b += a;
    a -= c, a ^= rot(c, 16), c += b;
    b -= a, b ^= rot(a, 19), a += c;
    c -= b, c ^= rot(b, 4), b += a;
  }
  if (length == 0) return c;
  std::array<unsigned char, 12> tail{};  // the last 1 to 12 bytes, zero-padded
  std::copy(k + i, k + i + length, tail.begin());
  k = tail.data();
  a += word(0), b += word(4), c += word(8);
  c ^= b, c -= rot(b, 14);
  a ^= c, a -= rot(c, 11);
  b ^= a, b -= rot(a, 25);
  c ^= b, c -= rot(b, 16);
  a ^= c, a -= rot(c, 4);
  b ^= a, b -= rot(a, 14);
  c ^= b, c -= rot(b, 24);
  return c;
}

std::uint64_t little_endian(const unsigned char* p, std::size_t bytes) {
  std::uint64_t v = 0;
  for (std::size_t b = 0; b < bytes; ++b) v |= static_cast<std::uint64_t>(p[b]) << (8 * b);
  return v;
}

/// In the messages of an object header chunk, h[p, end): zeroes what follows
/// the terminating NUL in each null-terminated string attribute (version-3
/// attribute message, string datatype), and lists the continuation chunks
/// (offset, length) in `more`.
void clean_messages(std::vector<unsigned char>& h, std::size_t p, std::size_t end, unsigned header_flags,
                    std::vector<std::pair<std::uint64_t, std::uint64_t>>& more) {
  const std::size_t order = (header_flags & 0x04) != 0 ? 2 : 0;  // each message's creation order
  while (p + 4 + order <= end) {
    const unsigned type = h[p];
    const std::size_t size = little_endian(&h[p + 1], 2), q = p + 4 + order;
    if (q + size > end) return;
    if (type == 0x10 && size >= 16) more.emplace_back(little_endian(&h[q], 8), little_endian(&h[q + 8], 8));
    if (type == 0x0c && size >= 9 && h[q] == 3) {
      const std::size_t name = little_endian(&h[q + 2], 2), datatype = little_endian(&h[q + 4], 2),
                        dataspace = little_endian(&h[q + 6], 2), dt = q + 9 + name;
      if (dt + 8 <= q + size && (h[dt] & 0x0f) == 3 && (h[dt + 1] & 0x0f) == 0) {
        const std::size_t data = dt + datatype + dataspace, length = little_endian(&h[dt + 4], 4);
        if (data + length <= q + size) {
          const auto first = h.begin() + static_cast<std::ptrdiff_t>(data);
          const auto last = first + static_cast<std::ptrdiff_t>(length);
          std::fill(std::find(first, last, 0), last, 0);
        }
      }
    }
    p = q + size;
  }
}

/// Makes the HDF5 file `path` the same bytes whenever one mesh is written.
/// libcgns leaves two things that change from write to write: HDF5 stamps
/// each object header with four times (access, modification, change, birth)
/// unless its creation property list says not to, which libcgns does not;
/// and libcgns writes the node attributes (name, label, type) as 33-byte
/// strings from buffers of which only the text and its NUL are set, the rest
/// being whatever memory held. Both are cleared here: the times set to zero
/// (HDF5 reads them back as 1970-01-01) and the bytes after each such
/// string's NUL zeroed.
///
/// A version-2 object header ("OHDR") holds the times when its flags have
/// bit 5, and its first chunk and every continuation chunk ("OCHK") end with
/// the lookup3 checksum of the chunk. The file is scanned for the signature;
/// a header is changed only when its checksum verifies (raw data that happens
/// to hold "OHDR" does not), and every changed chunk's checksum is recomputed.
Status clear_hdf5_noise(const std::filesystem::path& path) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  if (!f) return io_error(fmt::format("{}: cannot reopen the CGNS file", path.string()));
  std::error_code ec;
  const std::uint64_t file_size = std::filesystem::file_size(path, ec);
  if (ec) return io_error(fmt::format("{}: {}", path.string(), ec.message()));
  const auto read_back = [&](std::uint64_t at, void* to, std::uint64_t bytes) {
    f.seekg(static_cast<std::streamoff>(at));
    return static_cast<bool>(f.read(static_cast<char*>(to), static_cast<std::streamsize>(bytes)));
  };
  const Status read_failed = io_error(fmt::format("{}: reading the CGNS file back failed", path.string()));
  constexpr std::string_view kSignature = "OHDR";
  constexpr std::size_t kBlock = 1 << 20;
  std::vector<std::uint64_t> headers;
  std::string buf;
  for (std::uint64_t at = 0; at < file_size; at += kBlock) {
    // Each block with the signature's length less one byte of the next, so none is cut in two.
    buf.resize(static_cast<std::size_t>(std::min<std::uint64_t>(kBlock + kSignature.size() - 1, file_size - at)));
    if (!read_back(at, buf.data(), buf.size())) return read_failed;
    for (std::size_t k = buf.find(kSignature); k != std::string::npos && k < kBlock; k = buf.find(kSignature, k + 1))
      headers.push_back(at + k);
  }
  std::vector<unsigned char> h;
  // Reads the chunk [at, at + checked + 4) into h; true when its checksum verifies.
  const auto load = [&](std::uint64_t at, std::uint64_t checked) {
    if (checked > (1u << 24) || at + checked + 4 > file_size) return false;
    h.resize(static_cast<std::size_t>(checked + 4));
    return read_back(at, h.data(), h.size()) && lookup3(h.data(), checked) == little_endian(&h[checked], 4);
  };
  // Recomputes the checksum of h[0, checked) and writes h back at `at`.
  const auto store = [&](std::uint64_t at, std::size_t checked) {
    const std::uint32_t sum = lookup3(h.data(), checked);
    for (std::size_t b = 0; b < 4; ++b) h[checked + b] = static_cast<unsigned char>(sum >> (8 * b));
    f.seekp(static_cast<std::streamoff>(at));
    return static_cast<bool>(f.write(reinterpret_cast<const char*>(h.data()), static_cast<std::streamsize>(h.size())));
  };
  const Status write_failed = io_error(fmt::format("{}: writing the CGNS file failed", path.string()));
  for (const std::uint64_t at : headers) {
    unsigned char start[6 + 16 + 4 + 8];  // signature, version, flags, times, phase change, chunk size
    const std::uint64_t prefix = std::min<std::uint64_t>(sizeof start, file_size - at);
    if (!read_back(at, start, prefix)) return read_failed;
    const unsigned flags = start[5];
    if (prefix < sizeof start || start[4] != 2) continue;
    const std::size_t size_at = 6 + ((flags & 0x20) != 0 ? 16 : 0) + ((flags & 0x10) != 0 ? 4 : 0);
    const std::size_t size_bytes = std::size_t{1} << (flags & 3);
    const std::uint64_t chunk = little_endian(&start[size_at], size_bytes);
    const std::uint64_t checked = size_at + size_bytes + chunk;  // the bytes the checksum covers
    if (!load(at, checked)) continue;
    if ((flags & 0x20) != 0) std::fill(h.begin() + 6, h.begin() + 22, 0);
    std::vector<std::pair<std::uint64_t, std::uint64_t>> more;
    clean_messages(h, size_at + size_bytes, static_cast<std::size_t>(checked), flags, more);
    if (!store(at, static_cast<std::size_t>(checked))) return write_failed;
    for (std::size_t k = 0; k < more.size(); ++k) {  // continuation chunks: "OCHK", messages, checksum
      const auto [chunk_at, length] = more[k];
      if (length < 8 || !load(chunk_at, length - 4) || std::string_view(reinterpret_cast<const char*>(h.data()), 4) != "OCHK")
        continue;
      clean_messages(h, 4, static_cast<std::size_t>(length - 4), flags, more);
      if (!store(chunk_at, static_cast<std::size_t>(length - 4))) return write_failed;
    }
  }
  f.close();
  if (!f) return write_failed;
  return {};
}

/// Closes the file on every path out of write_cgns.
class CgnsFile {
 public:
  ~CgnsFile() {
    if (fn_ >= 0) cg_close(fn_);
  }
  int* handle() { return &fn_; }
  int fn() const { return fn_; }
  /// Closes now, reporting a failure to finish the file.
  int close() {
    const int rc = cg_close(fn_);
    fn_ = -1;
    return rc;
  }

 private:
  int fn_ = -1;
};

}  // namespace

Status write_cgns(const VolumeMesh& mesh, const std::filesystem::path& path) {
  const std::size_t cells = mesh.tets.size() + mesh.prisms.size() + mesh.pyramids.size();
  if (cells + mesh.boundary.size() >= static_cast<std::size_t>(std::numeric_limits<cgsize_t>::max()))
    return invalid_input(fmt::format("mesh has {} cells and {} boundary triangles; this libcgns numbers elements in "
                                     "32 bits",
                                     cells, mesh.boundary.size()));
  const std::lock_guard lock(cgns_mutex);
  const auto failed = [&](std::string_view what) {
    return io_error(fmt::format("{}: CGNS {} failed: {}", path.string(), what, cg_get_error()));
  };
  CgnsFile file;
  if (cg_set_file_type(CG_FILE_HDF5) != CG_OK) return failed("file type");
  if (cg_open(path.c_str(), CG_MODE_WRITE, file.handle()) != CG_OK) return failed("open");
  const int fn = file.fn();
  int base = 0, zone = 0, node = 0;
  if (cg_base_write(fn, "Base", 3, 3, &base) != CG_OK) return failed("base");
  cgsize_t size[3] = {static_cast<cgsize_t>(mesh.points.size()), static_cast<cgsize_t>(cells), 0};
  if (cg_zone_write(fn, base, "Zone", size, CGNS_ENUMV(Unstructured), &zone) != CG_OK) return failed("zone");

  std::vector<double> coord(mesh.points.size());
  for (int k = 0; k < 3; ++k) {
    for (std::size_t i = 0; i < mesh.points.size(); ++i) coord[i] = mesh.points[i][static_cast<std::size_t>(k)];
    const char* name = k == 0 ? "CoordinateX" : k == 1 ? "CoordinateY" : "CoordinateZ";
    if (cg_coord_write(fn, base, zone, CGNS_ENUMV(RealDouble), name, coord.data(), &node) != CG_OK)
      return failed("coordinates");
  }
  coord = {};

  std::set<std::string> used;
  std::vector<cgsize_t> conn;
  conn.reserve(4 * mesh.tets.size());
  // The sections of one kind of cell, numbered from `next` on: one named
  // `whole`, or with regions one per region (ascending id, its cells in mesh
  // order) named by `name_of`.
  cgsize_t next = 1;
  const auto sections = [&](CGNS_ENUMT(ElementType_t) type, const auto& list, const std::vector<int>& regions,
                            const char* whole, const auto& name_of) -> Status {
    std::vector<std::size_t> order(list.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    const bool per_region = regions.size() == list.size() && !list.empty();
    if (per_region)
      std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return regions[a] < regions[b]; });
    for (std::size_t k = 0; k < order.size();) {
      const int id = per_region ? regions[order[k]] : 0;
      conn.clear();
      cgsize_t count = 0;
      for (; k < order.size() && (!per_region || regions[order[k]] == id); ++k, ++count)
        for (Index v : list[order[k]]) conn.push_back(static_cast<cgsize_t>(v) + 1);
      const std::string name = per_region ? cgns_name(name_of(id), id, used) : *used.insert(whole).first;
      if (cg_section_write(fn, base, zone, name.c_str(), type, next, next + count - 1, 0, conn.data(), &node) != CG_OK)
        return failed(fmt::format("section {}", name));
      next += count;
    }
    return {};
  };
  const auto region_of = [&](const char* kind) {
    return [&mesh, kind](int id) {
      const std::string region = region_name(mesh.region_names, id);
      return *kind ? fmt::format("{}_{}", region, kind) : region;
    };
  };
  PDR_TRY(sections(CGNS_ENUMV(TETRA_4), mesh.tets, mesh.tet_regions, "Tetrahedra", region_of("")));
  PDR_TRY(sections(CGNS_ENUMV(PENTA_6), mesh.prisms, mesh.prism_regions, "Prisms", region_of("Prisms")));
  PDR_TRY(sections(CGNS_ENUMV(PYRA_5), mesh.pyramids, mesh.pyramid_regions, "Pyramids", region_of("Pyramids")));

  std::vector<std::size_t> order(mesh.boundary.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return mesh.boundary_ids[a] < mesh.boundary_ids[b]; });
  for (std::size_t k = 0; k < order.size();) {
    const int id = mesh.boundary_ids[order[k]];
    conn.clear();
    for (; k < order.size() && mesh.boundary_ids[order[k]] == id; ++k)
      for (Index v : mesh.boundary[order[k]]) conn.push_back(static_cast<cgsize_t>(v) + 1);
    const auto count = static_cast<cgsize_t>(conn.size() / 3);
    const std::string name = cgns_name(boundary_name(mesh.boundary_names, id), id, used);
    const cgsize_t range[2] = {next, next + count - 1};
    int family = 0, bc = 0;
    if (cg_section_write(fn, base, zone, name.c_str(), CGNS_ENUMV(TRI_3), range[0], range[1], 0, conn.data(),
                         &node) != CG_OK)
      return failed(fmt::format("section {}", name));
    if (cg_family_write(fn, base, name.c_str(), &family) != CG_OK) return failed(fmt::format("family {}", name));
    if (cg_boco_write(fn, base, zone, name.c_str(), CGNS_ENUMV(BCTypeUserDefined), CGNS_ENUMV(PointRange), 2, range,
                      &bc) != CG_OK ||
        cg_boco_gridlocation_write(fn, base, zone, bc, CGNS_ENUMV(FaceCenter)) != CG_OK)
      return failed(fmt::format("boundary condition {}", name));
    if (cg_goto(fn, base, "Zone_t", zone, "ZoneBC_t", 1, "BC_t", bc, "end") != CG_OK ||
        cg_famname_write(name.c_str()) != CG_OK)
      return failed(fmt::format("family name of {}", name));
    next += count;
  }
  if (file.close() != CG_OK) return failed("close");
  return clear_hdf5_noise(path);
}

}  // namespace pdrmesh::volio
