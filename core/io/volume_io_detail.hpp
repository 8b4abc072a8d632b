// SPDX-License-Identifier: AGPL-3.0-or-later
// Shared machinery of the volume mesh readers and writers (volume_io_*.cpp):
// whole-file input, buffered output, a text scanner that reports file:line,
// a byte reader that reports offsets, and the per-format entry points.
#pragma once

#include <fmt/compile.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <oneapi/tbb/parallel_for.h>

#include "pdrmesh/status.hpp"
#include "pdrmesh/volume_io.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh::volio {

// ---------------------------------------------------------------- files

/// The whole file as bytes; not_found / io_error otherwise.
Result<std::string> read_file(const std::filesystem::path& path);

/// A file written through one large buffer, flushed in big chunks.
class OutputFile {
 public:
  explicit OutputFile(std::filesystem::path path) : path_(std::move(path)) {}
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  Status open();
  fmt::memory_buffer& buf() { return buf_; }
  /// Writes the buffer out once it is large; call between records.
  Status maybe_flush() { return buf_.size() >= kFlushBytes ? flush() : Status{}; }
  Status close();

  /// Appends n records of `record` bytes each, encode(i, out) writing record
  /// i at `out`: the big sections of a binary format. Chunks of records are
  /// encoded and written (pwrite at their own offsets) in parallel, so that
  /// the kernel's copy into the page cache is spread over the threads too;
  /// the bytes are those of the serial loop.
  template <class Encode>
  Status fixed_records(std::size_t n, std::size_t record, Encode&& encode) {
    PDR_TRY(flush());
    PDR_ASSIGN_OR_RETURN(const std::uint64_t start, position());
    const std::size_t chunks = (n + kChunkRecords - 1) / kChunkRecords;
    std::atomic<int> error{0};
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
      const std::size_t lo = c * kChunkRecords, hi = std::min(n, lo + kChunkRecords);
      std::vector<char> bytes((hi - lo) * record);
      for (std::size_t i = lo; i < hi; ++i) encode(i, bytes.data() + (i - lo) * record);
      if (const int e = write_at(bytes.data(), bytes.size(), start + lo * record); e != 0) {
        int none = 0;
        error.compare_exchange_strong(none, e);
      }
    });
    if (const int e = error.load(); e != 0)
      return io_error(fmt::format("{}: write failed: {}", path_.string(), std::strerror(e)));
    return seek(start + static_cast<std::uint64_t>(n) * record);
  }

 private:
  static constexpr std::size_t kFlushBytes = std::size_t{32} << 20;
  static constexpr std::size_t kChunkRecords = std::size_t{1} << 16;  ///< fixed_records' chunk
  Status flush();
  /// The file's write position (after flush()), and moving it.
  Result<std::uint64_t> position();
  Status seek(std::uint64_t at);
  /// pwrite of all `size` bytes at `offset`; 0, or the errno of the failure.
  int write_at(const char* data, std::size_t size, std::uint64_t offset) const;
  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
  fmt::memory_buffer buf_;
};

/// Refuses meshes that no format can store faithfully: size mismatches,
/// indices out of range, non-finite coordinates, more points than int32 holds.
Status check_writable(const VolumeMesh& mesh);

/// Sorted distinct values.
std::vector<int> distinct(std::vector<int> values);

// ---------------------------------------------------------------- text input

/// Splits text into whitespace-separated tokens; errors name file:line, the
/// line computed only when an error is reported.
class TextScanner {
 public:
  TextScanner(std::string_view text, std::string name, char comment = '\0')
      : text_(text), name_(std::move(name)), comment_(comment), end_(text.size()) {}

  /// Restricts scanning to [begin, end) of the text (line numbers stay global).
  void set_range(std::size_t begin, std::size_t end) {
    pos_ = begin;
    end_ = end;
  }
  std::size_t pos() const { return pos_; }
  std::size_t remaining() const { return end_ - pos_; }
  const std::string& name() const { return name_; }

  /// Next token, or empty at the end. `last_token_start()` says where it began.
  std::string_view next();
  /// Next token without consuming it.
  std::string_view peek();
  /// Next token on the current line only (empty at the end of the line).
  std::string_view next_in_line();
  /// Skips the rest of the current line.
  void skip_line();
  /// A "quoted string" (Gmsh physical names); errors if none is there.
  Status quoted(std::string& out, std::string_view what);

  Status integer(std::int64_t& v, std::string_view what);
  Status integer(int& v, std::string_view what);
  Status real(double& v, std::string_view what);
  /// A point index written with `base` (0 or 1), checked against `n` points.
  Status index(Index& v, int base, std::size_t n, std::string_view what);
  /// A count of records of `tokens` tokens each that the rest of the file can hold.
  Status count(std::size_t& v, std::size_t tokens, std::string_view what) {
    return parse_count(next(), v, tokens, what);
  }
  /// Consumes `word` (case-insensitive) or fails.
  Status expect(std::string_view word);

  /// Parses `token` (already taken from this scanner) as a number.
  Status parse_integer(std::string_view token, std::int64_t& v, std::string_view what);
  Status parse_real(std::string_view token, double& v, std::string_view what);
  Status parse_count(std::string_view token, std::size_t& v, std::size_t tokens, std::string_view what);

  /// "name:line: message" at the last token (or at the current position).
  Status error(std::string_view message) const;
  Status error_at(std::size_t pos, std::string_view message) const;
  /// "unexpected end of file, expected <what>" at the last line with content.
  Status end_error(std::string_view what) const;
  std::size_t line_at(std::size_t pos) const;
  std::size_t last_token_start() const { return tok_start_; }

 private:
  void skip_space();
  std::string_view text_;
  std::string name_;
  char comment_;
  std::size_t pos_ = 0;
  std::size_t end_;
  std::size_t tok_start_ = 0;
};

/// Case-insensitive equality for ASCII keywords.
bool iequals(std::string_view a, std::string_view b);
/// Parses "prefix<int>" (e.g. "surface_12"); false when `s` has another form.
bool parse_suffixed_int(std::string_view s, std::string_view prefix, int& out);
/// Shows a token in an error message (shortened, printable).
std::string show(std::string_view token);

// ---------------------------------------------------------------- binary

inline constexpr bool kHostLittle = std::endian::native == std::endian::little;

template <class T>
T byteswap_value(T v) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  std::memcpy(&v, b, sizeof(T));
  return v;
}

/// Appends a value in the requested byte order.
template <class T>
void put(fmt::memory_buffer& buf, T v, bool little) {
  if (little != kHostLittle) v = byteswap_value(v);
  const char* p = reinterpret_cast<const char*>(&v);
  buf.append(p, p + sizeof(T));
}

/// Appends a cell's point indices plus `base` (0 or 1), separated by spaces.
template <std::size_t K>
void put_cell(fmt::memory_buffer& buf, const std::array<Index, K>& cell, Index base) {
  auto it = std::back_inserter(buf);
  for (std::size_t i = 0; i < K; ++i) fmt::format_to(it, FMT_COMPILE("{}{}"), i ? " " : "", cell[i] + base);
}

/// Reads fixed-size values from a byte string; errors name the byte offset.
class ByteReader {
 public:
  ByteReader(std::string_view data, std::string name) : data_(data), name_(std::move(name)) {}
  void set_swap(bool swap) { swap_ = swap; }
  std::size_t pos() const { return pos_; }
  std::size_t size() const { return data_.size(); }
  Status seek(std::size_t pos, std::string_view what);

  template <class T>
  Status get(T& v, std::string_view what) {
    if (data_.size() - pos_ < sizeof(T))
      return error(fmt::format("file ends inside {} ({} bytes needed, {} left)", what, sizeof(T),
                               data_.size() - pos_));
    std::memcpy(&v, data_.data() + pos_, sizeof(T));
    if (swap_) v = byteswap_value(v);
    pos_ += sizeof(T);
    return {};
  }
  /// A signed integer stored in `bytes` (4 or 8) bytes.
  Status integer(std::int64_t& v, int bytes, std::string_view what);
  /// A real stored in `bytes` (4 or 8) bytes, required finite.
  Status real(double& v, int bytes, std::string_view what);
  /// A point index stored 1-based in `bytes` bytes, checked against n.
  Status index(Index& v, int bytes, std::size_t n, std::string_view what);
  /// Checks that `count` records of `record_bytes` fit in the next `available` bytes.
  Status fits(std::uint64_t count, std::uint64_t record_bytes, std::uint64_t available,
              std::string_view what);

  Status error(std::string_view message) const { return error_at(pos_, message); }
  Status error_at(std::size_t pos, std::string_view message) const;

 private:
  std::string_view data_;
  std::string name_;
  std::size_t pos_ = 0;
  bool swap_ = false;
};

// ---------------------------------------------------------------- formats

/// Tets, then Prisms and Pyramids (ref 0) when the mesh has them.
Status write_medit(const VolumeMesh& mesh, const std::filesystem::path& path);
Result<VolumeMesh> read_medit(std::string_view text, const std::string& name);
Status write_meshb(const VolumeMesh& mesh, const std::filesystem::path& path);
Result<VolumeMesh> read_meshb(std::string_view data, const std::string& name);

inline constexpr int kVtkTriangle = 5;  ///< VTK cell types
inline constexpr int kVtkTetra = 10;
inline constexpr int kVtkWedge = 13;
inline constexpr int kVtkPyramid = 14;
/// The corners of a VTK cell type that volume meshes hold; -1 for the others.
constexpr int corners(int vtk_type) {
  switch (vtk_type) {
    case kVtkTriangle: return 3;
    case kVtkTetra: return 4;
    case kVtkWedge: return 6;
    case kVtkPyramid: return 5;
    default: return -1;
  }
}
Status write_vtu(const VolumeMesh& mesh, const std::filesystem::path& path, VtuEncoding encoding);
/// The VTU <FieldData> of the boundary and region names (none without names):
/// `boundary_ids` and `boundary_names` side by side, `region_ids` and `region_names`.
void write_vtu_field_data(const VolumeMesh& mesh, fmt::memory_buffer& buf);
Result<VolumeMesh> read_vtu(std::string_view text, const std::string& name);

Status write_ugrid_ascii(const VolumeMesh& mesh, const std::filesystem::path& path);
Result<VolumeMesh> read_ugrid_ascii(std::string_view text, const std::string& name);
Status write_ugrid_binary(const VolumeMesh& mesh, const std::filesystem::path& path, bool little);
Result<VolumeMesh> read_ugrid_binary(std::string_view data, const std::string& name, bool little);
/// Puts the names of the .mapbc beside `ugrid` (mapbc_path) into `mesh`, when there is one.
Status read_mapbc_beside(VolumeMesh& mesh, const std::filesystem::path& ugrid);

Status write_gmsh(const VolumeMesh& mesh, const std::filesystem::path& path);
Result<VolumeMesh> read_gmsh(std::string_view text, const std::string& name);

/// Tets, then prisms and pyramids when the mesh has them (in VTK's types and vertex order).
Status write_su2(const VolumeMesh& mesh, const std::filesystem::path& path);
/// A mesh with prisms or pyramids in `format` (volume_io_mixed.cpp; .mesh and .su2 through
/// write_medit and write_su2); unsupported for formats that hold tets only.
Status write_mixed(const VolumeMesh& mesh, VolumeFormat format, const std::filesystem::path& path);
Result<VolumeMesh> read_su2(std::string_view text, const std::string& name);

Status write_cgns(const VolumeMesh& mesh, const std::filesystem::path& path);
/// Writes the polyMesh files into directory `dir` (made if missing).
Status write_foam(const VolumeMesh& mesh, const std::filesystem::path& dir);

}  // namespace pdrmesh::volio
