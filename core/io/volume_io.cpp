// SPDX-License-Identifier: AGPL-3.0-or-later
// Volume mesh output and input: format dispatch by suffix and the shared
// helpers of the per-format readers and writers (volume_io_*.cpp).
#include "pdrmesh/volume_io.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <limits>
#include <utility>

#include <unistd.h>

#include "volume_io_detail.hpp"

namespace pdrmesh {
namespace volio {

// ---------------------------------------------------------------- files

Result<std::string> read_file(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return not_found(fmt::format("{}: no such file", path.string()));
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr)
    return io_error(fmt::format("{}: cannot open: {}", path.string(), std::strerror(errno)));
  std::string data;
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec) data.resize(static_cast<std::size_t>(size));
  const std::size_t got = data.empty() ? 0 : std::fread(data.data(), 1, data.size(), f);
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed || got != data.size())
    return io_error(fmt::format("{}: read failed after {} of {} bytes", path.string(), got, data.size()));
  return data;
}

OutputFile::~OutputFile() {
  if (file_ != nullptr) std::fclose(file_);
}

Status OutputFile::open() {
  file_ = std::fopen(path_.c_str(), "wb");
  if (file_ == nullptr)
    return io_error(fmt::format("{}: cannot create: {}", path_.string(), std::strerror(errno)));
  return {};
}

Status OutputFile::flush() {
  if (buf_.size() != 0 && std::fwrite(buf_.data(), 1, buf_.size(), file_) != buf_.size())
    return io_error(fmt::format("{}: write failed: {}", path_.string(), std::strerror(errno)));
  buf_.clear();
  return {};
}

Result<std::uint64_t> OutputFile::position() {
  const off_t at = ::ftello(file_);
  if (at < 0) return io_error(fmt::format("{}: cannot tell the write position: {}", path_.string(), std::strerror(errno)));
  return static_cast<std::uint64_t>(at);
}

Status OutputFile::seek(std::uint64_t at) {
  if (::fseeko(file_, static_cast<off_t>(at), SEEK_SET) != 0)
    return io_error(fmt::format("{}: cannot seek: {}", path_.string(), std::strerror(errno)));
  return {};
}

int OutputFile::write_at(const char* data, std::size_t size, std::uint64_t offset) const {
  const int fd = ::fileno(file_);
  while (size > 0) {
    const ssize_t n = ::pwrite(fd, data, size, static_cast<off_t>(offset));
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    if (n == 0) return EIO;
    data += n;
    size -= static_cast<std::size_t>(n);
    offset += static_cast<std::uint64_t>(n);
  }
  return 0;
}

Status OutputFile::close() {
  PDR_TRY(flush());
  const int rc = std::fclose(file_);
  file_ = nullptr;
  if (rc != 0) return io_error(fmt::format("{}: close failed: {}", path_.string(), std::strerror(errno)));
  return {};
}

Status check_writable(const VolumeMesh& mesh) {
  const std::size_t n = mesh.points.size();
  if (n >= static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
    return invalid_input(fmt::format("mesh has {} points; the file formats hold at most {}", n,
                                     std::numeric_limits<std::int32_t>::max() - 1));
  if (mesh.boundary_ids.size() != mesh.boundary.size())
    return invalid_input(fmt::format("mesh has {} boundary triangles but {} boundary ids",
                                     mesh.boundary.size(), mesh.boundary_ids.size()));
  if (!mesh.regions_fit())
    return invalid_input(fmt::format("mesh has {} tets, {} prisms and {} pyramids but {}, {} and {} regions",
                                     mesh.tets.size(), mesh.prisms.size(), mesh.pyramids.size(),
                                     mesh.tet_regions.size(), mesh.prism_regions.size(), mesh.pyramid_regions.size()));
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3& p = mesh.points[i];
    if (!is_finite(p))
      return invalid_input(fmt::format("point {} ({}, {}, {}) is not finite", i, p[0], p[1], p[2]));
  }
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const Tet& k = mesh.tets[t];
    for (Index v : k)
      if (v >= n)
        return invalid_input(fmt::format("tet {} (points {}, {}, {}, {}) refers to point {} of {}", t,
                                         k[0], k[1], k[2], k[3], v, n));
  }
  for (std::size_t t = 0; t < mesh.boundary.size(); ++t) {
    const Tri& k = mesh.boundary[t];
    for (Index v : k)
      if (v >= n)
        return invalid_input(fmt::format("boundary triangle {} (points {}, {}, {}) refers to point {} of {}",
                                         t, k[0], k[1], k[2], v, n));
  }
  return {};
}

std::vector<int> distinct(std::vector<int> values) {
  std::sort(values.begin(), values.end());
  values.erase(std::unique(values.begin(), values.end()), values.end());
  return values;
}

// ---------------------------------------------------------------- text input

namespace {
constexpr bool is_space(char c) { return c == ' ' || c == '\n' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }
}  // namespace

void TextScanner::skip_space() {
  while (pos_ < end_) {
    const char c = text_[pos_];
    if (is_space(c)) {
      ++pos_;
    } else if (comment_ != '\0' && c == comment_) {
      while (pos_ < end_ && text_[pos_] != '\n') ++pos_;
    } else {
      break;
    }
  }
}

std::string_view TextScanner::next() {
  skip_space();
  tok_start_ = pos_;
  while (pos_ < end_ && !is_space(text_[pos_])) ++pos_;
  return text_.substr(tok_start_, pos_ - tok_start_);
}

std::string_view TextScanner::peek() {
  const std::size_t save_pos = pos_, save_tok = tok_start_;
  const std::string_view t = next();
  pos_ = save_pos;
  tok_start_ = save_tok;
  return t;
}

std::string_view TextScanner::next_in_line() {
  while (pos_ < end_ && (text_[pos_] == ' ' || text_[pos_] == '\t' || text_[pos_] == '\r')) ++pos_;
  if (pos_ < end_ && comment_ != '\0' && text_[pos_] == comment_)
    while (pos_ < end_ && text_[pos_] != '\n') ++pos_;
  tok_start_ = pos_;
  while (pos_ < end_ && !is_space(text_[pos_])) ++pos_;
  return text_.substr(tok_start_, pos_ - tok_start_);
}

void TextScanner::skip_line() {
  while (pos_ < end_ && text_[pos_] != '\n') ++pos_;
  if (pos_ < end_) ++pos_;
}

Status TextScanner::quoted(std::string& out, std::string_view what) {
  skip_space();
  tok_start_ = pos_;
  if (pos_ >= end_ || text_[pos_] != '"') return error(fmt::format("expected quoted {}", what));
  const std::size_t close = text_.find('"', pos_ + 1);
  if (close == std::string_view::npos || close >= end_) return error(fmt::format("unterminated quoted {}", what));
  out.assign(text_.substr(pos_ + 1, close - pos_ - 1));
  pos_ = close + 1;
  return {};
}

Status TextScanner::parse_integer(std::string_view t, std::int64_t& v, std::string_view what) {
  if (t.empty()) return end_error(what);
  const char* b = t.data();
  if (*b == '+' && t.size() > 1) ++b;
  const auto [p, ec] = std::from_chars(b, t.data() + t.size(), v);
  if (ec != std::errc() || p != t.data() + t.size())
    return error(fmt::format("expected {} (an integer), got {}", what, show(t)));
  return {};
}

Status TextScanner::parse_real(std::string_view t, double& v, std::string_view what) {
  if (t.empty()) return end_error(what);
  const char* b = t.data();
  if (*b == '+' && t.size() > 1) ++b;
  const auto [p, ec] = std::from_chars(b, t.data() + t.size(), v);
  if (ec == std::errc::result_out_of_range)
    return error(fmt::format("{} {} is out of the double range", what, show(t)));
  if (ec != std::errc() || p != t.data() + t.size())
    return error(fmt::format("expected {} (a number), got {}", what, show(t)));
  if (!std::isfinite(v)) return error(fmt::format("{} {} is not a finite number", what, show(t)));
  return {};
}

Status TextScanner::integer(std::int64_t& v, std::string_view what) { return parse_integer(next(), v, what); }

Status TextScanner::integer(int& v, std::string_view what) {
  std::int64_t w = 0;
  PDR_TRY(integer(w, what));
  if (w < std::numeric_limits<int>::min() || w > std::numeric_limits<int>::max())
    return error(fmt::format("{} {} does not fit a 32-bit integer", what, w));
  v = static_cast<int>(w);
  return {};
}

Status TextScanner::real(double& v, std::string_view what) { return parse_real(next(), v, what); }

Status TextScanner::index(Index& v, int base, std::size_t n, std::string_view what) {
  std::int64_t w = 0;
  PDR_TRY(integer(w, what));
  if (w < base || w - base >= static_cast<std::int64_t>(n))
    return error(fmt::format("{} {} is out of range: {} points numbered from {}", what, w, n, base));
  v = static_cast<Index>(w - base);
  return {};
}

Status TextScanner::parse_count(std::string_view token, std::size_t& v, std::size_t tokens, std::string_view what) {
  std::int64_t w = 0;
  PDR_TRY(parse_integer(token, w, what));
  if (w < 0) return error(fmt::format("{} is negative ({})", what, w));
  // Every record of `tokens` tokens needs at least 2 * tokens bytes (digits and separators).
  const std::uint64_t need = static_cast<std::uint64_t>(w) * (2 * std::max<std::size_t>(tokens, 1));
  if (static_cast<std::uint64_t>(w) >= kNoIndex || need > remaining() + 1)
    return error(fmt::format("{} {} is more than the rest of the file ({} bytes) can hold", what, w,
                             remaining()));
  v = static_cast<std::size_t>(w);
  return {};
}

Status TextScanner::expect(std::string_view word) {
  const std::string_view t = next();
  if (!iequals(t, word))
    return t.empty() ? end_error(fmt::format("'{}'", word)) : error(fmt::format("expected '{}', got {}", word, show(t)));
  return {};
}

std::size_t TextScanner::line_at(std::size_t pos) const {
  const std::size_t p = std::min(pos, text_.size());
  return 1 + static_cast<std::size_t>(std::count(text_.begin(), text_.begin() + static_cast<std::ptrdiff_t>(p), '\n'));
}

Status TextScanner::end_error(std::string_view what) const {
  // Report the line of the last thing in the file, not the line after it.
  std::size_t p = std::min(tok_start_, text_.size());
  while (p > 0 && is_space(text_[p - 1])) --p;
  return error_at(p > 0 ? p - 1 : 0, fmt::format("unexpected end of file, expected {}", what));
}

Status TextScanner::error(std::string_view message) const { return error_at(tok_start_, message); }

Status TextScanner::error_at(std::size_t pos, std::string_view message) const {
  return invalid_input(fmt::format("{}:{}: {}", name_, line_at(pos), message));
}

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i])))
      return false;
  return true;
}

bool parse_suffixed_int(std::string_view s, std::string_view prefix, int& out) {
  if (s.size() <= prefix.size() || s.substr(0, prefix.size()) != prefix) return false;
  const std::string_view digits = s.substr(prefix.size());
  const auto [p, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), out);
  return ec == std::errc() && p == digits.data() + digits.size();
}

std::string show(std::string_view token) {
  std::string out = "'";
  for (char c : token.substr(0, 40)) out += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  if (token.size() > 40) out += "...";
  out += "'";
  return out;
}

// ---------------------------------------------------------------- binary

Status ByteReader::seek(std::size_t pos, std::string_view what) {
  if (pos > data_.size())
    return error(fmt::format("{} at byte {} lies beyond the end of the file ({} bytes)", what, pos, data_.size()));
  pos_ = pos;
  return {};
}

Status ByteReader::integer(std::int64_t& v, int bytes, std::string_view what) {
  if (bytes == 8) return get(v, what);
  std::int32_t w = 0;
  PDR_TRY(get(w, what));
  v = w;
  return {};
}

Status ByteReader::real(double& v, int bytes, std::string_view what) {
  const std::size_t at = pos_;
  if (bytes == 8) {
    PDR_TRY(get(v, what));
  } else {
    float f = 0;
    PDR_TRY(get(f, what));
    v = f;
  }
  if (!std::isfinite(v)) return error_at(at, fmt::format("{} is not a finite number ({})", what, v));
  return {};
}

Status ByteReader::index(Index& v, int bytes, std::size_t n, std::string_view what) {
  const std::size_t at = pos_;
  std::int64_t w = 0;
  PDR_TRY(integer(w, bytes, what));
  if (w < 1 || w > static_cast<std::int64_t>(n))
    return error_at(at, fmt::format("{} {} is out of range: {} points numbered from 1", what, w, n));
  v = static_cast<Index>(w - 1);
  return {};
}

Status ByteReader::fits(std::uint64_t count, std::uint64_t record_bytes, std::uint64_t available,
                        std::string_view what) {
  if (count >= kNoIndex || count * record_bytes > available)
    return error(fmt::format("{} {} needs {} bytes but only {} remain", what, count,
                             count >= kNoIndex ? std::string("too many") : std::to_string(count * record_bytes),
                             available));
  return {};
}

Status ByteReader::error_at(std::size_t pos, std::string_view message) const {
  return invalid_input(fmt::format("{}: byte offset {}: {}", name_, pos, message));
}

}  // namespace volio

// ---------------------------------------------------------------- dispatch

namespace {

struct SuffixEntry {
  std::string_view suffix;
  VolumeFormat format;
};
// Longer suffixes first: ".lb8.ugrid" and ".b8.ugrid" before ".ugrid".
constexpr std::array<SuffixEntry, 9> kSuffixes{{
    {".lb8.ugrid", VolumeFormat::kUgridLittle},
    {".b8.ugrid", VolumeFormat::kUgridBig},
    {".ugrid", VolumeFormat::kUgridAscii},
    {".meshb", VolumeFormat::kMeditBinary},
    {".mesh", VolumeFormat::kMedit},
    {".vtu", VolumeFormat::kVtu},
    {".msh", VolumeFormat::kGmsh},
    {".su2", VolumeFormat::kSu2},
    {".cgns", VolumeFormat::kCgns},
}};

constexpr std::string_view kPolyMesh = "polyMesh";

/// `path` without trailing separators ("case/constant/polyMesh/" names the directory polyMesh).
std::filesystem::path without_trailing_slash(const std::filesystem::path& path) {
  return path.has_filename() || !path.has_parent_path() ? path : path.parent_path();
}

bool ends_with(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

}  // namespace

std::string_view volume_format_suffixes() {
  return ".mesh .meshb .vtu .ugrid .lb8.ugrid .b8.ugrid .msh .su2 .cgns polyMesh";
}

Result<VolumeFormat> volume_format_from_path(const std::filesystem::path& path) {
  std::string name = without_trailing_slash(path).filename().string();
  if (name == kPolyMesh) return VolumeFormat::kFoam;
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  // Other UGRID encodings (Fortran records, single precision) must not be
  // mistaken for ASCII ".ugrid".
  for (std::string_view other : {".b4.ugrid", ".lb4.ugrid", ".r4.ugrid", ".lr4.ugrid", ".r8.ugrid", ".lr8.ugrid"})
    if (ends_with(name, other))
      return unsupported(fmt::format("{}: UGRID variant '{}' is not supported; volume mesh suffixes: {}",
                                     path.string(), other, volume_format_suffixes()));
  for (const SuffixEntry& e : kSuffixes)
    if (ends_with(name, e.suffix) && name.size() > e.suffix.size()) return e.format;
  return unsupported(fmt::format("{}: unknown volume mesh suffix; supported: {}", path.string(),
                                 volume_format_suffixes()));
}

namespace {

Status write_format(const VolumeMesh& mesh, VolumeFormat format, const std::filesystem::path& path,
                    const VolumeWriteOptions& options) {
  if (mesh.mixed() && format != VolumeFormat::kFoam && format != VolumeFormat::kCgns &&
      format != VolumeFormat::kMeditBinary)
    return volio::write_mixed(mesh, format, path);
  switch (format) {
    case VolumeFormat::kMedit: return volio::write_medit(mesh, path);
    case VolumeFormat::kMeditBinary: return volio::write_meshb(mesh, path);
    case VolumeFormat::kVtu: return volio::write_vtu(mesh, path, options.vtu);
    case VolumeFormat::kUgridAscii: return volio::write_ugrid_ascii(mesh, path);
    case VolumeFormat::kUgridLittle: return volio::write_ugrid_binary(mesh, path, true);
    case VolumeFormat::kUgridBig: return volio::write_ugrid_binary(mesh, path, false);
    case VolumeFormat::kGmsh: return volio::write_gmsh(mesh, path);
    case VolumeFormat::kSu2: return volio::write_su2(mesh, path);
    case VolumeFormat::kCgns: return volio::write_cgns(mesh, path);
    case VolumeFormat::kFoam: return volio::write_foam(mesh, path);
  }
  return internal_error("unhandled volume format");
}

void remove_quietly(const std::filesystem::path& path) noexcept {
  std::error_code ec;
  std::filesystem::remove_all(path, ec);
}

}  // namespace

StagedVolume& StagedVolume::operator=(StagedVolume&& other) noexcept {
  if (this != &other) {
    discard();
    files_ = std::exchange(other.files_, {});
  }
  return *this;
}

Status StagedVolume::commit() {
  if (files_.empty()) return internal_error("commit of a volume file that is not staged");
  // The mesh file goes last, so that whoever sees it sees its .mapbc too.
  while (!files_.empty()) {
    const auto& [staged, destination] = files_.back();
    std::error_code ec;
    // A directory (polyMesh) cannot be renamed onto a non-empty one: the old one
    // is moved aside first and removed once the new one is in place.
    std::filesystem::path old;
    if (std::filesystem::is_directory(staged, ec) && std::filesystem::is_directory(destination, ec)) {
      old = staged;
      old += ".old";
      std::filesystem::rename(destination, old, ec);
      if (ec) {
        const std::string why = ec.message();
        const std::string where = destination.string();
        discard();
        return io_error(fmt::format("{}: cannot replace the directory: {}", where, why));
      }
    }
    std::filesystem::rename(staged, destination, ec);
    if (ec) {
      const std::string why = ec.message();
      const std::filesystem::path where = destination;
      discard();
      if (!old.empty()) std::filesystem::rename(old, where, ec);  // put the old one back
      return io_error(fmt::format("{}: cannot put the written file in place: {}", where.string(), why));
    }
    if (!old.empty()) remove_quietly(old);
    files_.pop_back();
  }
  return {};
}

void StagedVolume::discard() noexcept {
  for (const auto& [staged, destination] : files_) remove_quietly(staged);
  files_.clear();
}

namespace {

/// A hidden file beside `path` for writing it: ".NAME.PID.partial".
std::filesystem::path partial_path(const std::filesystem::path& path) {
  return path.parent_path() / fmt::format(".{}.{}.partial", path.filename().string(), ::getpid());
}

bool is_ugrid(VolumeFormat f) {
  return f == VolumeFormat::kUgridAscii || f == VolumeFormat::kUgridLittle || f == VolumeFormat::kUgridBig;
}

}  // namespace

Result<StagedVolume> stage_volume(const VolumeMesh& mesh, const std::filesystem::path& given,
                                  const VolumeWriteOptions& options) {
  PDR_ASSIGN_OR_RETURN(const VolumeFormat format, volume_format_from_path(given));
  PDR_TRY(volio::check_writable(mesh));
  const std::filesystem::path path = without_trailing_slash(given);
  if (format == VolumeFormat::kFoam && path.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(path.parent_path(), ec);
    if (ec) return io_error(fmt::format("{}: cannot create the directory: {}", path.parent_path().string(), ec.message()));
  }
  StagedVolume staged;  // removes the partial files if a write fails
  const std::filesystem::path partial = partial_path(path);
  if (format == VolumeFormat::kFoam) remove_quietly(partial);  // no stale files of an earlier run
  staged.add(partial, path);
  if (Status s = write_format(mesh, format, partial, options); !s.ok())
    return Status(s.code(), fmt::format("{} (writing {})", s.message(), path.string()));
  if (is_ugrid(format) && !mesh.boundary.empty()) {
    const std::filesystem::path mapbc = mapbc_path(path);
    const std::filesystem::path mapbc_partial = partial_path(mapbc);
    staged.add(mapbc_partial, mapbc);
    volio::OutputFile out(mapbc_partial);
    PDR_TRY(out.open());
    const std::string text = format_mapbc(mesh);
    out.buf().append(text.data(), text.data() + text.size());
    PDR_TRY(out.close());
  }
  return staged;
}

Status write_volume(const VolumeMesh& mesh, const std::filesystem::path& path, const VolumeWriteOptions& options) {
  PDR_ASSIGN_OR_RETURN(StagedVolume staged, stage_volume(mesh, path, options));
  return staged.commit();
}

Result<VolumeMesh> read_volume(const std::filesystem::path& path) {
  PDR_ASSIGN_OR_RETURN(const VolumeFormat format, volume_format_from_path(path));
  if (format == VolumeFormat::kCgns || format == VolumeFormat::kFoam)
    return unsupported(fmt::format("{}: pdrmesh writes {} but does not read it; volume mesh formats read: {}",
                                   path.string(), format == VolumeFormat::kCgns ? "CGNS" : "OpenFOAM polyMesh",
                                   ".mesh .meshb .vtu .ugrid .lb8.ugrid .b8.ugrid .msh .su2"));
  PDR_ASSIGN_OR_RETURN(const std::string data, volio::read_file(path));
  const std::string name = path.string();  // errors name the path as given
  switch (format) {
    case VolumeFormat::kMedit: return volio::read_medit(data, name);
    case VolumeFormat::kMeditBinary: return volio::read_meshb(data, name);
    case VolumeFormat::kVtu: return volio::read_vtu(data, name);
    case VolumeFormat::kUgridAscii:
    case VolumeFormat::kUgridLittle:
    case VolumeFormat::kUgridBig: {
      PDR_ASSIGN_OR_RETURN(VolumeMesh mesh, format == VolumeFormat::kUgridAscii
                                                ? volio::read_ugrid_ascii(data, name)
                                                : volio::read_ugrid_binary(data, name, format == VolumeFormat::kUgridLittle));
      PDR_TRY(volio::read_mapbc_beside(mesh, path));
      return mesh;
    }
    case VolumeFormat::kGmsh: return volio::read_gmsh(data, name);
    case VolumeFormat::kSu2: return volio::read_su2(data, name);
    case VolumeFormat::kCgns:
    case VolumeFormat::kFoam: break;
  }
  return internal_error("unhandled volume format");
}

}  // namespace pdrmesh
