// SPDX-License-Identifier: AGPL-3.0-or-later
// Shared machinery of the surface readers (surface_io_*.cpp): a text cursor that
// tracks line numbers, number parsing with std::from_chars, a builder that
// checks points and faces as they arrive, and exact point welding for STL.
#pragma once

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"

namespace pdrmesh::surface_io_detail {

/// `tok` quoted for a message: at most 40 characters, unprintable bytes escaped.
std::string quote_token(std::string_view tok);

/// Whole-token parses; false on garbage or overflow. A leading '+' is accepted.
bool parse_double(std::string_view tok, double& out);
bool parse_int(std::string_view tok, std::int64_t& out);

/// A scalar stored at `p` in little- or big-endian byte order.
template <class T>
T load_scalar(const char* p, bool big_endian) {
  std::array<unsigned char, sizeof(T)> b{};
  std::memcpy(b.data(), p, sizeof(T));
  if (big_endian != (std::endian::native == std::endian::big)) std::reverse(b.begin(), b.end());
  return std::bit_cast<T>(b);
}

/// ASCII case-insensitive equality.
bool iequals(std::string_view a, std::string_view b);

/// Walks a text buffer token by token, keeping the line number for messages.
class TextCursor {
 public:
  /// `comment`: a character that starts a comment running to the end of the
  /// line, or '\0' for none.
  TextCursor(std::string_view text, std::string_view name, char comment)
      : text_(text), name_(name), comment_(comment) {}

  std::string_view name() const { return name_; }
  std::size_t line() const { return line_; }
  std::size_t offset() const { return pos_; }
  std::size_t remaining() const { return text_.size() - pos_; }

  /// Next token, crossing line ends and comments; empty at the end of input.
  std::string_view token() {
    skip_space();
    return take_token();
  }
  /// Next token on the current line; empty when only blanks or a comment remain.
  std::string_view line_token() {
    skip_blanks();
    return take_token();
  }
  /// True when nothing but blanks, comments and line ends remains.
  bool at_end() {
    skip_space();
    return pos_ == text_.size();
  }
  /// The rest of the current line without surrounding blanks; does not consume it.
  std::string_view rest_of_line() const;
  /// Moves past the next line end (or to the end of input).
  void next_line();

  /// invalid_input("name:line: msg").
  Status error(std::string_view msg) const;
  /// The error for a missing or malformed token where `what` was expected.
  Status bad_token(std::string_view tok, std::string_view what) const;

  /// Reads a number; `same_line` restricts the search to the current line.
  Status read_double(double& out, std::string_view what, bool same_line = false);
  Status read_int(std::int64_t& out, std::string_view what, bool same_line = false);
  /// Reads a count, checking that `min_bytes_each` bytes per item fit in what
  /// is left of the input (so a corrupt header cannot make us allocate).
  Status read_count(std::uint64_t& out, std::string_view what, std::uint64_t min_bytes_each,
                    bool same_line = false);
  /// Reads the next token and fails unless it equals `word` (ASCII case-insensitive).
  Status expect(std::string_view word);

 private:
  static bool is_blank(char ch) {
    return ch == ' ' || ch == '\t' || ch == '\r' || ch == '\v' || ch == '\f';
  }
  void skip_space();
  void skip_blanks();
  std::string_view take_token();

  std::string_view text_;
  std::string_view name_;
  char comment_;
  std::size_t pos_ = 0;
  std::size_t line_ = 1;
};

/// Error unless `count * min_bytes_each <= available`; `where` prefixes the message.
Status check_count_fits(std::uint64_t count, std::uint64_t min_bytes_each, std::uint64_t available,
                        std::string_view where, std::string_view what);

/// The standard messages of the builder, built only on error paths.
Status nonfinite_point(const Vec3& p, std::uint64_t point_number, const std::string& where);
Status bad_face(std::string_view face_word, std::uint64_t face_number,
                std::span<const std::int64_t> indices, std::int64_t base, std::uint64_t limit,
                const std::string& where);

/// Collects points and faces, checking coordinates and indices as they arrive.
/// `where` arguments are callables returning "file:line" or "file: byte N",
/// called only when something is wrong.
class SurfaceBuilder {
 public:
  /// `face_word` names records in messages ("triangle", "face").
  SurfaceBuilder(std::string_view name, std::string_view face_word) : face_word_(face_word) {
    mesh_.name = std::string(name);
  }

  std::size_t point_count() const { return mesh_.points.size(); }
  std::uint64_t face_count() const { return faces_; }
  /// Starts numbering records afresh from 1 under a new word ("quad").
  void start_section(std::string_view face_word) {
    face_word_ = face_word;
    section_start_ = faces_;
  }
  void reserve(std::uint64_t points, std::uint64_t triangles);

  template <class Where>
  Status add_point(const Vec3& p, const Where& where) {
    if (!is_finite(p))
      return nonfinite_point(p, mesh_.points.size() + 1, where());
    mesh_.points.push_back(p);
    return {};
  }

  /// Adds a polygon given by file indices (`base` = 0 or 1), fan-triangulated.
  /// The indices must lie in [base, base + limit); `limit` defaults to the
  /// number of points added so far.
  template <class Where>
  Status add_face(std::span<const std::int64_t> indices, std::int64_t base, int id,
                  const Where& where, std::uint64_t limit = kPointsSoFar) {
    ++faces_;
    if (limit == kPointsSoFar) limit = mesh_.points.size();
    bool ok = indices.size() >= 3;
    for (std::int64_t i : indices)
      ok = ok && i >= base && static_cast<std::uint64_t>(i - base) < limit;
    if (!ok) return bad_face(face_word_, faces_ - section_start_, indices, base, limit, where());
    const auto at = [&](std::size_t k) { return static_cast<Index>(indices[k] - base); };
    for (std::size_t k = 1; k + 1 < indices.size(); ++k) {
      mesh_.triangles.push_back({at(0), at(k), at(k + 1)});
      mesh_.surface_ids.push_back(id);
    }
    return {};
  }

  /// Adds a triangle of already-checked 0-based indices.
  void add_triangle(const Tri& t, int id) {
    ++faces_;
    mesh_.triangles.push_back(t);
    mesh_.surface_ids.push_back(id);
  }
  std::vector<Vec3>& points() { return mesh_.points; }

  /// The mesh, or an error when it holds no triangle.
  Result<SurfaceMesh> finish() &&;

  static constexpr std::uint64_t kPointsSoFar = UINT64_MAX;

 private:
  SurfaceMesh mesh_;
  std::string_view face_word_;
  std::uint64_t faces_ = 0;
  std::uint64_t section_start_ = 0;
};

/// Surface ids for the named groups of a file (STL solids, OBJ groups): each
/// distinct raw name gets the next id 1, 2, ... when first asked for, and
/// keeps it. names() gives their boundary names (sanitize_boundary_name; a
/// raw name that is empty or "surface_<n>" gives none).
class GroupIds {
 public:
  /// The id of the group named `raw` (the same for the same raw name).
  int id_of(std::string_view raw);
  /// A new id with no name.
  int fresh() { return next_++; }
  /// The boundary names of the groups; invalid_input naming both groups when
  /// two raw names give the same boundary name. `group` names a group in
  /// messages ("solid", "group").
  Result<std::map<int, std::string>> names(std::string_view file, std::string_view group) const;

 private:
  std::map<std::string, int, std::less<>> ids_;
  int next_ = 1;
};

/// A `where` callable for a text cursor: "name:line".
inline auto where_at(const TextCursor& c) {
  return [&c] { return fmt::format("{}:{}", c.name(), c.line()); };
}

/// Reads `n` lines `x y z ...` (the rest of each line is ignored); `word`
/// names a record in messages ("vertex", "node").
Status read_point_lines(TextCursor& c, SurfaceBuilder& out, std::uint64_t n, std::string_view word);

/// Reads the first token of record `i` (0-based) of `n` as an integer, naming
/// the record in the message if it is missing.
Status read_record_start(TextCursor& c, std::int64_t& out, std::string_view word, std::uint64_t i,
                         std::uint64_t n);

/// Exact welding: one index per distinct coordinate triple (+0.0 == -0.0),
/// numbered in order of first appearance. Open addressing over indices into
/// the point array, so no allocation per point.
class PointWelder {
 public:
  /// Index of `p` in `points`, appending it if new. All of `points` must have
  /// been added through this welder.
  Index add(const Vec3& p, std::vector<Vec3>& points);
  /// Prepares for about `n` distinct points.
  void reserve(std::size_t n);

 private:
  void rehash(std::size_t slots, const std::vector<Vec3>& points);
  std::vector<Index> slots_;  ///< kNoIndex where empty
};

Result<SurfaceMesh> parse_stl(std::string_view bytes, std::string_view name);
Result<SurfaceMesh> parse_obj(std::string_view bytes, std::string_view name);
Result<SurfaceMesh> parse_off(std::string_view bytes, std::string_view name);
Result<SurfaceMesh> parse_ply(std::string_view bytes, std::string_view name);
Result<SurfaceMesh> parse_medit(std::string_view bytes, std::string_view name);
Result<SurfaceMesh> parse_aflr3_surf(std::string_view bytes, std::string_view name);

}  // namespace pdrmesh::surface_io_detail
