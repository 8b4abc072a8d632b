// SPDX-License-Identifier: AGPL-3.0-or-later
// Leaf task serialisation and the coordinator's acceptance test of a result.
#include "pdrmesh/leaf_task.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <new>
#include <numbers>
#include <tuple>
#include <utility>

#include "pdrmesh/byte_codec.hpp"
#include "pdrmesh/fixed_chunks.hpp"
#include "pdrmesh/predicates.hpp"
#include "pdrmesh/topology.hpp"

namespace pdrmesh {

namespace {

constexpr char kInputMagic[8] = {'P', 'D', 'R', 'L', 'E', 'A', 'F', 'I'};
constexpr char kOutputMagic[8] = {'P', 'D', 'R', 'L', 'E', 'A', 'F', 'O'};
constexpr std::uint32_t kVersion = 5;

Status decode_error(std::string_view what, std::string_view detail) {
  return invalid_input(fmt::format("leaf task {}: {}", what, detail));
}

void put_point(codec::Writer& w, const Vec3& p) {
  for (double c : p) w.f64(c);
}

bool get_point(codec::Reader& r, Vec3& p) {
  for (double& c : p)
    if (!r.f64(c) || !std::isfinite(c)) return false;
  return true;
}

template <std::size_t N>
void put_indices(codec::Writer& w, const std::array<Index, N>& a) {
  for (Index v : a) w.u32(v);
}

/// Reads N indices, each below `limit` and pairwise distinct.
template <std::size_t N>
bool get_indices(codec::Reader& r, std::array<Index, N>& a, std::size_t limit) {
  for (std::size_t i = 0; i < N; ++i) {
    if (!r.u32(a[i]) || a[i] >= limit) return false;
    for (std::size_t j = 0; j < i; ++j)
      if (a[j] == a[i]) return false;
  }
  return true;
}

/// Writes a sizes array: its count, then the values.
void put_sizes(codec::Writer& w, const std::vector<double>& sizes) {
  w.u64(sizes.size());
  for (double h : sizes) w.f64(h);
}

/// Reads a sizes array of 0 or `n` entries, each finite and > 0.
bool get_sizes(codec::Reader& r, std::size_t n, std::vector<double>& sizes) {
  std::size_t s = 0;
  if (!r.count(8, s) || (s != 0 && s != n)) return false;
  sizes.resize(s);
  for (double& h : sizes)
    if (!r.f64(h) || !std::isfinite(h) || !(h > 0)) return false;
  return true;
}

bool get_header(codec::Reader& r, const char (&magic)[8]) {
  char m[8];
  std::uint32_t version = 0;
  return r.bytes(m, 8) && std::memcmp(m, magic, 8) == 0 && r.u32(version) && version == kVersion;
}

/// Rotates a triangle so that its smallest index comes first (keeps orientation).
Tri canonical(const Tri& t) {
  const int m = t[0] < t[1] ? (t[0] < t[2] ? 0 : 2) : (t[1] < t[2] ? 1 : 2);
  return {t[static_cast<std::size_t>(m)], t[static_cast<std::size_t>((m + 1) % 3)],
          t[static_cast<std::size_t>((m + 2) % 3)]};
}

std::string tri_str(const Tri& t) { return fmt::format("({}, {}, {})", t[0], t[1], t[2]); }

}  // namespace

std::string LeafTaskInput::encode() const {
  codec::Writer w;
  w.bytes(kInputMagic, 8);
  w.u32(kVersion);
  w.u32(leaf);
  w.u64(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    w.u64(i < point_ids.size() ? point_ids[i] : GlobalId{0});
    put_point(w, points[i]);
  }
  w.u64(tets.size());
  for (const Tet& t : tets) put_indices(w, t);
  w.u64(frozen_faces.size());
  for (std::size_t i = 0; i < frozen_faces.size(); ++i) {
    put_indices(w, frozen_faces[i]);
    w.u32(static_cast<std::uint32_t>(i < frozen_ids.size() ? frozen_ids[i] : 0));
  }
  w.u32(core ? 1 : 0);
  if (core) {
    put_point(w, core->lo);
    put_point(w, core->hi);
  }
  put_sizes(w, sizes);
  w.u64(seeds.size());
  for (const Vec3& p : seeds) put_point(w, p);
  return w.take();
}

Result<LeafTaskInput> LeafTaskInput::decode(std::string_view bytes) {
  codec::Reader r(bytes);
  LeafTaskInput in;
  if (!get_header(r, kInputMagic)) return decode_error("input", "bad magic or version");
  if (!r.u32(in.leaf)) return decode_error("input", "truncated header");
  std::size_t n = 0;
  if (!r.count(32, n)) return decode_error("input", "point count exceeds the buffer");
  in.point_ids.resize(n);
  in.points.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!r.u64(in.point_ids[i]) || !get_point(r, in.points[i]))
      return decode_error("input", fmt::format("point {} is truncated or not finite", i));
  }
  std::vector<GlobalId> ids = in.point_ids;
  std::sort(ids.begin(), ids.end());
  if (std::adjacent_find(ids.begin(), ids.end()) != ids.end())
    return decode_error("input", "two points have the same global id");
  std::size_t m = 0;
  if (!r.count(16, m)) return decode_error("input", "tet count exceeds the buffer");
  in.tets.resize(m);
  for (std::size_t t = 0; t < m; ++t) {
    if (!get_indices(r, in.tets[t], n))
      return decode_error("input", fmt::format("tet {} has an index out of range (of {}) or repeated", t, n));
  }
  std::size_t k = 0;
  if (!r.count(16, k)) return decode_error("input", "frozen face count exceeds the buffer");
  in.frozen_faces.resize(k);
  in.frozen_ids.resize(k);
  for (std::size_t f = 0; f < k; ++f) {
    std::uint32_t id = 0;
    if (!get_indices(r, in.frozen_faces[f], n) || !r.u32(id))
      return decode_error("input", fmt::format("frozen face {} has an index out of range (of {}) or repeated", f, n));
    in.frozen_ids[f] = static_cast<int>(id);
  }
  std::uint32_t has_core = 0;
  if (!r.u32(has_core) || has_core > 1) return decode_error("input", "bad core flag");
  if (has_core == 1) {
    Box b;
    if (!get_point(r, b.lo) || !get_point(r, b.hi) || !(b.lo[0] <= b.hi[0] && b.lo[1] <= b.hi[1] && b.lo[2] <= b.hi[2]))
      return decode_error("input", "the core box is truncated, not finite or empty");
    in.core = b;
  }
  if (!get_sizes(r, n, in.sizes)) return decode_error("input", "the sizes are truncated, miscounted or not positive");
  std::size_t q = 0;
  if (!r.count(24, q)) return decode_error("input", "seed count exceeds the buffer");
  in.seeds.resize(q);
  for (std::size_t i = 0; i < q; ++i)
    if (!get_point(r, in.seeds[i])) return decode_error("input", fmt::format("seed {} is not finite", i));
  if (r.left() != 0) return decode_error("input", fmt::format("{} trailing bytes", r.left()));
  return in;
}

std::string LeafTaskOutput::encode() const {
  codec::Writer w;
  w.bytes(kOutputMagic, 8);
  w.u32(kVersion);
  w.u32(leaf);
  w.u32(input_points);
  w.u64(new_points.size());
  for (const Vec3& p : new_points) put_point(w, p);
  put_sizes(w, new_sizes);
  w.u64(tets.size());
  for (const Tet& t : tets) put_indices(w, t);
  w.u64(moved.size());
  for (std::size_t i = 0; i < moved.size(); ++i) {
    w.u32(moved[i]);
    put_point(w, i < moved_to.size() ? moved_to[i] : Vec3{});
  }
  return w.take();
}

std::uint64_t LeafTaskOutput::encoded_size() const {
  return 20 + 8 + 24 * std::uint64_t{new_points.size()} + 8 + 8 * std::uint64_t{new_sizes.size()} + 8 +
         16 * std::uint64_t{tets.size()} + 8 + 28 * std::uint64_t{moved.size()};
}

Result<LeafTaskOutput> LeafTaskOutput::decode(std::string_view bytes) {
  codec::Reader r(bytes);
  LeafTaskOutput out;
  if (!get_header(r, kOutputMagic)) return decode_error("output", "bad magic or version");
  if (!r.u32(out.leaf) || !r.u32(out.input_points)) return decode_error("output", "truncated header");
  std::size_t n = 0;
  if (!r.count(24, n)) return decode_error("output", "new point count exceeds the buffer");
  out.new_points.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!get_point(r, out.new_points[i]))
      return decode_error("output", fmt::format("new point {} is truncated or not finite", i));
  }
  if (!get_sizes(r, n, out.new_sizes))
    return decode_error("output", "the new points' sizes are truncated, miscounted or not positive");
  const std::size_t limit = std::size_t{out.input_points} + n;
  std::size_t m = 0;
  if (!r.count(16, m)) return decode_error("output", "tet count exceeds the buffer");
  out.tets.resize(m);
  for (std::size_t t = 0; t < m; ++t) {
    if (!get_indices(r, out.tets[t], limit))
      return decode_error("output", fmt::format("tet {} has a reference out of range (of {}) or repeated", t, limit));
  }
  std::size_t k = 0;
  if (!r.count(28, k)) return decode_error("output", "moved point count exceeds the buffer");
  out.moved.resize(k);
  out.moved_to.resize(k);
  for (std::size_t i = 0; i < k; ++i) {
    if (!r.u32(out.moved[i]) || out.moved[i] >= out.input_points || !get_point(r, out.moved_to[i]))
      return decode_error("output", fmt::format("moved point {} is truncated, out of range or not finite", i));
  }
  if (r.left() != 0) return decode_error("output", fmt::format("{} trailing bytes", r.left()));
  return out;
}

Status validate_leaf_output(const LeafTaskInput& in, const LeafTaskOutput& out) {
  auto fail = [&](std::string what) {
    return invalid_input(fmt::format("leaf {} result rejected: {}", in.leaf, what));
  };
  if (out.leaf != in.leaf) return fail(fmt::format("it names leaf {}", out.leaf));
  if (out.input_points != in.points.size())
    return fail(fmt::format("it counts {} input points, the task had {}", out.input_points, in.points.size()));
  const std::size_t ni = in.points.size();
  const std::size_t limit = ni + out.new_points.size();
  if (!out.new_sizes.empty() && out.new_sizes.size() != out.new_points.size())
    return fail(fmt::format("it gives {} sizes for {} new points", out.new_sizes.size(), out.new_points.size()));
  for (double h : out.new_sizes)
    if (!std::isfinite(h) || !(h > 0)) return fail(fmt::format("a new point's size is {}", h));
  if (out.moved_to.size() != out.moved.size())
    return fail(fmt::format("it moves {} points with {} coordinates", out.moved.size(), out.moved_to.size()));
  std::vector<Vec3> moved_points;  // in.points with the moves applied (only when there are moves)
  if (!out.moved.empty()) {
    std::vector<unsigned char> on_hull(ni, 0);
    for (const Tri& f : in.frozen_faces)
      for (Index v : f) on_hull[v] = 1;
    moved_points = in.points;
    for (std::size_t i = 0; i < out.moved.size(); ++i) {
      const Index v = out.moved[i];
      if (v >= ni || (i > 0 && v <= out.moved[i - 1]))
        return fail(fmt::format("moved point {} ({}) is out of range or not ascending", i, v));
      if (on_hull[v] != 0) return fail(fmt::format("it moves hull point {}", v));
      if (!is_finite(out.moved_to[i])) return fail(fmt::format("moved point {} is not finite", v));
      moved_points[v] = out.moved_to[i];
    }
  }
  const std::vector<Vec3>& inputs = out.moved.empty() ? in.points : moved_points;
  auto point = [&](Index r) -> const Vec3& { return r < ni ? inputs[r] : out.new_points[r - ni]; };
  std::vector<unsigned char> used(out.new_points.size(), 0);
  for (std::size_t t = 0; t < out.tets.size(); ++t) {
    const Tet& v = out.tets[t];
    for (int i = 0; i < 4; ++i) {
      if (v[i] >= limit) return fail(fmt::format("tet {} refers to {} of {} points", t, v[i], limit));
      for (int j = 0; j < i; ++j)
        if (v[i] == v[j]) return fail(fmt::format("tet {} repeats point {}", t, v[i]));
      if (v[i] >= ni) used[v[i] - ni] = 1;
    }
    if (exact::orient3d(point(v[0]), point(v[1]), point(v[2]), point(v[3])) <= 0)
      return fail(fmt::format("tet {} ({}, {}, {}, {}) is not positively oriented", t, v[0], v[1], v[2], v[3]));
  }
  for (std::size_t k = 0; k < used.size(); ++k)
    if (used[k] == 0) return fail(fmt::format("new point {} is used by no tet", k));
  for (const Vec3& p : out.new_points)
    if (!is_finite(p))
      return fail(fmt::format("a new point is not finite ({}, {}, {})", p[0], p[1], p[2]));
  // Faces grouped by their sorted points: a face of two tets must be used with
  // opposite orientations, one of a single tet is a hull face.
  const auto faces = detail::faces_by_smallest_point(out.tets, limit);
  std::vector<Tri> hull;
  std::string problem;
  for (std::size_t a = 0; a < limit && problem.empty(); ++a) {
    detail::for_each_face_group(faces, a, [&](std::span<const detail::FaceRef> group) {
      if (!problem.empty()) return;
      const Tri key = {static_cast<Index>(a), group[0].b, group[0].c};
      const Tri tri = canonical(topo::face_of(out.tets[group[0].tet], static_cast<int>(group[0].slot)));
      if (group.size() > 2) {
        problem = fmt::format("face {} is shared by {} tets", tri_str(key), group.size());
      } else if (group.size() == 2) {
        const Tri other = canonical(topo::face_of(out.tets[group[1].tet], static_cast<int>(group[1].slot)));
        if (!(tri[1] == other[2] && tri[2] == other[1]))
          problem = fmt::format("face {} is used twice with the same orientation", tri_str(key));
      } else {
        hull.push_back(tri);
      }
    });
  }
  if (!problem.empty()) return fail(problem);
  std::vector<Tri> frozen;
  frozen.reserve(in.frozen_faces.size());
  for (const Tri& f : in.frozen_faces) frozen.push_back(canonical(f));
  std::sort(hull.begin(), hull.end());
  std::sort(frozen.begin(), frozen.end());
  if (hull != frozen) {
    std::vector<Tri> extra, missing;
    std::set_difference(hull.begin(), hull.end(), frozen.begin(), frozen.end(), std::back_inserter(extra));
    std::set_difference(frozen.begin(), frozen.end(), hull.begin(), hull.end(), std::back_inserter(missing));
    return fail(fmt::format("its hull has {} faces, the frozen hull {}: {} faces not frozen (first {}), {} frozen "
                            "faces missing (first {})",
                            hull.size(), frozen.size(), extra.size(), extra.empty() ? "-" : tri_str(extra[0]),
                            missing.size(), missing.empty() ? "-" : tri_str(missing[0])));
  }
  return {};
}

std::uint64_t leaf_output_byte_limit(const LeafTaskInput& in, const SizingField& sizing) {
  constexpr double kCap = 4611686018427387904.0;  // 2^62
  Box box;
  for (const Vec3& p : in.points) box.add(p);
  const double h = sizing.lower_bound(box);
  if (!(h > 0)) return static_cast<std::uint64_t>(kCap);
  const double r = 0.2 * h;
  double volume = 1;
  for (int a = 0; a < 3; ++a) volume *= box.hi[a] - box.lo[a] + 2 * r;
  const double new_points = volume / (4.0 / 3.0 * std::numbers::pi * r * r * r);
  const double points = static_cast<double>(in.points.size()) + new_points;
  // Header and counts, then 4 doubles a new point (its size too), 4 u32 a tet, a u32 and 3 doubles a move.
  const double bytes = 72 + 32 * new_points + 16 * 12 * points + 28 * static_cast<double>(in.points.size());
  return static_cast<std::uint64_t>(std::min(std::ceil(bytes), kCap));
}

Result<TetMesh> leaf_tet_mesh(const LeafTaskInput& in) {
  VolumeMesh v;
  v.points = in.points;
  v.tets = in.tets;
  v.boundary = in.frozen_faces;
  v.boundary_ids = in.frozen_ids;
  std::vector<GlobalId> ids(in.points.size());
  for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = i;
  return TetMesh::from_volume_mesh(v, std::move(ids), static_cast<GlobalId>(in.points.size()));
}

LeafTaskOutput leaf_output_from(const LeafTaskInput& in, const TetMesh& mesh) {
  LeafTaskOutput out;
  out.leaf = in.leaf;
  out.input_points = static_cast<std::uint32_t>(in.points.size());
  out.new_points.assign(mesh.points().begin() + static_cast<std::ptrdiff_t>(in.points.size()),
                        mesh.points().end());
  out.tets.reserve(mesh.num_tets());
  for (Index t = 0; t < mesh.num_slots(); ++t)
    if (mesh.alive(t)) out.tets.push_back(mesh.tet(t));
  for (Index v = 0; v < in.points.size(); ++v) {
    if (mesh.point(v) != in.points[v]) {
      out.moved.push_back(v);
      out.moved_to.push_back(mesh.point(v));
    }
  }
  return out;
}

Result<LeafTaskOutput> run_leaf_kernel(const LeafKernel& kernel, const LeafTaskInput& in,
                                       const SizingField& sizing) {
  try {
    return kernel.run(in, sizing);
  } catch (const std::bad_alloc&) {
    return resource_exhausted(fmt::format("out of memory while refining ({} kernel, {} input tets, {} points)",
                                          kernel.name(), in.tets.size(), in.points.size()));
  } catch (const std::exception& e) {
    return internal_error(fmt::format("{} kernel: unexpected error: {}", kernel.name(), e.what()));
  }
}

Result<std::string> run_leaf_task(const LeafKernel& kernel, std::string_view input, const SizingField& sizing) {
  try {
    PDR_ASSIGN_OR_RETURN(LeafTaskInput in, LeafTaskInput::decode(input));
    PDR_ASSIGN_OR_RETURN(LeafTaskOutput out, run_leaf_kernel(kernel, in, sizing));
    return out.encode();
  } catch (const std::bad_alloc&) {  // decoding or encoding
    return resource_exhausted(fmt::format("out of memory while refining ({} kernel, {} input bytes)", kernel.name(),
                                          input.size()));
  }
}

bool is_kernel_failure(const Status& s) {
  return s.code() == StatusCode::kInternal || s.code() == StatusCode::kDeadlineExceeded;
}

}  // namespace pdrmesh
