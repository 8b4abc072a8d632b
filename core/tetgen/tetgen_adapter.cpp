// SPDX-License-Identifier: AGPL-3.0-or-later
// TetGen adapter (see tetgen_adapter.hpp): starts the helper program
// pdrmesh-tetgen (tetgen_child.cpp) for each call, hands it the surface,
// receives points and tets through a pipe, validates and orients them.

#include "pdrmesh/tetgen_adapter.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <string_view>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include "pdrmesh/predicates.hpp"
#include "pdrmesh/topology.hpp"
#include "tetgen_wire.hpp"

namespace pdrmesh {
namespace {

namespace wire = tetgen_wire;

// Kept from the helper's stdout/stderr: the end of it goes into messages.
constexpr std::size_t kLogKeep = 64 * 1024;
constexpr std::size_t kLogTail = 600;

/// Owns a file descriptor.
class Fd {
 public:
  Fd() = default;
  explicit Fd(int fd) : fd_(fd) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  Fd(Fd&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
  Fd& operator=(Fd&& other) noexcept {
    reset(std::exchange(other.fd_, -1));
    return *this;
  }
  ~Fd() { reset(); }
  int get() const { return fd_; }
  void reset(int fd = -1) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = fd;
  }

 private:
  int fd_ = -1;
};

// ---------------------------------------------------------------------------
// Parent side.

struct ChildOutcome {
  std::vector<char> result;
  std::string log;
  bool timed_out = false;
  int wait_status = 0;
};

/// Reads both pipes until EOF or the deadline, then reaps the child (killing
/// it at the deadline). Always reaps: no zombie is left behind.
ChildOutcome supervise(pid_t pid, int result_r, int log_r, double time_limit_s) {
  using Clock = std::chrono::steady_clock;
  const auto deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(time_limit_s));
  ChildOutcome o;
  pollfd fds[2] = {{result_r, POLLIN, 0}, {log_r, POLLIN, 0}};
  std::vector<char> chunk(1 << 16);
  while (fds[0].fd >= 0 || fds[1].fd >= 0) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) {
      o.timed_out = true;
      break;
    }
    const int n = ::poll(fds, 2, static_cast<int>(std::min<long long>(left + 1, INT_MAX)));
    if (n < 0) {
      if (errno == EINTR) continue;
      o.timed_out = true;  // cannot supervise: treat as a failure, kill below
      break;
    }
    for (int i = 0; i < 2; ++i) {
      if (fds[i].fd < 0 || fds[i].revents == 0) continue;
      const ssize_t r = ::read(fds[i].fd, chunk.data(), chunk.size());
      if (r < 0 && errno == EINTR) continue;
      if (r <= 0) {
        fds[i].fd = -1;  // EOF (or an error: same for us)
        continue;
      }
      if (i == 0) {
        o.result.insert(o.result.end(), chunk.data(), chunk.data() + r);
      } else {
        o.log.append(chunk.data(), static_cast<std::size_t>(r));
        if (o.log.size() > 2 * kLogKeep) o.log.erase(0, o.log.size() - kLogKeep);
      }
    }
  }
  // Pipes closed: the child is exiting; still bounded by the deadline.
  for (;;) {
    if (!o.timed_out) {
      const pid_t r = ::waitpid(pid, &o.wait_status, WNOHANG);
      if (r == pid) return o;
      if (r < 0 && errno != EINTR) return o;  // ECHILD: reaped by someone else
      if (Clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        continue;
      }
      o.timed_out = true;
    }
    ::kill(pid, SIGKILL);
    while (::waitpid(pid, &o.wait_status, 0) < 0 && errno == EINTR) {
    }
    return o;
  }
}

std::string log_tail(const std::string& log) {
  std::string_view v(log);
  while (!v.empty() && std::isspace(static_cast<unsigned char>(v.back()))) v.remove_suffix(1);
  if (v.empty()) return {};
  if (v.size() > kLogTail) v = v.substr(v.size() - kLogTail);
  std::string text(v);
  std::replace(text.begin(), text.end(), '\n', '|');
  return fmt::format("; TetGen output: \"{}\"", text);
}

Status tetgen_code_status(int code) {
  switch (code) {
    case 1: return resource_exhausted("TetGen ran out of memory (code 1)");
    case 2: return internal_error("TetGen reported an internal error (code 2)");
    case 3: return invalid_input("TetGen found self-intersecting input triangles (code 3)");
    case 4: return invalid_input("TetGen found a very small input feature size (code 4)");
    case 5: return invalid_input("TetGen found two very close input facets or points (code 5)");
    case 10: return invalid_input("TetGen found duplicated or invalid input (code 10)");
    default: return internal_error(fmt::format("TetGen failed with code {}", code));
  }
}

/// Prefixes the message with the surface name and appends the log tail.
Status decorate(const Status& s, const SurfaceMesh& surface, const std::string& log) {
  std::string where = surface.name.empty() ? std::string() : surface.name + ": ";
  return {s.code(), where + s.message() + log_tail(log)};
}

struct RawMesh {
  std::vector<Vec3> points;
  std::vector<Tet> tets;
};

/// Turns the child's bytes into a mesh, checking counts, indices and finiteness.
Result<RawMesh> parse_answer(const std::vector<char>& bytes, const TetgenOptions& options) {
  wire::AnswerHeader h;
  if (bytes.size() < sizeof h)
    return internal_error(fmt::format("TetGen's process sent {} bytes, not a complete answer", bytes.size()));
  std::memcpy(&h, bytes.data(), sizeof h);
  if (h.magic != wire::kAnswerMagic) return internal_error("TetGen's process sent a malformed answer (bad magic)");
  const std::size_t rest = bytes.size() - sizeof h;
  const char* payload = bytes.data() + sizeof h;
  switch (static_cast<wire::Answer>(h.answer)) {
    case wire::Answer::kOk: break;
    case wire::Answer::kTetgenCode: return tetgen_code_status(h.code);
    case wire::Answer::kOutOfMemory:
      return resource_exhausted(
          options.memory_limit_bytes > 0
              ? fmt::format("TetGen ran out of memory (limit {} bytes)", options.memory_limit_bytes)
              : std::string("TetGen ran out of memory"));
    case wire::Answer::kException:
      return internal_error(fmt::format("TetGen threw an exception: {}",
                                        std::string_view(payload, std::min<std::size_t>(rest, h.message_len))));
    case wire::Answer::kUnknown: return internal_error("TetGen threw an unknown exception");
    default: return internal_error(fmt::format("TetGen's process sent an unknown answer kind {}", h.answer));
  }
  // Sizes are checked against the bytes actually received before anything is allocated.
  if (h.n_points > rest / (3 * sizeof(double)) || h.n_tets > rest / (4 * sizeof(int)) ||
      h.n_points * 3 * sizeof(double) + h.n_tets * 4 * sizeof(int) != rest)
    return internal_error(fmt::format("TetGen's answer announces {} points and {} tets but holds {} bytes",
                                      h.n_points, h.n_tets, rest));
  RawMesh m;
  m.points.resize(h.n_points);
  std::memcpy(m.points.data(), payload, h.n_points * sizeof(Vec3));
  for (std::size_t i = 0; i < m.points.size(); ++i) {
    const Vec3& p = m.points[i];
    if (!is_finite(p))
      return internal_error(fmt::format("TetGen output point {} is not finite ({}, {}, {})", i, p[0], p[1], p[2]));
  }
  std::vector<std::int32_t> corners(h.n_tets * 4);
  std::memcpy(corners.data(), payload + h.n_points * sizeof(Vec3), corners.size() * sizeof(std::int32_t));
  m.tets.resize(h.n_tets);
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    for (int k = 0; k < 4; ++k) {
      const std::int32_t v = corners[4 * t + static_cast<std::size_t>(k)];
      if (v < 0 || static_cast<std::uint64_t>(v) >= h.n_points)
        return internal_error(fmt::format("TetGen output tet {} has point index {} out of range [0, {})", t, v,
                                          h.n_points));
      m.tets[t][static_cast<std::size_t>(k)] = static_cast<Index>(v);
    }
  }
  return m;
}

// ---------------------------------------------------------------------------
// Validation of the tet mesh against the input surface.

/// The same oriented triangle (up to rotation).
bool same_orientation(const Tri& a, const Tri& b) {
  for (int r = 0; r < 3; ++r)
    if (a[0] == b[r] && a[1] == b[(r + 1) % 3] && a[2] == b[(r + 2) % 3]) return true;
  return false;
}

struct FaceRecord {
  Tri key;    // sorted vertex indices
  Index tet;  // owning tet
  int local;  // 0..3: the face opposite local vertex `local` (topology.hpp)
};

/// Orients every tet positively in pdrmesh's convention. A degenerate or
/// wrongly oriented tet is an error (never silently flipped one by one).
Status orient_tets(RawMesh& m) {
  // Found by experiment (cube, corpus): TetGen 1.5 (library, -p) returns tets
  // (a, b, c, d) with signed_volume > 0, i.e. already positive here (Shewchuk's
  // orient3d < 0). The swap stays as a switch in case another TetGen differs;
  // the check below catches any tet that does not fit.
  constexpr bool kTetgenNativeIsNegative = false;
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    Tet& tet = m.tets[t];
    if (kTetgenNativeIsNegative) std::swap(tet[0], tet[1]);
    const int o = exact::orient3d(m.points[tet[0]], m.points[tet[1]], m.points[tet[2]], m.points[tet[3]]);
    if (o <= 0)
      return internal_error(fmt::format("TetGen output tet {} (points {}, {}, {}, {}) is {}", t, tet[0], tet[1],
                                        tet[2], tet[3], o == 0 ? "degenerate (zero volume)" : "inverted"));
  }
  return Status::ok_status();
}

/// Removes tets outside the surface that TetGen -p could not reach from the
/// convex hull (cavities), checks that the boundary of what remains is exactly
/// the input triangulation with matching orientation and that interior faces
/// are shared by two oppositely oriented tets, and drops unused Steiner points.
Result<VolumeMesh> build_volume_mesh(RawMesh m, const SurfaceMesh& surface) {
  const std::size_t n_in = surface.points.size();
  const std::size_t nt = m.tets.size();
  std::vector<FaceRecord> faces;
  faces.reserve(4 * nt);
  for (std::size_t t = 0; t < nt; ++t)
    for (int k = 0; k < 4; ++k) faces.push_back({topo::sorted_key(topo::face_of(m.tets[t], k)), static_cast<Index>(t), k});
  auto by_key = [](const FaceRecord& a, const FaceRecord& b) {
    return std::tie(a.key, a.tet, a.local) < std::tie(b.key, b.tet, b.local);
  };
  tbb::parallel_sort(faces.begin(), faces.end(), by_key);  // a total order: the serial sort's result

  // Input triangles sorted by key, to join with the tet faces.
  std::vector<std::pair<Tri, Index>> input(surface.triangles.size());
  for (std::size_t i = 0; i < input.size(); ++i) input[i] = {topo::sorted_key(surface.triangles[i]), static_cast<Index>(i)};
  std::sort(input.begin(), input.end());
  for (std::size_t i = 1; i < input.size(); ++i)
    if (input[i].first == input[i - 1].first)
      return invalid_input(fmt::format("triangles {} and {} have the same points ({}, {}, {})", input[i - 1].second,
                                       input[i].second, input[i].first[0], input[i].first[1], input[i].first[2]));

  std::vector<Index> neighbor(4 * nt, kNoIndex);  // across non-input faces only
  std::vector<Index> inside_of(nt, kNoIndex);     // input triangle a tet lies inside of
  std::vector<Index> seeds;                       // tets outside an input triangle
  std::size_t in_pos = 0;
  for (std::size_t g = 0; g < faces.size();) {
    std::size_t e = g;
    while (e < faces.size() && faces[e].key == faces[g].key) ++e;
    const std::size_t count = e - g;
    const Tri& key = faces[g].key;
    while (in_pos < input.size() && input[in_pos].first < key) ++in_pos;
    const bool is_input = in_pos < input.size() && input[in_pos].first == key;
    const auto face_text = [&] { return fmt::format("face ({}, {}, {}) of tet {}", key[0], key[1], key[2], faces[g].tet); };
    if (count > 2) return internal_error(fmt::format("TetGen output: {} is shared by {} tets", face_text(), count));
    if (count == 2) {
      const Tri f0 = topo::face_of(m.tets[faces[g].tet], faces[g].local);
      const Tri f1 = topo::face_of(m.tets[faces[g + 1].tet], faces[g + 1].local);
      if (!same_orientation(f0, {f1[0], f1[2], f1[1]}))
        return internal_error(fmt::format("TetGen output: {} is oriented the same way by tets {} and {} (overlap)",
                                          face_text(), faces[g].tet, faces[g + 1].tet));
    }
    if (is_input) {
      const Index tri = input[in_pos].second;
      const Tri& want = surface.triangles[tri];
      for (std::size_t r = g; r < e; ++r) {
        const bool inside = same_orientation(topo::face_of(m.tets[faces[r].tet], faces[r].local), want);
        if (inside) {
          inside_of[faces[r].tet] = tri;
        } else if (count == 1) {
          return internal_error(fmt::format(
              "TetGen output: the only tet ({}) at input triangle {} (points {}, {}, {}) lies outside the surface",
              faces[r].tet, tri, want[0], want[1], want[2]));
        } else {
          seeds.push_back(faces[r].tet);
        }
      }
    } else if (count == 2) {
      neighbor[4 * faces[g].tet + static_cast<Index>(faces[g].local)] = faces[g + 1].tet;
      neighbor[4 * faces[g + 1].tet + static_cast<Index>(faces[g + 1].local)] = faces[g].tet;
    }
    g = e;
  }
  for (const auto& [key, tri] : input) {
    auto it = std::lower_bound(faces.begin(), faces.end(), FaceRecord{key, 0, 0}, by_key);
    if (it == faces.end() || it->key != key) {
      const Tri& t = surface.triangles[tri];
      return internal_error(fmt::format(
          "TetGen output: input triangle {} (points {}, {}, {}) is not a face of any tet (boundary changed)", tri,
          t[0], t[1], t[2]));
    }
  }

  // Flood the outside from the seeds; it must never reach a tet inside.
  std::vector<char> outside(nt, 0);
  while (!seeds.empty()) {
    const Index t = seeds.back();
    seeds.pop_back();
    if (outside[t]) continue;
    if (inside_of[t] != kNoIndex) {
      const Tri& tri = surface.triangles[inside_of[t]];
      return invalid_input(fmt::format(
          "the surface's orientation is inconsistent: tet {} is both outside some triangles and inside triangle {} "
          "(points {}, {}, {}); nested bodies must be oriented away from the meshed volume",
          t, inside_of[t], tri[0], tri[1], tri[2]));
    }
    outside[t] = 1;
    for (int k = 0; k < 4; ++k)
      if (const Index n = neighbor[4 * t + static_cast<Index>(k)]; n != kNoIndex && !outside[n]) seeds.push_back(n);
  }

  // Faces with one tet must be input triangles (unless that tet was removed).
  for (std::size_t g = 0; g < faces.size();) {
    std::size_t e = g;
    while (e < faces.size() && faces[e].key == faces[g].key) ++e;
    if (e - g == 1 && !outside[faces[g].tet] &&
        !std::binary_search(input.begin(), input.end(), std::pair<Tri, Index>{faces[g].key, 0},
                            [](const auto& a, const auto& b) { return a.first < b.first; })) {
      const Tri f = topo::face_of(m.tets[faces[g].tet], faces[g].local);
      const Vec3& p = m.points[f[0]];
      return internal_error(fmt::format(
          "TetGen output: boundary face ({}, {}, {}) of tet {} is not an input triangle (near ({}, {}, {}))", f[0],
          f[1], f[2], faces[g].tet, p[0], p[1], p[2]));
    }
    g = e;
  }

  // Keep the inside tets; renumber the Steiner points they use, in order.
  std::vector<Index> new_index(m.points.size(), kNoIndex);
  for (std::size_t i = 0; i < n_in; ++i) new_index[i] = static_cast<Index>(i);
  VolumeMesh vm;
  vm.points.assign(m.points.begin(), m.points.begin() + static_cast<std::ptrdiff_t>(n_in));
  vm.tets.reserve(nt);
  for (std::size_t t = 0; t < nt; ++t) {
    if (outside[t]) continue;
    Tet tet = m.tets[t];
    for (Index& v : tet) {
      if (new_index[v] == kNoIndex) {
        new_index[v] = static_cast<Index>(vm.points.size());
        vm.points.push_back(m.points[v]);
      }
      v = new_index[v];
    }
    vm.tets.push_back(tet);
  }
  vm.boundary = surface.triangles;
  vm.boundary_ids = surface.surface_ids;
  if (vm.boundary_ids.empty()) vm.boundary_ids.assign(vm.boundary.size(), 1);
  vm.boundary_names = surface.surface_names;
  return vm;
}

Status check_input(const SurfaceMesh& s, const TetgenOptions& o) {
  if (s.points.size() < 4 || s.triangles.size() < 4)
    return invalid_input(fmt::format("a closed surface needs at least 4 points and 4 triangles, got {} and {}",
                                     s.points.size(), s.triangles.size()));
  if (s.points.size() > static_cast<std::size_t>(INT_MAX / 3) || s.triangles.size() > static_cast<std::size_t>(INT_MAX / 3))
    return unsupported(fmt::format("{} points / {} triangles exceed TetGen's int indices", s.points.size(),
                                   s.triangles.size()));
  if (!s.surface_ids.empty() && s.surface_ids.size() != s.triangles.size())
    return invalid_input(fmt::format("{} surface ids for {} triangles", s.surface_ids.size(), s.triangles.size()));
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    const Vec3& p = s.points[i];
    if (!is_finite(p))
      return invalid_input(fmt::format("point {} is not finite ({}, {}, {})", i, p[0], p[1], p[2]));
  }
  for (std::size_t i = 0; i < s.triangles.size(); ++i) {
    const Tri& t = s.triangles[i];
    for (Index v : t)
      if (v >= s.points.size())
        return invalid_input(fmt::format("triangle {} (points {}, {}, {}) refers to point {} of {}", i, t[0], t[1],
                                         t[2], v, s.points.size()));
  }
  if (o.max_volume && !(std::isfinite(*o.max_volume) && *o.max_volume > 0))
    return invalid_input(fmt::format("max_volume must be positive and finite, got {}", *o.max_volume));
  if (o.radius_edge && !(std::isfinite(*o.radius_edge) && *o.radius_edge >= 1.0))
    return invalid_input(fmt::format("radius_edge must be at least 1 (TetGen may not terminate below), got {}",
                                     *o.radius_edge));
  if (!(o.time_limit_s > 0 && o.time_limit_s < 1e9))
    return invalid_input(fmt::format("time_limit_s must be positive, got {}", o.time_limit_s));
  return Status::ok_status();
}

/// A jittered body-centred cubic lattice over a box: point (i, j, k, c) is the
/// corner (c = 0) or centre (c = 1) of cell (i, j, k), moved by a deterministic
/// jitter of up to 0.05 h per axis (which avoids the lattice's cospherical and
/// coplanar point sets). Its Delaunay tets have a volume of about h^3 / 12.
class SeedLattice {
 public:
  SeedLattice(const Box& box, double h) : box_(box), h_(h) {
    for (std::size_t k = 0; k < 3; ++k)
      n_[k] = static_cast<std::size_t>(std::ceil((box.hi[k] - box.lo[k]) / h)) + 1;
  }
  double size() const { return 2.0 * static_cast<double>(n_[0]) * static_cast<double>(n_[1]) * static_cast<double>(n_[2]); }
  std::size_t slots() const { return n_[0] * n_[1] * n_[2] * 2; }
  /// Cells along axis k.
  std::size_t cells(std::size_t k) const { return n_[k]; }
  /// Coordinate `axis` of the unjittered point of index `i` along that axis
  /// (c = 1: a cell centre); point(slot) lies within 0.05 h of it per axis.
  double nominal(std::size_t axis, std::size_t i, std::size_t c) const {
    return box_.lo[axis] + h_ * (static_cast<double>(i) + 0.5 * static_cast<double>(c));
  }
  /// The indices i along `axis` whose unjittered coordinate (sublattice c) may
  /// lie in [lo, hi]: up to `slack` h beyond it, to absorb rounding (and the
  /// jitter, for callers that test jittered points). False when there is none.
  bool index_range(std::size_t axis, double lo, double hi, std::size_t c, double slack, std::size_t& from,
                   std::size_t& to) const {
    const double shift = 0.5 * static_cast<double>(c);
    const double first = std::ceil((lo - box_.lo[axis]) / h_ - shift - slack);
    const double last = std::floor((hi - box_.lo[axis]) / h_ - shift + slack);
    const double top = static_cast<double>(n_[axis] - 1);
    if (!(first <= last) || last < 0 || first > top) return false;
    from = first <= 0 ? 0 : static_cast<std::size_t>(first);
    to = last >= top ? n_[axis] - 1 : static_cast<std::size_t>(last);
    return true;
  }
  std::size_t slot(const std::array<std::size_t, 3>& ijk, std::size_t c) const {
    return ((ijk[0] * n_[1] + ijk[1]) * n_[2] + ijk[2]) * 2 + c;
  }
  /// Whether the point of `slot` belongs to the lattice of spacing 2^k h
  /// (k >= 0) with the same origin: for k >= 1 its cell corners are the
  /// corners whose indices are multiples of 2^k, its cell centres the corners
  /// whose indices are all 2^(k-1) modulo 2^k; no centre of this lattice.
  bool on_coarser(std::size_t slot, int k) const {
    if (k == 0) return true;
    if (slot % 2 == 1) return false;
    const std::size_t cell = slot / 2, m = std::size_t{1} << k;
    const std::size_t i = cell / (n_[1] * n_[2]), j = (cell / n_[2]) % n_[1], l = cell % n_[2];
    const std::size_t r = i % m;
    return (r == 0 || r == m / 2) && j % m == r && l % m == r;
  }
  Vec3 point(std::size_t slot) const {
    const std::size_t c = slot % 2, cell = slot / 2;
    const std::array<std::size_t, 3> ijk = {cell / (n_[1] * n_[2]), (cell / n_[2]) % n_[1], cell % n_[2]};
    std::uint64_t x = slot * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull;
    Vec3 p{};
    for (std::size_t a = 0; a < 3; ++a) {
      x ^= x >> 31;
      x *= 0xBF58476D1CE4E5B9ull;
      x ^= x >> 29;
      const double jitter = (static_cast<double>(x >> 11) * 0x1.0p-53 - 0.5) * 0.1;
      p[a] = box_.lo[a] + h_ * (static_cast<double>(ijk[a]) + 0.5 * static_cast<double>(c) + jitter);
    }
    return p;
  }
  /// Calls f(slot) for every lattice point that may lie in [lo - pad, hi + pad]
  /// (its unjittered point within 0.06 h of that box: the jitter is at most 0.05 h).
  template <class F>
  void for_each_near(const Vec3& lo, const Vec3& hi, double pad, F&& f) const {
    for (std::size_t c = 0; c < 2; ++c) {
      std::array<std::size_t, 3> from{}, to{};
      bool any = true;
      for (std::size_t k = 0; k < 3; ++k) any = any && index_range(k, lo[k] - pad, hi[k] + pad, c, 0.06, from[k], to[k]);
      if (!any) continue;
      for (std::size_t i = from[0]; i <= to[0]; ++i)
        for (std::size_t j = from[1]; j <= to[1]; ++j)
          for (std::size_t k = from[2]; k <= to[2]; ++k) f(slot({i, j, k}, c));
    }
  }

 private:
  Box box_;
  double h_;
  std::array<std::size_t, 3> n_{};
};

/// Sign of orient2d(a, b, q) in the (y, z) plane for q moved by (eps, eps^2),
/// eps -> 0 (simulation of simplicity): never 0 unless a and b project to the
/// same point, and opposite for (b, a), so that a line through q crosses
/// exactly one of two triangles that share an edge or a vertex it meets.
int perturbed_orient_yz(const Vec3& a, const Vec3& b, const Vec3& q) {
  if (const int s = exact::orient2d(a, b, q, 0); s != 0) return s;
  if (a[2] != b[2]) return a[2] > b[2] ? 1 : -1;
  if (a[1] != b[1]) return b[1] > a[1] ? 1 : -1;
  return 0;
}

/// Clears keep[slot] for the lattice points outside the domain, so that TetGen
/// is not given the empty part of the bounding box (95% of the lattice on
/// frame, whose Delaunay mesh took 8 of 11 s). The kept points lie at least
/// 0.4 h from every triangle, so each is on the same side as its unjittered
/// point (within 0.09 h), which lies on a lattice row: a line parallel to x.
/// A row's crossings with the surface are found exactly (orient2d in the
/// (y, z) plane with simulated perturbation), and for each crossed triangle
/// the first point of the row beyond it by a binary search on orient3d (its
/// sign is monotone along the row). A point is inside when an odd number of
/// triangles lie before it on its row: several bodies and cavities are
/// counted right, whatever their orientation.
void drop_outside(const SurfaceMesh& s, const SeedLattice& lattice, std::vector<char>& keep) {
  const std::size_t nx = lattice.cells(0), ny = lattice.cells(1), nz = lattice.cells(2);
  const std::size_t rows = ny * nz * 2;
  const auto row_of = [&](std::size_t j, std::size_t k, std::size_t c) { return (j * nz + k) * 2 + c; };
  // Crossings as (row, triangle), rows in CSR form.
  std::vector<std::pair<std::size_t, Index>> crossings;
  for (std::size_t t = 0; t < s.triangles.size(); ++t) {
    const Vec3 &a = s.points[s.triangles[t][0]], &b = s.points[s.triangles[t][1]], &c = s.points[s.triangles[t][2]];
    const int area = exact::orient2d(a, b, c, 0);
    if (area == 0) continue;  // parallel to x: no row crosses it (only touches, which the perturbation resolves)
    Box tb;
    for (const Vec3* p : {&a, &b, &c}) tb.add(*p);
    for (std::size_t sub = 0; sub < 2; ++sub) {
      std::size_t j0 = 0, j1 = 0, k0 = 0, k1 = 0;
      if (!lattice.index_range(1, tb.lo[1], tb.hi[1], sub, 0.01, j0, j1) ||
          !lattice.index_range(2, tb.lo[2], tb.hi[2], sub, 0.01, k0, k1))
        continue;
      for (std::size_t j = j0; j <= j1; ++j)
        for (std::size_t k = k0; k <= k1; ++k) {
          const Vec3 q{0.0, lattice.nominal(1, j, sub), lattice.nominal(2, k, sub)};
          if (perturbed_orient_yz(a, b, q) == area && perturbed_orient_yz(b, c, q) == area &&
              perturbed_orient_yz(c, a, q) == area)
            crossings.emplace_back(row_of(j, k, sub), static_cast<Index>(t));
        }
    }
  }
  std::sort(crossings.begin(), crossings.end());
  std::vector<std::size_t> start(rows + 1, 0);
  for (const auto& x : crossings) ++start[x.first + 1];
  for (std::size_t r = 0; r < rows; ++r) start[r + 1] += start[r];
  // Rows are independent and write disjoint slots: any schedule gives the same keep.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rows, 64), [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<std::uint32_t> before(nx + 1);
    for (std::size_t r = range.begin(); r != range.end(); ++r) {
      const std::size_t sub = r % 2, k = (r / 2) % nz, j = r / 2 / nz;
      std::fill(before.begin(), before.end(), 0u);
      for (std::size_t x = start[r]; x < start[r + 1]; ++x) {
        const Tri& t = s.triangles[crossings[x].second];
        const Vec3 &a = s.points[t[0]], &b = s.points[t[1]], &c = s.points[t[2]];
        const auto at = [&](double px) { return Vec3{px, lattice.nominal(1, j, sub), lattice.nominal(2, k, sub)}; };
        // Past every vertex of the triangle, hence beyond where the row crosses it.
        const double far = std::max({a[0], b[0], c[0]}) + std::fabs(std::max({a[0], b[0], c[0]})) + 1.0;
        const int beyond = exact::orient3d(a, b, c, at(far));
        std::size_t lo = 0, hi = nx;  // first i whose point is beyond the triangle
        while (lo < hi) {
          const std::size_t mid = lo + (hi - lo) / 2;
          if (exact::orient3d(a, b, c, at(lattice.nominal(0, mid, sub))) == beyond)
            hi = mid;
          else
            lo = mid + 1;
        }
        ++before[lo];
      }
      std::uint32_t parity = 0;
      for (std::size_t i = 0; i < nx; ++i) {
        parity ^= before[i] & 1u;
        if (parity == 0) keep[lattice.slot({i, j, k}, sub)] = 0;
      }
    }
  });
}

/// Writes the helper's request (tetgen_wire.hpp) into an unlinked in-memory
/// file, rewound, which becomes the helper's stdin: nothing to interleave with
/// reading its answer, and nothing left on disk.
Result<Fd> write_request(const SurfaceMesh& s, const TetgenOptions& o, const std::vector<Vec3>& seeds) {
  Fd fd(::memfd_create("pdrmesh-tetgen-request", MFD_CLOEXEC));
  if (fd.get() < 0) return internal_error(fmt::format("cannot create TetGen's request file: {}", std::strerror(errno)));
  const std::string sw = tetgen_switches(o);
  wire::RequestHeader h;
  h.n_points = s.points.size() + seeds.size();
  h.n_triangles = s.triangles.size();
  h.switches_len = sw.size();
  h.memory_limit = o.memory_limit_bytes;
  h.fault = static_cast<std::uint32_t>(o.inject_fault);
  std::vector<std::int32_t> corners;
  corners.reserve(3 * s.triangles.size());
  for (const Tri& t : s.triangles)
    for (Index v : t) corners.push_back(static_cast<std::int32_t>(v));
  static_assert(sizeof(Vec3) == 3 * sizeof(double));
  if (!wire::write_all(fd.get(), &h, sizeof h) ||
      !wire::write_all(fd.get(), s.points.data(), s.points.size() * sizeof(Vec3)) ||
      !wire::write_all(fd.get(), seeds.data(), seeds.size() * sizeof(Vec3)) ||
      !wire::write_all(fd.get(), corners.data(), corners.size() * sizeof(std::int32_t)) ||
      !wire::write_all(fd.get(), sw.data(), sw.size()) || ::lseek(fd.get(), 0, SEEK_SET) != 0)
    return internal_error(fmt::format("cannot write TetGen's request: {}", std::strerror(errno)));
  return fd;
}

/// Where the helper program is: $PDRMESH_TETGEN_HELPER if set, else
/// pdrmesh-tetgen beside the running program (how it is installed), else the
/// one in the build tree (test and bench programs live in other folders).
/// Never a search of $PATH.
Result<std::string> helper_path() {
  if (const char* env = std::getenv("PDRMESH_TETGEN_HELPER"); env != nullptr && *env != '\0') {
    if (::access(env, X_OK) != 0)
      return internal_error(fmt::format("PDRMESH_TETGEN_HELPER={} is not an executable file", env));
    return std::string(env);
  }
  std::vector<std::string> tried;
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) tried.push_back((self.parent_path() / "pdrmesh-tetgen").string());
#ifdef PDRMESH_TETGEN_BUILD_PATH
  tried.emplace_back(PDRMESH_TETGEN_BUILD_PATH);
#endif
  for (const std::string& path : tried)
    if (::access(path.c_str(), X_OK) == 0) return path;
  return internal_error(fmt::format("cannot find pdrmesh-tetgen, the helper program that runs TetGen (tried {}); "
                                    "install it beside this program or set PDRMESH_TETGEN_HELPER",
                                    fmt::join(tried, ", ")));
}

/// Moves `fd` to a descriptor number of at least 10 (close-on-exec), so that
/// the helper's dup2 calls onto 0 to 3 cannot clobber one with another.
Status raise_fd(Fd& fd) {
  if (fd.get() >= 10) return Status::ok_status();
  const int moved = ::fcntl(fd.get(), F_DUPFD_CLOEXEC, 10);
  if (moved < 0) return internal_error(fmt::format("cannot move a descriptor for TetGen: {}", std::strerror(errno)));
  fd.reset(moved);
  return Status::ok_status();
}

/// Starts the helper with `request` as stdin, `log` as stdout and stderr and
/// `answer` as descriptor 3; nothing else open, default signal handling, no
/// signal blocked. posix_spawn runs no code of ours between fork and exec.
Result<pid_t> spawn_helper(const std::string& path, Fd& request, Fd& log, Fd& answer) {
  PDR_TRY(raise_fd(request));
  PDR_TRY(raise_fd(log));
  PDR_TRY(raise_fd(answer));
  posix_spawn_file_actions_t actions;
  posix_spawnattr_t attr;
  if (posix_spawn_file_actions_init(&actions) != 0) return internal_error("cannot prepare the start of TetGen's process");
  if (posix_spawnattr_init(&attr) != 0) {
    posix_spawn_file_actions_destroy(&actions);
    return internal_error("cannot prepare the start of TetGen's process");
  }
  sigset_t defaults, none;
  sigemptyset(&defaults);
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGPIPE, SIGTERM, SIGINT, SIGHUP}) sigaddset(&defaults, sig);
  sigemptyset(&none);
  int rc = posix_spawnattr_setsigdefault(&attr, &defaults);
  if (rc == 0) rc = posix_spawnattr_setsigmask(&attr, &none);
  if (rc == 0) rc = posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETSIGMASK);
  if (rc == 0) rc = posix_spawn_file_actions_adddup2(&actions, request.get(), 0);
  if (rc == 0) rc = posix_spawn_file_actions_adddup2(&actions, log.get(), 1);
  if (rc == 0) rc = posix_spawn_file_actions_adddup2(&actions, log.get(), 2);
  if (rc == 0) rc = posix_spawn_file_actions_adddup2(&actions, answer.get(), wire::kAnswerFd);
  if (rc == 0) rc = posix_spawn_file_actions_addclosefrom_np(&actions, wire::kAnswerFd + 1);
  pid_t pid = -1;
  if (rc == 0) {
    char* argv[] = {const_cast<char*>(path.c_str()), nullptr};
    rc = ::posix_spawn(&pid, path.c_str(), &actions, &attr, argv, environ);
  }
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  if (rc != 0) return internal_error(fmt::format("cannot start {}: {}", path, std::strerror(rc)));
  return pid;
}

}  // namespace

// Seeds for a dense mesh. TetGen 1.5 with -Y rejects every refinement point
// that encroaches on a boundary face, so -a alone hardly refines near coarse
// boundaries (on hinge it adds no point at all). We therefore add the points
// of a lattice over the bounding box, whose Delaunay tets have about half the
// volume bound, to TetGen's input points (after the surface's points), except
// those closer than 0.4 spacing to a triangle's plane within the triangle's
// box (no seed on or next to the boundary), and those outside the domain
// (drop_outside). (TetGen's own -i for added points crashes in TetGen 1.5 on
// some inputs, e.g. elephant, even with only interior points.)
double seed_spacing(double max_volume) { return 0.8 * std::cbrt(12.0 * max_volume); }

namespace {
/// seed_points' lattices are at most 2^this times as wide as the finest.
constexpr int kMaxCoarser = 20;
}  // namespace

Result<std::vector<Vec3>> seed_points(const SurfaceMesh& s, double max_volume,
                                      const std::function<double(const Vec3&)>& widest) {
  const double h = seed_spacing(max_volume);
  const SeedLattice lattice(s.bounds(), h);
  if (lattice.size() > 2e8)
    return resource_exhausted(fmt::format("max_volume {} asks for {:.3g} seed points over the bounding box, more "
                                          "than the supported 2e8",
                                          max_volume, lattice.size()));
  std::vector<char> keep(lattice.slots(), 1);
  const double gap = 0.4 * h;
  for (const Tri& t : s.triangles) {
    const Vec3 &a = s.points[t[0]], &b = s.points[t[1]], &c = s.points[t[2]];
    Box tb;
    for (const Vec3* p : {&a, &b, &c}) tb.add(*p);
    Vec3 normal = cross(b - a, c - a);
    const double len = norm(normal);
    normal = len > 0 ? (1.0 / len) * normal : Vec3{0, 0, 0};
    lattice.for_each_near(tb.lo, tb.hi, gap, [&](std::size_t slot) {
      if (!keep[slot]) return;
      const Vec3 p = lattice.point(slot);
      for (std::size_t q = 0; q < 3; ++q)
        if (p[q] < tb.lo[q] - gap || p[q] > tb.hi[q] + gap) return;
      if (len == 0 || std::fabs(dot(p - a, normal)) < gap) keep[slot] = 0;
    });
  }
  drop_outside(s, lattice, keep);
  if (widest) {
    // Where widest allows twice the spacing or more, the seed stays only on
    // the coarsest lattice of spacing 2^k h within it: the seeds thin out
    // level by level, each level a regular lattice.
    tbb::parallel_for(std::size_t{0}, keep.size(), [&](std::size_t slot) {
      if (!keep[slot]) return;
      const double w = widest(lattice.point(slot));
      int k = 0;
      while (k < kMaxCoarser && std::ldexp(h, k + 1) <= w) ++k;
      if (!lattice.on_coarser(slot, k)) keep[slot] = 0;
    });
  }
  std::vector<Vec3> seeds;
  for (std::size_t slot = 0; slot < keep.size(); ++slot)
    if (keep[slot]) seeds.push_back(lattice.point(slot));
  if (seeds.size() + s.points.size() > static_cast<std::size_t>(INT_MAX / 3))
    return unsupported(fmt::format("{} seed points exceed TetGen's int indices", seeds.size()));
  return seeds;
}

// Switches, letter by letter:
//   p  the input is a piecewise linear complex (our triangles), tetrahedralize
//      its interior and remove the tets outside it;
//   Y  preserve the input boundary: no Steiner point on input faces or edges
//      (boundary recovery may add interior points only);
//   z  indices start at 0;
//   Q  quiet (TetGen still prints errors; they go to the child's log pipe);
//   M  do not merge coplanar facets or close vertices: every input triangle
//      stays a face, every input point stays a point, as given;
//   J  do not jettison unused vertices: output point i is input point i;
//   F  do not produce TetGen's face list (the adapter derives the boundary);
//   q<r>  quality refinement with radius-edge ratio bound r (only if set);
//   a<v>  maximum tetrahedron volume v (only if set).
// Nothing else: in particular no -d/-r/-c/-i/-m, nothing that adds boundary
// points. Numbers are written in shortest round-trip form.
std::string tetgen_switches(const TetgenOptions& options) {
  std::string s = "pYzQMJF";
  if (options.seeds_only) return s;
  if (options.radius_edge) s += fmt::format("q{}", *options.radius_edge);
  if (options.max_volume) s += fmt::format("a{}", *options.max_volume);
  return s;
}

namespace {

/// One isolated TetGen run (see the file comment) and the validation of its output.
Result<VolumeMesh> run_tetgen(const SurfaceMesh& surface, const TetgenOptions& options,
                              const std::vector<Vec3>& seeds) {
  PDR_ASSIGN_OR_RETURN(const std::string helper, helper_path());
  PDR_ASSIGN_OR_RETURN(Fd request, write_request(surface, options, seeds));

  int result_pipe[2], log_pipe[2];
  if (::pipe2(result_pipe, O_CLOEXEC) != 0)
    return internal_error(fmt::format("cannot create a pipe for TetGen: {}", std::strerror(errno)));
  Fd result_r(result_pipe[0]), result_w(result_pipe[1]);
  if (::pipe2(log_pipe, O_CLOEXEC) != 0)
    return internal_error(fmt::format("cannot create a pipe for TetGen: {}", std::strerror(errno)));
  Fd log_r(log_pipe[0]), log_w(log_pipe[1]);

  PDR_ASSIGN_OR_RETURN(const pid_t pid, spawn_helper(helper, request, log_w, result_w));
  request.reset();
  result_w.reset();
  log_w.reset();
  ChildOutcome o = supervise(pid, result_r.get(), log_r.get(), options.time_limit_s);
  if (o.timed_out)
    return decorate(deadline_exceeded(fmt::format("TetGen did not finish within the time limit of {} s "
                                                  "(time_limit_s); its process was killed",
                                                  options.time_limit_s)),
                    surface, o.log);
  if (WIFSIGNALED(o.wait_status)) {
    const int sig = WTERMSIG(o.wait_status);
    const char* what = ::sigdescr_np(sig);
    std::string msg = fmt::format("TetGen crashed (signal {}: {})", sig, what ? what : "unknown signal");
    if (options.memory_limit_bytes > 0) msg += fmt::format(" with a memory limit of {} bytes", options.memory_limit_bytes);
    // TetGen 1.5 often crashes right after diagnosing intersecting input
    // ("Found two segments intersect each other."): that is the user's data.
    if (o.log.find("intersect") != std::string::npos)
      return decorate(invalid_input("the surface intersects itself: " + msg), surface, o.log);
    return decorate(internal_error(msg), surface, o.log);
  }
  if (!WIFEXITED(o.wait_status) || WEXITSTATUS(o.wait_status) != 0)
    return decorate(internal_error(fmt::format("TetGen's process exited with status {} without an answer",
                                               WIFEXITED(o.wait_status) ? WEXITSTATUS(o.wait_status) : -1)),
                    surface, o.log);
  Result<RawMesh> raw = parse_answer(o.result, options);
  if (!raw.ok()) return decorate(raw.status(), surface, o.log);
  RawMesh& m = raw.value();
  if (m.points.size() < surface.points.size())
    return decorate(internal_error(fmt::format("TetGen's output has {} points, fewer than the {} input points",
                                               m.points.size(), surface.points.size())),
                    surface, {});
  for (std::size_t i = 0; i < surface.points.size(); ++i) {
    if (std::memcmp(&m.points[i], &surface.points[i], sizeof(Vec3)) != 0) {
      const Vec3 &a = surface.points[i], &b = m.points[i];
      return decorate(internal_error(fmt::format("TetGen moved input point {} from ({}, {}, {}) to ({}, {}, {})", i,
                                                 a[0], a[1], a[2], b[0], b[1], b[2])),
                      surface, {});
    }
  }
  if (Status s = orient_tets(m); !s.ok()) return decorate(s, surface, {});
  Result<VolumeMesh> vm = build_volume_mesh(std::move(m), surface);
  if (!vm.ok()) return decorate(vm.status(), surface, {});
  return vm;
}

}  // namespace

Result<VolumeMesh> tetrahedralize(const SurfaceMesh& surface, const TetgenOptions& options) {
  PDR_TRY(check_input(surface, options));
  std::vector<Vec3> seeds;
  if (options.max_volume) {
    PDR_ASSIGN_OR_RETURN(seeds, seed_points(surface, *options.max_volume));
  }
  return run_tetgen(surface, options, seeds);
}

}  // namespace pdrmesh
