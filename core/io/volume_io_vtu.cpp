// SPDX-License-Identifier: AGPL-3.0-or-later
// VTK XML UnstructuredGrid (.vtu) volume meshes, for ParaView and friends.
//
// Cells are the tets (VTK_TETRA, 10) followed by the boundary triangles
// (VTK_TRIANGLE, 5). Cell data: `min_dihedral` (Float64, degrees: a tet's
// smallest dihedral angle; a boundary triangle carries that of the tet behind
// it, NaN when no tet has it as a face), `surface_id` (Int32, 0 for tets) and,
// when the mesh has regions, `region` (Int32, 0 for triangles). min_dihedral is
// output only and not read back. Field data: `boundary_ids` (Int32) and
// `boundary_names` (String), one entry per named boundary id, which ParaView's
// spreadsheet view shows side by side; `region_ids` and `region_names` the same
// for the named regions.
//
// Encodings (VtuEncoding): appended raw binary (the default), the same with
// zlib compression (vtkZLibDataCompressor, 32 KiB blocks), or ascii with
// shortest round-trip numbers. All are exact (binary trivially; ascii checked
// bit-exact through VTK 9.1's vtkXMLUnstructuredGridReader). Headers are
// UInt64, little endian.
//
// The reader is not a general XML parser: it reads the DataArrays of an
// UnstructuredGrid with one Piece in every encoding VTK, ParaView and meshio
// write: ascii, inline base64 (format="binary"), appended raw or base64, zlib
// compressed or not, UInt32 or UInt64 headers, either byte order. Damaged
// binary data is an invalid_input error naming the array.
#include <fmt/compile.h>
#include <oneapi/tbb/parallel_for.h>
#include <zlib.h>

#include <algorithm>
#include <functional>
#include <optional>
#include <vector>

#include "pdrmesh/quality.hpp"
#include "volume_io_detail.hpp"

namespace pdrmesh::volio {
namespace {

constexpr std::size_t kZlibBlock = 32768;  // bytes a compressed block holds (VTK's default)

// ---------------------------------------------------------------- writing

/// One DataArray to write: `count` values of `width` bytes; `fill(first, n,
/// dst)` stores values [first, first + n) little endian at dst (it must only
/// read shared data: chunks are filled in parallel).
struct OutArray {
  std::string attributes;  ///< type, Name, NumberOfComponents
  std::size_t count = 0;
  int width = 8;
  bool is_float = false;
  std::function<void(std::size_t, std::size_t, char*)> fill;
};

template <class T>
void store(char* dst, T v) {
  if (!kHostLittle) v = byteswap_value(v);
  std::memcpy(dst, &v, sizeof(T));
}

/// Formats little-endian binary values as ascii, eight a line.
void format_ascii(const OutArray& a, const char* src, std::size_t first, std::size_t n, fmt::memory_buffer& b) {
  auto o = std::back_inserter(b);
  for (std::size_t i = 0; i < n; ++i) {
    const char* p = src + i * static_cast<std::size_t>(a.width);
    if (a.is_float) {
      double v = 0;
      std::memcpy(&v, p, 8);
      if (!kHostLittle) v = byteswap_value(v);
      fmt::format_to(o, FMT_COMPILE("{} "), v);
    } else if (a.width == 1) {
      fmt::format_to(o, FMT_COMPILE("{} "), static_cast<unsigned>(static_cast<unsigned char>(*p)));
    } else if (a.width == 4) {
      std::int32_t v = 0;
      std::memcpy(&v, p, 4);
      if (!kHostLittle) v = byteswap_value(v);
      fmt::format_to(o, FMT_COMPILE("{} "), v);
    } else {
      std::int64_t v = 0;
      std::memcpy(&v, p, 8);
      if (!kHostLittle) v = byteswap_value(v);
      fmt::format_to(o, FMT_COMPILE("{} "), v);
    }
    if ((first + i + 1) % 8 == 0 || first + i + 1 == a.count) b.push_back('\n');
  }
}

/// An ascii DataArray, formatted a chunk of lines per task in parallel and
/// written in order: the same bytes for any thread count.
Status write_ascii_array(OutputFile& out, const OutArray& a) {
  fmt::format_to(std::back_inserter(out.buf()), "        <DataArray {} format=\"ascii\">\n", a.attributes);
  constexpr std::size_t kChunk = 8 * 2048;  // values a chunk (whole lines)
  constexpr std::size_t kBatch = 64;        // chunks formatted at once (bounded memory)
  const std::size_t n = a.count;
  std::vector<fmt::memory_buffer> chunks(std::min(kBatch, (n + kChunk - 1) / kChunk));
  for (std::size_t first = 0; first < n; first += kChunk * kBatch) {
    const std::size_t count = std::min(kBatch, (n - first + kChunk - 1) / kChunk);
    tbb::parallel_for(std::size_t{0}, count, [&](std::size_t c) {
      const std::size_t lo = first + c * kChunk, hi = std::min(n, lo + kChunk);
      std::vector<char> raw((hi - lo) * static_cast<std::size_t>(a.width));
      a.fill(lo, hi - lo, raw.data());
      chunks[c].clear();
      format_ascii(a, raw.data(), lo, hi - lo, chunks[c]);
    });
    for (std::size_t c = 0; c < count; ++c) {
      out.buf().append(chunks[c].data(), chunks[c].data() + chunks[c].size());
      PDR_TRY(out.maybe_flush());
    }
  }
  fmt::format_to(std::back_inserter(out.buf()), "        </DataArray>\n");
  return {};
}

/// An array's compressed form: the vtkZLibDataCompressor header (UInt64
/// block count, block size, last block size, each block's compressed size)
/// followed by the blocks, compressed in parallel.
Result<std::string> compress_array(const OutArray& a) {
  const std::size_t bytes = a.count * static_cast<std::size_t>(a.width);
  const std::size_t blocks = (bytes + kZlibBlock - 1) / kZlibBlock;
  const std::size_t per_block = kZlibBlock / static_cast<std::size_t>(a.width);
  std::vector<std::string> packed(blocks);
  std::vector<int> rc(blocks, Z_OK);
  tbb::parallel_for(std::size_t{0}, blocks, [&](std::size_t k) {
    const std::size_t first = k * per_block, n = std::min(per_block, a.count - first);
    std::vector<char> raw(n * static_cast<std::size_t>(a.width));
    a.fill(first, n, raw.data());
    uLongf size = compressBound(static_cast<uLong>(raw.size()));
    packed[k].resize(size);
    rc[k] = compress2(reinterpret_cast<Bytef*>(packed[k].data()), &size, reinterpret_cast<const Bytef*>(raw.data()),
                      static_cast<uLong>(raw.size()), Z_DEFAULT_COMPRESSION);
    packed[k].resize(size);
  });
  for (int r : rc)
    if (r != Z_OK) return internal_error(fmt::format("zlib compress2 failed ({})", r));
  fmt::memory_buffer head;
  put<std::uint64_t>(head, blocks, true);
  put<std::uint64_t>(head, kZlibBlock, true);
  put<std::uint64_t>(head, bytes % kZlibBlock, true);
  for (const std::string& p : packed) put<std::uint64_t>(head, p.size(), true);
  std::string out(head.data(), head.size());
  for (const std::string& p : packed) out += p;
  return out;
}

/// A raw appended array: UInt64 byte count, then the values, a chunk at a time.
Status write_raw_array(OutputFile& out, const OutArray& a) {
  const std::size_t w = static_cast<std::size_t>(a.width);
  put<std::uint64_t>(out.buf(), a.count * w, true);
  constexpr std::size_t kChunk = std::size_t{1} << 20;  // values a chunk
  for (std::size_t first = 0; first < a.count; first += kChunk) {
    const std::size_t n = std::min(kChunk, a.count - first), at = out.buf().size();
    out.buf().resize(at + n * w);
    a.fill(first, n, out.buf().data() + at);
    PDR_TRY(out.maybe_flush());
  }
  return {};
}

/// The smallest dihedral angle of each boundary triangle's tet (the tet
/// with that face), NaN where no tet has it.
std::vector<double> boundary_min_dihedral(const VolumeMesh& mesh, const std::vector<double>& tet_min) {
  using Key = std::array<Index, 3>;
  auto key = [](Index a, Index b, Index c) {
    Key k{a, b, c};
    std::sort(k.begin(), k.end());
    return k;
  };
  std::vector<std::pair<Key, std::size_t>> faces(mesh.boundary.size());
  std::vector<bool> on_boundary(mesh.points.size(), false);
  for (std::size_t i = 0; i < mesh.boundary.size(); ++i) {
    const Tri& t = mesh.boundary[i];
    faces[i] = {key(t[0], t[1], t[2]), i};
    for (Index v : t) on_boundary[v] = true;
  }
  std::sort(faces.begin(), faces.end());
  std::vector<double> out(mesh.boundary.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const Tet& k = mesh.tets[t];
    int flagged = 0;
    for (Index v : k) flagged += on_boundary[v] ? 1 : 0;
    if (flagged < 3) continue;
    for (int skip = 0; skip < 4; ++skip) {
      Index f[3];
      int n = 0;
      for (int v = 0; v < 4; ++v)
        if (v != skip) f[n++] = k[static_cast<std::size_t>(v)];
      const Key fk = key(f[0], f[1], f[2]);
      auto it = std::lower_bound(faces.begin(), faces.end(), std::pair<Key, std::size_t>{fk, 0});
      for (; it != faces.end() && it->first == fk; ++it) out[it->second] = tet_min[t];
    }
  }
  return out;
}

/// VTK's ascii form of a String array: each string as its byte values, then 0.
std::string ascii_strings(const std::vector<std::string>& strings) {
  fmt::memory_buffer b;
  for (const std::string& s : strings) {
    for (char c : s) fmt::format_to(std::back_inserter(b), "{} ", static_cast<unsigned>(static_cast<unsigned char>(c)));
    fmt::format_to(std::back_inserter(b), "0\n");
  }
  return fmt::to_string(b);
}

}  // namespace

void write_vtu_field_data(const VolumeMesh& mesh, fmt::memory_buffer& buf) {
  auto it = std::back_inserter(buf);
  // Ids and names side by side, boundaries then regions.
  const auto named = [&](const std::map<int, std::string>& map, std::string_view what) {
    std::vector<std::string> names;
    fmt::format_to(it, "      <DataArray type=\"Int32\" Name=\"{}_ids\" NumberOfTuples=\"{}\" format=\"ascii\">\n        ",
                   what, map.size());
    for (const auto& [id, name] : map) {
      fmt::format_to(it, "{} ", id);
      names.push_back(name);
    }
    fmt::format_to(it, "\n      </DataArray>\n      <DataArray type=\"String\" Name=\"{}_names\" "
                       "NumberOfTuples=\"{}\" format=\"ascii\">\n{}      </DataArray>\n",
                   what, names.size(), ascii_strings(names));
  };
  const bool region_names = !mesh.region_names.empty() && mesh.has_regions();
  if (!mesh.boundary_names.empty() || region_names) {
    fmt::format_to(it, "    <FieldData>\n");
    if (!mesh.boundary_names.empty()) named(mesh.boundary_names, "boundary");
    if (region_names) named(mesh.region_names, "region");
    fmt::format_to(it, "    </FieldData>\n");
  }
}

Status write_vtu(const VolumeMesh& mesh, const std::filesystem::path& path, VtuEncoding encoding) {
  const std::size_t nt = mesh.tets.size(), nb = mesh.boundary.size(), nc = nt + nb;
  const std::vector<double> tet_min = min_dihedral_per_tet(mesh);
  const std::vector<double> tri_min = boundary_min_dihedral(mesh, tet_min);

  std::vector<OutArray> arrays;
  arrays.push_back({"type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\"", 3 * mesh.points.size(), 8, true,
                    [&](std::size_t first, std::size_t n, char* dst) {
                      for (std::size_t i = 0; i < n; ++i) store(dst + 8 * i, mesh.points[(first + i) / 3][(first + i) % 3]);
                    }});
  arrays.push_back({"type=\"Int64\" Name=\"connectivity\"", 4 * nt + 3 * nb, 8, false,
                    [&](std::size_t first, std::size_t n, char* dst) {
                      for (std::size_t i = 0; i < n; ++i) {
                        const std::size_t k = first + i;
                        const Index v = k < 4 * nt ? mesh.tets[k / 4][k % 4] : mesh.boundary[(k - 4 * nt) / 3][(k - 4 * nt) % 3];
                        store<std::int64_t>(dst + 8 * i, v);
                      }
                    }});
  arrays.push_back({"type=\"Int64\" Name=\"offsets\"", nc, 8, false, [&](std::size_t first, std::size_t n, char* dst) {
                      for (std::size_t i = 0; i < n; ++i) {
                        const std::size_t c = first + i;
                        store<std::int64_t>(dst + 8 * i, static_cast<std::int64_t>(c < nt ? 4 * (c + 1) : 4 * nt + 3 * (c - nt + 1)));
                      }
                    }});
  arrays.push_back({"type=\"UInt8\" Name=\"types\"", nc, 1, false, [&](std::size_t first, std::size_t n, char* dst) {
                      for (std::size_t i = 0; i < n; ++i) dst[i] = static_cast<char>(first + i < nt ? kVtkTetra : kVtkTriangle);
                    }});
  const std::size_t cell_arrays_begin = arrays.size();
  arrays.push_back({"type=\"Float64\" Name=\"min_dihedral\"", nc, 8, true, [&](std::size_t first, std::size_t n, char* dst) {
                      for (std::size_t i = 0; i < n; ++i) {
                        const std::size_t c = first + i;
                        store(dst + 8 * i, c < nt ? tet_min[c] : tri_min[c - nt]);
                      }
                    }});
  arrays.push_back({"type=\"Int32\" Name=\"surface_id\"", nc, 4, false, [&](std::size_t first, std::size_t n, char* dst) {
                      for (std::size_t i = 0; i < n; ++i) {
                        const std::size_t c = first + i;
                        store<std::int32_t>(dst + 4 * i, c < nt ? 0 : mesh.boundary_ids[c - nt]);
                      }
                    }});
  if (!mesh.tet_regions.empty())
    arrays.push_back({"type=\"Int32\" Name=\"region\"", nc, 4, false, [&](std::size_t first, std::size_t n, char* dst) {
                        for (std::size_t i = 0; i < n; ++i) {
                          const std::size_t c = first + i;
                          store<std::int32_t>(dst + 4 * i, c < nt ? mesh.tet_regions[c] : 0);
                        }
                      }});

  // Compressed arrays are made first: their sizes fix the offsets in the header.
  std::vector<std::string> packed;
  std::vector<std::uint64_t> offsets;
  std::uint64_t offset = 0;
  for (const OutArray& a : arrays) {
    offsets.push_back(offset);
    if (encoding == VtuEncoding::kCompressed) {
      PDR_ASSIGN_OR_RETURN(std::string p, compress_array(a));
      offset += p.size();
      packed.push_back(std::move(p));
    } else {
      offset += 8 + a.count * static_cast<std::uint64_t>(a.width);
    }
  }

  OutputFile out(path);
  PDR_TRY(out.open());
  auto it = std::back_inserter(out.buf());
  fmt::format_to(it,
                 "<?xml version=\"1.0\"?>\n"
                 "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
                 "header_type=\"UInt64\"{}>\n"
                 "  <UnstructuredGrid>\n",
                 encoding == VtuEncoding::kCompressed ? " compressor=\"vtkZLibDataCompressor\"" : "");
  write_vtu_field_data(mesh, out.buf());
  fmt::format_to(it, "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n", mesh.points.size(), nc);
  for (std::size_t k = 0; k < arrays.size(); ++k) {
    if (k == 0) fmt::format_to(it, "      <Points>\n");
    if (k == 1) fmt::format_to(it, "      </Points>\n      <Cells>\n");
    if (k == cell_arrays_begin) fmt::format_to(it, "      </Cells>\n      <CellData Scalars=\"min_dihedral\">\n");
    if (encoding == VtuEncoding::kAscii) {
      PDR_TRY(write_ascii_array(out, arrays[k]));
    } else {
      fmt::format_to(it, "        <DataArray {} format=\"appended\" offset=\"{}\"/>\n", arrays[k].attributes, offsets[k]);
    }
  }
  fmt::format_to(it, "      </CellData>\n    </Piece>\n  </UnstructuredGrid>\n");
  if (encoding != VtuEncoding::kAscii) {
    fmt::format_to(it, "  <AppendedData encoding=\"raw\">\n   _");
    for (std::size_t k = 0; k < arrays.size(); ++k) {
      if (encoding == VtuEncoding::kCompressed) {
        out.buf().append(packed[k].data(), packed[k].data() + packed[k].size());
        PDR_TRY(out.maybe_flush());
      } else {
        PDR_TRY(write_raw_array(out, arrays[k]));
      }
    }
    fmt::format_to(it, "\n  </AppendedData>\n");
  }
  fmt::format_to(it, "</VTKFile>\n");
  return out.close();
}

}  // namespace pdrmesh::volio
