// SPDX-License-Identifier: AGPL-3.0-or-later
// Writes the fuzz targets' seed inputs into OUT/<target>/: small surfaces cut
// from the test surfaces (DATA_DIR/sphere966.mesh and hinge.mesh, normally
// tests/data; the first triangles of each) in every surface format, a small volume mesh in every
// volume format, valid leaf tasks and results, client requests; plus truncated
// copies of each. Generated at build time, never committed.
//   pdrmesh_fuzz_seeds DATA_DIR OUT_DIR
// Exits 1 when a test surface cannot be read.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "../octree_fixtures.hpp"
#include "job_runner.hpp"
#include "job_service.hpp"
#include "pdrmesh/leaf_task.hpp"
#include "pdrmesh/pdr.hpp"
#include "pdrmesh/predicates.hpp"
#include "pdrmesh/surface_io.hpp"
#include "volume_io_detail.hpp"

namespace fs = std::filesystem;
using namespace pdrmesh;

namespace {

int seeds = 0;

/// The seed and, for longer ones, its first half (a truncated file).
void put(const fs::path& dir, const std::string& name, const std::string& bytes) {
  fs::create_directories(dir);
  auto write = [&](const std::string& file, std::string_view b) {
    std::ofstream(dir / file, std::ios::binary).write(b.data(), static_cast<std::streamsize>(b.size()));
    ++seeds;
  };
  write(name, bytes);
  if (bytes.size() > 16) write(name + ".cut", std::string_view(bytes).substr(0, bytes.size() / 2));
}

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

/// The first `k` triangles of `s` with the points they use.
SurfaceMesh first_triangles(const SurfaceMesh& s, std::size_t k) {
  SurfaceMesh out;
  std::vector<Index> map(s.points.size(), kNoIndex);
  for (std::size_t t = 0; t < std::min(k, s.triangles.size()); ++t) {
    Tri tri = s.triangles[t];
    for (Index& v : tri) {
      if (map[v] == kNoIndex) {
        map[v] = static_cast<Index>(out.points.size());
        out.points.push_back(s.points[v]);
      }
      v = map[v];
    }
    out.triangles.push_back(tri);
    out.surface_ids.push_back(s.surface_ids[t] + static_cast<int>(t % 2));
  }
  return out;
}

std::string binary_stl(const SurfaceMesh& s) {
  std::string b(80, ' ');
  auto u32 = [&](std::uint32_t v) { b.append(reinterpret_cast<const char*>(&v), 4); };
  auto f32 = [&](float v) { b.append(reinterpret_cast<const char*>(&v), 4); };
  u32(static_cast<std::uint32_t>(s.triangles.size()));
  for (const Tri& t : s.triangles) {
    for (int i = 0; i < 3; ++i) f32(0);
    for (Index v : t)
      for (double c : s.points[v]) f32(static_cast<float>(c));
    b.append(2, '\0');
  }
  return b;
}

bool surface_seeds(const fs::path& data, const fs::path& out) {
  std::vector<SurfaceMesh> sources;
  for (const char* file : {"sphere966.mesh", "hinge.mesh"}) {
    Result<SurfaceMesh> s = read_surface(data / file);
    if (!s.ok()) {
      std::fprintf(stderr, "make_seeds: %s\n", s.status().to_string().c_str());
      return false;
    }
    sources.push_back(first_triangles(*s, 4));
    sources.push_back(first_triangles(*s, 24));
  }
  const std::pair<const char*, SurfaceFormat> formats[] = {
      {"stl_ascii", SurfaceFormat::kStl}, {"obj", SurfaceFormat::kObj},   {"off", SurfaceFormat::kOff},
      {"ply", SurfaceFormat::kPly},       {"mesh", SurfaceFormat::kMedit}, {"surf", SurfaceFormat::kAflr3Surf}};
  for (std::size_t i = 0; i < sources.size(); ++i) {
    const std::string n = "corpus" + std::to_string(i);
    for (const auto& [target, format] : formats) {
      Result<std::string> text = format_surface(sources[i], format);
      if (!text.ok()) continue;
      // The STL ASCII target prefixes "solid" itself.
      put(out / ("surface_" + std::string(target)), n, format == SurfaceFormat::kStl ? text->substr(5) : *text);
      if (format == SurfaceFormat::kOff) put(out / "surface_check", n, "\0" + *text);
    }
    put(out / "surface_stl_binary", n, binary_stl(sources[i]).substr(80));
  }
  // What the writers do not produce: polygons, relative indices, binary PLY.
  put(out / "surface_obj", "quad", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\ng a\nf 1/1/1 2//2 3 4\ng b\nf -1 -2 -3\n");
  put(out / "surface_off", "quad", "COFF\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n4 0 1 2 3 255 0 0\n3 0 1 4\n");
  std::string ply =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nproperty int surface_id\nend_header\n";
  const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  ply.append(reinterpret_cast<const char*>(xyz), sizeof xyz);
  ply.push_back('\3');
  const std::int32_t face[4] = {0, 1, 2, 7};
  ply.append(reinterpret_cast<const char*>(face), sizeof face);
  put(out / "surface_ply", "binary", ply);
  // The compact surface of the check target: a closed tetrahedron, and one crossing it.
  const std::string tet("\x01\x04" "\x00\x00\x00" "\x0a\x00\x00" "\x00\x0a\x00" "\x00\x00\x0a"
                        "\x00\x02\x01" "\x00\x01\x03" "\x00\x03\x02" "\x01\x02\x03", 2 + 12 + 12);
  put(out / "surface_check", "tetrahedron", tet);
  put(out / "surface_check", "crossing", tet.substr(0, 14) + "\x01\x02\x04");
  return true;
}

void volume_seeds(const fs::path& out) {
  for (int k : {1, 2}) {
    const VolumeMesh g = fixtures::kuhn_grid(k);
    const LeafTaskInput in = build_leaf_input(0, g.points, g.tets, FaceIdTable());
    VolumeMesh m;
    m.points = in.points;
    m.tets = in.tets;
    m.boundary = in.frozen_faces;
    for (std::size_t i = 0; i < m.boundary.size(); ++i) m.boundary_ids.push_back(1 + static_cast<int>(i % 3));
    m.tet_regions.assign(m.tets.size(), 1);
    m.boundary_names = {{1, "inlet"}, {3, "wall"}};
    const std::pair<const char*, std::function<Status(const VolumeMesh&, const fs::path&)>> writers[] = {
        {"mesh", volio::write_medit},
        {"meshb", volio::write_meshb},
        {"vtu", [](const VolumeMesh& v, const fs::path& p) { return volio::write_vtu(v, p, VtuEncoding::kBinary); }},
        {"ugrid", volio::write_ugrid_ascii},
        {"ugrid_lb8", [](const VolumeMesh& v, const fs::path& p) { return volio::write_ugrid_binary(v, p, true); }},
        {"ugrid_b8", [](const VolumeMesh& v, const fs::path& p) { return volio::write_ugrid_binary(v, p, false); }},
        {"msh", volio::write_gmsh},
        {"su2", volio::write_su2}};
    for (const auto& [target, write] : writers) {
      const fs::path tmp = out / ("tmp." + std::string(target));
      if (!write(m, tmp).ok()) continue;
      put(out / ("volume_" + std::string(target)), "grid" + std::to_string(k), slurp(tmp));
      fs::remove(tmp);
    }
    // The other VTU encodings: compressed binary and ascii.
    for (const auto& [suffix, encoding] : {std::pair{"_zlib", VtuEncoding::kCompressed}, std::pair{"_ascii", VtuEncoding::kAscii}}) {
      const fs::path tmp = out / "tmp.vtu";
      if (!volio::write_vtu(m, tmp, encoding).ok()) continue;
      put(out / "volume_vtu", "grid" + std::to_string(k) + suffix, slurp(tmp));
      fs::remove(tmp);
    }
  }
}

void leaf_seeds(const fs::path& out) {
  const VolumeMesh g = fixtures::kuhn_grid(1);
  const LeafTaskInput in = build_leaf_input(3, g.points, g.tets, FaceIdTable());
  put(out / "leaf_result", "task", in.encode());
  LeafTaskOutput same;
  same.leaf = in.leaf;
  same.input_points = static_cast<std::uint32_t>(in.points.size());
  same.tets = in.tets;
  put(out / "leaf_result", "unchanged", same.encode());
  // The centre of the cube joined to every hull face.
  LeafTaskOutput star = same;
  star.tets.clear();
  star.new_points.push_back({0.5, 0.5, 0.5});
  std::vector<Vec3> points = in.points;
  points.push_back(star.new_points[0]);
  for (const Tri& f : in.frozen_faces) {
    Tet t{f[0], f[1], f[2], same.input_points};
    if (exact::orient3d(points[t[0]], points[t[1]], points[t[2]], points[t[3]]) < 0) std::swap(t[1], t[2]);
    star.tets.push_back(t);
  }
  put(out / "leaf_result", "star", star.encode());
}

void request_seeds(const fs::path& out) {
  server::JobOptions o;
  put(out / "job_request", "defaults.json", "\x01" + o.to_json());
  o.max_volume = 0.25;
  o.depth = 3;
  o.kernel = "tetgen";
  o.sizing.size = 0.1;
  o.sizing.hmin = 0.01;
  o.sizing.hmax = 1;
  o.optimize = false;
  put(out / "job_request", "set.json", "\x01" + o.to_json());
  v1::SubmitRequest request;
  request.mutable_header()->set_file_name("part.stl");
  request.mutable_header()->set_total_bytes(684);
  server::to_proto(o, *request.mutable_header()->mutable_options());
  put(out / "job_request", "header.pb", std::string(1, '\0') + request.SerializeAsString());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s DATA_DIR OUT_DIR\n", argv[0]);
    return 2;
  }
  const fs::path data = argv[1], out = argv[2];
  if (!surface_seeds(data, out)) return 1;
  volume_seeds(out);
  leaf_seeds(out);
  request_seeds(out);
  std::printf("make_seeds: %d seed files in %s\n", seeds, out.c_str());
  return 0;
}
