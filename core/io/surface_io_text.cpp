// SPDX-License-Identifier: AGPL-3.0-or-later
// Shared reader machinery: text cursor, number parsing, surface builder, point welder.
#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <limits>

#include "pdrmesh/boundary_names.hpp"
#include "surface_io_internal.hpp"

namespace pdrmesh::surface_io_detail {

std::string quote_token(std::string_view tok) {
  constexpr std::size_t kMax = 40;
  std::string out = "'";
  for (std::size_t i = 0; i < std::min(tok.size(), kMax); ++i) {
    const auto ch = static_cast<unsigned char>(tok[i]);
    if (ch >= 0x20 && ch < 0x7f) {
      out += static_cast<char>(ch);
    } else {
      out += fmt::format("\\x{:02x}", ch);
    }
  }
  if (tok.size() > kMax) out += "...";
  out += "'";
  return out;
}

bool parse_double(std::string_view tok, double& out) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  if (tok.empty()) return false;
  const char* end = tok.data() + tok.size();
  const auto r = std::from_chars(tok.data(), end, out);
  if (r.ptr != end) return false;
  if (r.ec == std::errc::result_out_of_range) {
    // A well-formed number beyond double's range: like strtod, underflow gives
    // zero and overflow infinity (which the readers then report as non-finite).
    const bool negative = tok.front() == '-';
    const std::size_t e = tok.find_first_of("eE");
    const bool underflow = e != std::string_view::npos
                               ? e + 1 < tok.size() && tok[e + 1] == '-'
                               : tok.find_first_not_of("-0.") == std::string_view::npos ||
                                     tok.find_first_not_of("-0") == tok.find('.');
    const double magnitude = underflow ? 0.0 : std::numeric_limits<double>::infinity();
    out = negative ? -magnitude : magnitude;
    return true;
  }
  return r.ec == std::errc();
}

bool parse_int(std::string_view tok, std::int64_t& out) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  if (tok.empty()) return false;
  const char* end = tok.data() + tok.size();
  const auto r = std::from_chars(tok.data(), end, out);
  return r.ec == std::errc() && r.ptr == end;
}

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto lower = [](char ch) {
      return ch >= 'A' && ch <= 'Z' ? static_cast<char>(ch + 32) : ch;
    };
    if (lower(a[i]) != lower(b[i])) return false;
  }
  return true;
}

void TextCursor::skip_space() {
  while (pos_ < text_.size()) {
    const char ch = text_[pos_];
    if (ch == '\n') {
      ++line_;
      ++pos_;
    } else if (is_blank(ch)) {
      ++pos_;
    } else if (comment_ != '\0' && ch == comment_) {
      while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    } else {
      return;
    }
  }
}

void TextCursor::skip_blanks() {
  while (pos_ < text_.size() && is_blank(text_[pos_])) ++pos_;
  if (pos_ < text_.size() && comment_ != '\0' && text_[pos_] == comment_) {
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
  }
}

std::string_view TextCursor::take_token() {
  const std::size_t start = pos_;
  while (pos_ < text_.size()) {
    const char ch = text_[pos_];
    if (ch == '\n' || is_blank(ch) || (comment_ != '\0' && ch == comment_)) break;
    ++pos_;
  }
  return text_.substr(start, pos_ - start);
}

std::string_view TextCursor::rest_of_line() const {
  std::size_t end = text_.find('\n', pos_);
  if (end == std::string_view::npos) end = text_.size();
  std::string_view s = text_.substr(pos_, end - pos_);
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

void TextCursor::next_line() {
  const std::size_t end = text_.find('\n', pos_);
  if (end == std::string_view::npos) {
    pos_ = text_.size();
  } else {
    pos_ = end + 1;
    ++line_;
  }
}

Status TextCursor::error(std::string_view msg) const {
  return invalid_input(fmt::format("{}:{}: {}", name_, line_, msg));
}

Status TextCursor::bad_token(std::string_view tok, std::string_view what) const {
  if (!tok.empty()) return error(fmt::format("expected {}, got {}", what, quote_token(tok)));
  if (pos_ >= text_.size()) return error(fmt::format("file ends where {} was expected", what));
  return error(fmt::format("line ends where {} was expected", what));
}

Status TextCursor::read_double(double& out, std::string_view what, bool same_line) {
  const std::string_view tok = same_line ? line_token() : token();
  if (!parse_double(tok, out)) return bad_token(tok, what);
  return {};
}

Status TextCursor::read_int(std::int64_t& out, std::string_view what, bool same_line) {
  const std::string_view tok = same_line ? line_token() : token();
  if (!parse_int(tok, out)) return bad_token(tok, what);
  return {};
}

Status TextCursor::read_count(std::uint64_t& out, std::string_view what,
                              std::uint64_t min_bytes_each, bool same_line) {
  std::int64_t n = 0;
  const std::string_view tok = same_line ? line_token() : token();
  if (!parse_int(tok, n) || n < 0) return bad_token(tok, what);
  out = static_cast<std::uint64_t>(n);
  return check_count_fits(out, min_bytes_each, remaining() + 1, fmt::format("{}:{}", name_, line_),
                          what);
}

Status TextCursor::expect(std::string_view word) {
  const std::string_view tok = token();
  if (!iequals(tok, word)) return bad_token(tok, fmt::format("'{}'", word));
  return {};
}

Status check_count_fits(std::uint64_t count, std::uint64_t min_bytes_each, std::uint64_t available,
                        std::string_view where, std::string_view what) {
  // Written to avoid overflow in count * min_bytes_each.
  if (min_bytes_each > 0 && count > available / min_bytes_each) {
    return invalid_input(fmt::format(
        "{}: {} = {} cannot fit in the {} bytes left in the file (needs at least {} bytes each)",
        where, what, count, available, min_bytes_each));
  }
  if (count >= kNoIndex) {
    return invalid_input(fmt::format("{}: {} = {} exceeds the supported maximum of {}", where, what,
                                     count, kNoIndex - 1));
  }
  return {};
}

Status nonfinite_point(const Vec3& p, std::uint64_t point_number, const std::string& where) {
  return invalid_input(fmt::format("{}: point {} has a non-finite coordinate ({}, {}, {})", where,
                                   point_number, p[0], p[1], p[2]));
}

Status bad_face(std::string_view face_word, std::uint64_t face_number,
                std::span<const std::int64_t> indices, std::int64_t base, std::uint64_t limit,
                const std::string& where) {
  if (indices.size() < 3) {
    return invalid_input(fmt::format("{}: {} {} has {} point indices, at least 3 are needed", where,
                                     face_word, face_number, indices.size()));
  }
  for (std::int64_t i : indices) {
    if (i < base || static_cast<std::uint64_t>(i - base) >= limit) {
      const std::string range =
          limit == 0
              ? std::string("no points are defined")
              : fmt::format("valid: {}..{}", base, static_cast<std::uint64_t>(base) + limit - 1);
      return invalid_input(fmt::format(
          "{}: {} {} (points {}): point index {} out of range ({})", where, face_word, face_number,
          fmt::format("{}{}",
                      fmt::join(indices.first(std::min<std::size_t>(indices.size(), 8)), ", "),
                      indices.size() > 8 ? ", ..." : ""),
          i, range));
    }
  }
  return internal_error(
      fmt::format("{}: {} {} reported bad but is not", where, face_word, face_number));
}

Status read_point_lines(TextCursor& c, SurfaceBuilder& out, std::uint64_t n,
                        std::string_view word) {
  for (std::uint64_t i = 0; i < n; ++i) {
    Vec3 p{};
    const std::string_view tok = c.token();
    if (!parse_double(tok, p[0]))
      return c.bad_token(tok, fmt::format("{} {} of {}", word, i + 1, n));
    PDR_TRY(c.read_double(p[1], "a coordinate", true));
    PDR_TRY(c.read_double(p[2], "a coordinate", true));
    PDR_TRY(out.add_point(p, where_at(c)));
    c.next_line();
  }
  return {};
}

Status read_record_start(TextCursor& c, std::int64_t& out, std::string_view word, std::uint64_t i,
                         std::uint64_t n) {
  const std::string_view tok = c.token();
  if (!parse_int(tok, out)) return c.bad_token(tok, fmt::format("{} {} of {}", word, i + 1, n));
  return {};
}

void SurfaceBuilder::reserve(std::uint64_t points, std::uint64_t triangles) {
  mesh_.points.reserve(points);
  mesh_.triangles.reserve(triangles);
  mesh_.surface_ids.reserve(triangles);
}

Result<SurfaceMesh> SurfaceBuilder::finish() && {
  if (mesh_.triangles.empty()) return invalid_input(fmt::format("{}: no triangles", mesh_.name));
  if (mesh_.points.size() >= kNoIndex) {
    return invalid_input(
        fmt::format("{}: {} points exceed the supported maximum", mesh_.name, mesh_.points.size()));
  }
  return std::move(mesh_);
}

namespace {

/// The coordinate bits with -0.0 turned into +0.0 (adding +0.0 does exactly that).
std::array<std::uint64_t, 3> weld_key(const Vec3& p) {
  return {std::bit_cast<std::uint64_t>(p[0] + 0.0), std::bit_cast<std::uint64_t>(p[1] + 0.0),
          std::bit_cast<std::uint64_t>(p[2] + 0.0)};
}

std::size_t weld_hash(const std::array<std::uint64_t, 3>& k) {
  // splitmix64-style mixing of the three bit patterns.
  const auto mix = [](std::uint64_t z) {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  };
  return static_cast<std::size_t>(mix(k[0] ^ mix(k[1] ^ mix(k[2]))));
}

}  // namespace

void PointWelder::reserve(std::size_t n) {
  if (2 * n > slots_.size()) rehash(std::bit_ceil(2 * n), {});
}

void PointWelder::rehash(std::size_t slots, const std::vector<Vec3>& points) {
  std::vector<Index> old = std::move(slots_);
  slots_.assign(slots, kNoIndex);
  const std::size_t mask = slots - 1;
  for (Index i : old) {
    if (i == kNoIndex) continue;
    std::size_t h = weld_hash(weld_key(points[i])) & mask;
    while (slots_[h] != kNoIndex) h = (h + 1) & mask;
    slots_[h] = i;
  }
}

Index PointWelder::add(const Vec3& p, std::vector<Vec3>& points) {
  if (2 * (points.size() + 1) > slots_.size()) {
    rehash(std::max<std::size_t>(1024, 2 * slots_.size()), points);
  }
  const auto key = weld_key(p);
  const std::size_t mask = slots_.size() - 1;
  for (std::size_t h = weld_hash(key) & mask;; h = (h + 1) & mask) {
    const Index i = slots_[h];
    if (i == kNoIndex) {
      slots_[h] = static_cast<Index>(points.size());
      points.push_back(p);
      return slots_[h];
    }
    if (weld_key(points[i]) == key) return i;
  }
}

int GroupIds::id_of(std::string_view raw) {
  const auto it = ids_.find(raw);
  if (it != ids_.end()) return it->second;
  const int id = next_++;
  ids_.emplace(std::string(raw), id);
  return id;
}

Result<std::map<int, std::string>> GroupIds::names(std::string_view file, std::string_view group) const {
  std::map<int, std::string> names;
  std::map<std::string, std::string_view, std::less<>> raw_of;  // boundary name -> the raw name that gave it
  for (const auto& [raw, id] : ids_) {
    std::string name = sanitize_boundary_name(raw);
    if (name.empty() || is_default_boundary_name(id, name)) continue;
    // "surface_<n>" of another id (a file written from ids that were not 1..k) is no name either.
    if (!check_boundary_name(id, name).ok()) continue;
    const auto [it, fresh] = raw_of.try_emplace(name, raw);
    if (!fresh)
      return invalid_input(fmt::format("{}: the {}s {} and {} both give the boundary name '{}' (names keep letters, "
                                       "digits, '_', '-', '.', at most {} characters); rename one",
                                       file, group, quote_token(it->second), quote_token(raw), name,
                                       kMaxBoundaryNameLength));
    names.emplace(id, std::move(name));
  }
  return names;
}

}  // namespace pdrmesh::surface_io_detail
