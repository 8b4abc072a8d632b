// SPDX-License-Identifier: AGPL-3.0-or-later
// pdrmesh_bench_kernels: times the kernel pieces that have speed goals and
// prints a table with the machine. Not a test: it asserts nothing.
//   surface check: corpus surfaces and generated tori up to 1M triangles
//   sizing field: query time on a dense TetGen background, random and Morton order
//   usage: pdrmesh_bench_kernels [CORPUS_DIR]
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <string>
#include <thread>

#include "pdrmesh/sizing.hpp"
#include "pdrmesh/surface_check.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/validate.hpp"

namespace {

using namespace pdrmesh;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double process_cpu_seconds() { return double(std::clock()) / CLOCKS_PER_SEC; }

std::string machine() {
  std::ifstream cpu("/proc/cpuinfo");
  std::string line, model = "unknown cpu";
  while (std::getline(cpu, line))
    if (line.rfind("model name", 0) == 0) {
      model = line.substr(line.find(':') + 2);
      break;
    }
  return fmt::format("{} hardware threads, {}", std::thread::hardware_concurrency(), model);
}

/// A torus with n x m quads, 2 n m triangles, genus 1.
SurfaceMesh torus(Index n, Index m) {
  SurfaceMesh s;
  for (Index i = 0; i < n; ++i)
    for (Index j = 0; j < m; ++j) {
      const double u = 2 * std::numbers::pi * i / n, v = 2 * std::numbers::pi * j / m;
      s.points.push_back({(3 + std::cos(v)) * std::cos(u), (3 + std::cos(v)) * std::sin(u), std::sin(v)});
    }
  for (Index i = 0; i < n; ++i)
    for (Index j = 0; j < m; ++j) {
      const Index a = i * m + j, b = ((i + 1) % n) * m + j, c = ((i + 1) % n) * m + (j + 1) % m,
                  d = i * m + (j + 1) % m;
      s.triangles.push_back({a, b, c});
      s.triangles.push_back({a, c, d});
    }
  s.surface_ids.assign(s.triangles.size(), 1);
  s.name = fmt::format("torus {}x{}", n, m);
  return s;
}

void bench_check(const SurfaceMesh& s) {
  const auto t0 = Clock::now();
  const double c0 = process_cpu_seconds();
  const SurfaceReport r = check_surface(s);
  fmt::print("{:<24} {:>10} {:>9.3f} {:>9.3f} {:>10}\n", s.name, s.triangles.size(), seconds_since(t0),
             process_cpu_seconds() - c0, r.meshable() ? "meshable" : "DEFECTS");
}

void bench_sizing(const std::filesystem::path& path, double volume_divisor) {
  auto surface = read_surface(path);
  if (!surface.ok()) {
    fmt::print("{}: {}\n", path.string(), surface.status().to_string());
    return;
  }
  TetgenOptions o;
  o.max_volume = enclosed_volume(*surface) / volume_divisor;
  auto background = tetrahedralize(*surface, o);
  if (!background.ok()) {
    fmt::print("{}: {}\n", path.string(), background.status().to_string());
    return;
  }
  const auto t0 = Clock::now();
  auto field = SizingField::build(*surface, *background, SizingOptions{});
  const double build_s = seconds_since(t0);
  if (!field.ok()) {
    fmt::print("{}: {}\n", path.string(), field.status().to_string());
    return;
  }
  const Box box = surface->bounds();
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec3> xs(200000);
  for (Vec3& x : xs)
    for (int k = 0; k < 3; ++k) x[k] = box.lo[k] + u(rng) * (box.hi[k] - box.lo[k]);
  double sink = 0;
  auto per_query_ns = [&] {
    const double c0 = process_cpu_seconds();
    for (const Vec3& x : xs) sink += field->at(x);
    return 1e9 * (process_cpu_seconds() - c0) / double(xs.size());
  };
  const double random_ns = per_query_ns();
  auto morton = [&](const Vec3& p) {
    std::uint64_t key = 0;
    std::uint32_t c[3];
    for (int k = 0; k < 3; ++k)
      c[k] = static_cast<std::uint32_t>(std::clamp((p[k] - box.lo[k]) / (box.hi[k] - box.lo[k]), 0.0, 1.0) * 1023);
    for (int bit = 9; bit >= 0; --bit)
      for (int k = 0; k < 3; ++k) key = 2 * key + ((c[k] >> bit) & 1u);
    return key;
  };
  std::sort(xs.begin(), xs.end(), [&](const Vec3& a, const Vec3& b) { return morton(a) < morton(b); });
  const double morton_ns = per_query_ns();
  fmt::print("{:<24} {:>10} {:>10} {:>9.3f} {:>12.0f} {:>12.0f}   (checksum {:.6g})\n", path.filename().string(),
             background->points.size(), background->tets.size(), build_s, random_ns, morton_ns, sink);
}

}  // namespace

int main(int argc, char** argv) {
  const std::filesystem::path corpus = argc > 1 ? argv[1] : PDRMESH_DEFAULT_CORPUS;
  fmt::print("pdrmesh kernel benchmarks; machine: {}\n\n", machine());

  fmt::print("surface check (read not included; cpu_s summed over threads)\n");
  fmt::print("{:<24} {:>10} {:>9} {:>9} {:>10}\n", "surface", "triangles", "wall_s", "cpu_s", "result");
  for (const char* name : {"armadillo", "frame"}) {
    auto s = read_surface(corpus / (std::string(name) + ".stl"));
    if (s.ok()) bench_check(*s);
  }
  for (Index n : {250u, 500u, 1000u}) bench_check(torus(n, n / 2));

  fmt::print("\nsizing field on a TetGen background (max volume = enclosed / 20000); query cost in CPU ns\n");
  fmt::print("{:<24} {:>10} {:>10} {:>9} {:>12} {:>12}\n", "surface", "points", "tets", "build_s", "random_ns",
             "morton_ns");
  for (const char* name : {"bunny_npm", "elephant", "fandisk"})
    bench_sizing(corpus / (std::string(name) + ".stl"), 20000);
  return 0;
}
