// SPDX-License-Identifier: AGPL-3.0-or-later
// Surface input/output: format by suffix, file reading, dispatch to the
// per-format readers (surface_io_*.cpp) and the writers.
#include "pdrmesh/surface_io.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <numeric>

#include "pdrmesh/volume_mesh.hpp"
#include "surface_io_internal.hpp"

namespace pdrmesh {
namespace {

using surface_io_detail::quote_token;

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

Result<std::string> read_file(const std::filesystem::path& path) {
  File f(std::fopen(path.c_str(), "rb"));
  if (!f) {
    const int err = errno;
    const std::string msg = fmt::format("cannot open {}: {}", path.string(), std::strerror(err));
    return err == ENOENT ? not_found(msg) : io_error(msg);
  }
  std::string bytes;
  std::error_code ec;
  if (const auto size = std::filesystem::file_size(path, ec); !ec) bytes.reserve(size);
  std::array<char, 1 << 16> chunk{};
  for (;;) {
    const std::size_t n = std::fread(chunk.data(), 1, chunk.size(), f.get());
    bytes.append(chunk.data(), n);
    if (n < chunk.size()) break;
  }
  if (std::ferror(f.get()) != 0) {
    return io_error(fmt::format("error reading {}: {}", path.string(), std::strerror(errno)));
  }
  return bytes;
}

/// Output that goes to a file in 1 MiB pieces, or stays in memory.
class Sink {
 public:
  explicit Sink(std::FILE* file) : file_(file) {}

  template <class... Args>
  void print(fmt::format_string<Args...> f, Args&&... args) {
    fmt::format_to(std::back_inserter(buf_), f, std::forward<Args>(args)...);
    if (file_ != nullptr && buf_.size() > (1U << 20)) flush();
  }
  void flush() {
    if (file_ != nullptr && buf_.size() > 0) {
      if (std::fwrite(buf_.data(), 1, buf_.size(), file_) != buf_.size()) failed_ = true;
      buf_.clear();
    }
  }
  bool failed() const { return failed_; }
  std::string str() const { return fmt::to_string(buf_); }

 private:
  std::FILE* file_;
  fmt::memory_buffer buf_;
  bool failed_ = false;
};

Status validate_for_write(const SurfaceMesh& s) {
  if (s.surface_ids.size() != s.triangles.size()) {
    return invalid_input(fmt::format("{}: {} surface ids for {} triangles", s.name,
                                     s.surface_ids.size(), s.triangles.size()));
  }
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    const Vec3& p = s.points[i];
    if (!is_finite(p)) {
      return invalid_input(fmt::format("{}: point {} has a non-finite coordinate ({}, {}, {})",
                                       s.name, i, p[0], p[1], p[2]));
    }
  }
  for (std::size_t i = 0; i < s.triangles.size(); ++i) {
    const Tri& t = s.triangles[i];
    if (t[0] >= s.points.size() || t[1] >= s.points.size() || t[2] >= s.points.size()) {
      return invalid_input(
          fmt::format("{}: triangle {} (points {}, {}, {}) has an index out of "
                      "range ({} points)",
                      s.name, i, t[0], t[1], t[2], s.points.size()));
    }
  }
  return {};
}

void write_stl(const SurfaceMesh& s, Sink& out) {
  // One solid per distinct id, ascending; triangles keep their order within a solid.
  std::vector<std::size_t> order(s.triangles.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return s.surface_ids[a] < s.surface_ids[b];
  });
  for (std::size_t k = 0; k < order.size(); ++k) {
    const int id = s.surface_ids[order[k]];
    if (k == 0 || s.surface_ids[order[k - 1]] != id) out.print("solid {}\n", boundary_name(s.surface_names, id));
    const Tri& t = s.triangles[order[k]];
    const Vec3& a = s.points[t[0]];
    const Vec3& b = s.points[t[1]];
    const Vec3& c = s.points[t[2]];
    Vec3 n = cross(b - a, c - a);
    const double len = norm(n);
    n = len > 0 ? (1.0 / len) * n : Vec3{0, 0, 0};
    out.print(" facet normal {} {} {}\n  outer loop\n", n[0], n[1], n[2]);
    for (const Vec3* p : {&a, &b, &c}) out.print("   vertex {} {} {}\n", (*p)[0], (*p)[1], (*p)[2]);
    out.print("  endloop\n endfacet\n");
    if (k + 1 == order.size() || s.surface_ids[order[k + 1]] != id) {
      out.print("endsolid {}\n", boundary_name(s.surface_names, id));
    }
  }
}

void write_obj(const SurfaceMesh& s, Sink& out) {
  out.print("# {} points, {} triangles\n", s.points.size(), s.triangles.size());
  for (const Vec3& p : s.points) out.print("v {} {} {}\n", p[0], p[1], p[2]);
  for (std::size_t i = 0; i < s.triangles.size(); ++i) {
    if (i == 0 || s.surface_ids[i] != s.surface_ids[i - 1])
      out.print("g {}\n", boundary_name(s.surface_names, s.surface_ids[i]));
    const Tri& t = s.triangles[i];
    out.print("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
  }
}

void write_off(const SurfaceMesh& s, Sink& out) {
  out.print("OFF\n{} {} 0\n", s.points.size(), s.triangles.size());
  for (const Vec3& p : s.points) out.print("{} {} {}\n", p[0], p[1], p[2]);
  for (const Tri& t : s.triangles) out.print("3 {} {} {}\n", t[0], t[1], t[2]);
}

void write_ply(const SurfaceMesh& s, Sink& out) {
  out.print(
      "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\n"
      "property double z\nelement face {}\nproperty list uchar uint vertex_indices\n"
      "property int surface_id\nend_header\n",
      s.points.size(), s.triangles.size());
  for (const Vec3& p : s.points) out.print("{} {} {}\n", p[0], p[1], p[2]);
  for (std::size_t i = 0; i < s.triangles.size(); ++i) {
    const Tri& t = s.triangles[i];
    out.print("3 {} {} {} {}\n", t[0], t[1], t[2], s.surface_ids[i]);
  }
}

void write_medit(const SurfaceMesh& s, Sink& out) {
  out.print("MeshVersionFormatted 2\nDimension 3\n\nVertices\n{}\n", s.points.size());
  for (const Vec3& p : s.points) out.print("{} {} {} 0\n", p[0], p[1], p[2]);
  out.print("\nTriangles\n{}\n", s.triangles.size());
  for (std::size_t i = 0; i < s.triangles.size(); ++i) {
    const Tri& t = s.triangles[i];
    out.print("{} {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1, s.surface_ids[i]);
  }
  out.print("\nEnd\n");
}

void write_aflr3_surf(const SurfaceMesh& s, Sink& out) {
  out.print("{} 0 {}\n", s.triangles.size(), s.points.size());
  for (const Vec3& p : s.points) out.print("{} {} {}\n", p[0], p[1], p[2]);
  for (std::size_t i = 0; i < s.triangles.size(); ++i) {
    const Tri& t = s.triangles[i];
    out.print("{} {} {} {} 0 0\n", t[0] + 1, t[1] + 1, t[2] + 1, s.surface_ids[i]);
  }
}

void write_format(const SurfaceMesh& s, SurfaceFormat format, Sink& out) {
  switch (format) {
    case SurfaceFormat::kStl: write_stl(s, out); break;
    case SurfaceFormat::kObj: write_obj(s, out); break;
    case SurfaceFormat::kOff: write_off(s, out); break;
    case SurfaceFormat::kPly: write_ply(s, out); break;
    case SurfaceFormat::kMedit: write_medit(s, out); break;
    case SurfaceFormat::kAflr3Surf: write_aflr3_surf(s, out); break;
  }
  out.flush();
}

}  // namespace

Result<SurfaceFormat> surface_format_from_path(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](char ch) { return ch >= 'A' && ch <= 'Z' ? static_cast<char>(ch + 32) : ch; });
  if (ext == ".stl") return SurfaceFormat::kStl;
  if (ext == ".obj") return SurfaceFormat::kObj;
  if (ext == ".off") return SurfaceFormat::kOff;
  if (ext == ".ply") return SurfaceFormat::kPly;
  if (ext == ".mesh") return SurfaceFormat::kMedit;
  if (ext == ".surf") return SurfaceFormat::kAflr3Surf;
  return unsupported(
      fmt::format("{}: unknown surface format {} (expected .stl, .obj, .off, .ply, "
                  ".mesh or .surf)",
                  path.string(), quote_token(path.extension().string())));
}

Result<SurfaceMesh> parse_surface(std::string_view bytes, SurfaceFormat format,
                                  std::string_view name) {
  namespace d = surface_io_detail;
  if (bytes.find_first_not_of(" \t\r\n") == std::string_view::npos) {
    return invalid_input(fmt::format("{}: empty file", name));
  }
  switch (format) {
    case SurfaceFormat::kStl: return d::parse_stl(bytes, name);
    case SurfaceFormat::kObj: return d::parse_obj(bytes, name);
    case SurfaceFormat::kOff: return d::parse_off(bytes, name);
    case SurfaceFormat::kPly: return d::parse_ply(bytes, name);
    case SurfaceFormat::kMedit: return d::parse_medit(bytes, name);
    case SurfaceFormat::kAflr3Surf: return d::parse_aflr3_surf(bytes, name);
  }
  return internal_error("parse_surface: unknown format");
}

Result<SurfaceMesh> read_surface(const std::filesystem::path& path) {
  PDR_ASSIGN_OR_RETURN(const SurfaceFormat format, surface_format_from_path(path));
  PDR_ASSIGN_OR_RETURN(const std::string bytes, read_file(path));
  // Errors name the path as given; the surface is named by its file name.
  PDR_ASSIGN_OR_RETURN(SurfaceMesh surface, parse_surface(bytes, format, path.string()));
  surface.name = path.filename().string();
  return surface;
}

Result<std::string> format_surface(const SurfaceMesh& surface, SurfaceFormat format) {
  PDR_TRY(validate_for_write(surface));
  Sink out(nullptr);
  write_format(surface, format, out);
  return out.str();
}

Status write_surface(const SurfaceMesh& surface, const std::filesystem::path& path) {
  PDR_ASSIGN_OR_RETURN(const SurfaceFormat format, surface_format_from_path(path));
  PDR_TRY(validate_for_write(surface));
  File f(std::fopen(path.c_str(), "wb"));
  if (!f)
    return io_error(
        fmt::format("cannot open {} for writing: {}", path.string(), std::strerror(errno)));
  Sink out(f.get());
  write_format(surface, format, out);
  if (out.failed() || std::fclose(f.release()) != 0) {
    return io_error(fmt::format("error writing {}: {}", path.string(), std::strerror(errno)));
  }
  return {};
}

}  // namespace pdrmesh
