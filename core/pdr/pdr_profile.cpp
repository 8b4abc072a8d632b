// SPDX-License-Identifier: AGPL-3.0-or-later
// PDR profile files and the projected scaling of a recorded run (see pdr_profile.hpp).
#include "pdrmesh/pdr_profile.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <utility>

#include "pdrmesh/decomposition.hpp"
#include "pdrmesh/schedule_replay.hpp"

namespace pdrmesh {

namespace {

using nlohmann::json;

/// The phase fields of PdrProfile, by name (one table for writing and reading).
template <class P>
auto phase_fields(P& p) {
  return std::to_array<std::pair<const char*, decltype(&p.total)>>({
      {"initial", &p.initial},
      {"decomposition", &p.decomposition},
      {"fixups", &p.fixups},
      {"partition_swap", &p.partition_swap},
      {"boundary_extraction", &p.boundary_extraction},
      {"leaves", &p.leaves},
      {"merge", &p.merge},
      {"interface_round", &p.interface_round},
      {"optimization", &p.optimization},
      {"optimization_leaves", &p.optimization_leaves},
      {"task_busy", &p.task_busy},
      {"total", &p.total},
  });
}

/// Phases added later (around the engine); optional when read, for older files.
template <class P>
auto outer_phase_fields(P& p) {
  return std::to_array<std::pair<const char*, decltype(&p.total)>>({
      {"global_optimization", &p.global_optimization},
      {"read", &p.read},
      {"surface_check", &p.surface_check},
      {"background", &p.background},
      {"sizing", &p.sizing},
      {"overlapped", &p.overlapped},
      {"validation", &p.validation},
      {"write", &p.write},
      {"quality", &p.quality},
      {"wall", &p.wall},
      {"cpu", &p.cpu},
      {"task_cpu", &p.task_cpu},
  });
}

}  // namespace

std::string profile_to_json(const PdrProfile& p, std::size_t workers) {
  json j;
  j["version"] = 1;
  j["workers"] = workers;
  j["depth"] = p.depth;
  if (p.requested_depth >= 0) j["requested_depth"] = p.requested_depth;
  j["initial_tets"] = p.initial_tets;
  j["final_tets"] = p.final_tets;
  j["failed_leaves"] = p.failed_leaves;
  j["threads"] = p.threads;
  json phases = json::object();
  for (const auto& [name, field] : phase_fields(p)) phases[name] = *field;
  for (const auto& [name, field] : outer_phase_fields(p)) phases[name] = *field;
  j["phases"] = std::move(phases);
  json rounds = json::array();
  for (const RoundRecord& r : p.rounds) {
    rounds.push_back({{"name", r.name}, {"depth", r.depth}, {"leaves", r.leaves}, {"n1", r.n1},
                      {"rank", r.rank}, {"task_s", r.task_s}, {"wall_s", r.wall_s},
                      {"tets", r.tets}, {"tets_sent", r.tets_sent}});
  }
  j["rounds"] = std::move(rounds);
  return j.dump();
}

Result<PdrProfile> profile_from_json(std::string_view text) {
  const json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return invalid_input("profile: not a JSON object");
  if (j.value("version", 0) != 1) return invalid_input("profile: missing or unknown \"version\" (expected 1)");
  PdrProfile p;
  try {
    p.depth = j.at("depth").get<int>();
    p.requested_depth = j.value("requested_depth", -1);
    p.initial_tets = j.at("initial_tets").get<std::size_t>();
    p.final_tets = j.at("final_tets").get<std::size_t>();
    p.failed_leaves = j.value("failed_leaves", std::size_t{0});
    p.threads = j.value("threads", std::size_t{0});
    const json& phases = j.at("phases");
    for (const auto& [name, field] : phase_fields(p)) *field = phases.at(name).get<double>();
    for (const auto& [name, field] : outer_phase_fields(p)) *field = phases.value(name, 0.0);
    for (const json& r : j.at("rounds")) {
      RoundRecord rec;
      rec.name = r.at("name").get<std::string>();
      rec.depth = r.at("depth").get<int>();
      rec.leaves = r.at("leaves").get<std::vector<LeafId>>();
      rec.n1 = r.at("n1").get<std::vector<std::vector<Index>>>();
      rec.rank = r.at("rank").get<std::vector<Index>>();
      rec.task_s = r.at("task_s").get<std::vector<double>>();
      rec.wall_s = r.at("wall_s").get<double>();
      rec.tets = r.value("tets", std::size_t{0});
      rec.tets_sent = r.value("tets_sent", std::size_t{0});
      const std::size_t n = rec.leaves.size();
      if (rec.n1.size() != n || rec.rank.size() != n || rec.task_s.size() != n)
        return invalid_input(fmt::format("profile: round '{}' lists {} leaves but {} n1, {} rank, {} task_s entries",
                                         rec.name, n, rec.n1.size(), rec.rank.size(), rec.task_s.size()));
      if (rec.depth < 0 || rec.depth > kMaxDepth)
        return invalid_input(fmt::format("profile: round '{}' has depth {}", rec.name, rec.depth));
      for (std::size_t l = 0; l < n; ++l)
        for (Index m : rec.n1[l])
          if (m >= n || m == l)
            return invalid_input(fmt::format("profile: round '{}': leaf {} has neighbour {} (of {} leaves)",
                                             rec.name, l, m, n));
      p.rounds.push_back(std::move(rec));
    }
  } catch (const json::exception& e) {
    return invalid_input(fmt::format("profile: {}", e.what()));
  }
  return p;
}

double serial_seconds(const PdrProfile& p) {
  double rounds = 0;
  for (const RoundRecord& r : p.rounds) rounds += r.wall_s;
  return std::max(0.0, (p.wall > 0 ? p.wall : p.total) - rounds);
}

double SerialModel::at(std::size_t cores) const {
  const double p = static_cast<double>(std::max<std::size_t>(cores, 1));
  return initial_s + serial_s + parallel_s / p;
}

SerialModel serial_model(const PdrProfile& p) {
  SerialModel m;
  const double outside_wall = serial_seconds(p);
  if (p.cpu <= 0 || p.threads < 2) {
    m.serial_s = outside_wall;
    return m;
  }
  m.initial_s = std::min(p.initial + p.background, outside_wall);
  const double wall = std::max(0.0, outside_wall - m.initial_s);
  const double cpu = std::max(0.0, p.cpu - p.task_cpu - p.initial - p.background);
  const double t = static_cast<double>(p.threads);
  m.parallel_s = std::clamp((cpu - wall) * t / (t - 1), 0.0, cpu);
  m.serial_s = cpu - m.parallel_s;
  return m;
}

Result<RoundRecord> refine_round(const RoundRecord& r, int k) {
  if (k == 0) return r;
  if (k < 0 || r.depth + k > kMaxDepth)
    return invalid_input(fmt::format("cannot refine a depth {} round by {} levels (at most {})", r.depth, k, kMaxDepth));
  const int depth = r.depth + k;
  const std::uint32_t m = 1u << k;
  const std::uint32_t n = 1u << depth;
  // Children in parent rank order, each parent's children in grid order.
  std::vector<Index> by_rank(r.leaves.size());
  for (Index l = 0; l < r.leaves.size(); ++l) by_rank[l] = l;
  std::stable_sort(by_rank.begin(), by_rank.end(), [&](Index a, Index b) { return r.rank[a] < r.rank[b]; });
  struct Child {
    LeafId id;
    Index order;
    double s;
  };
  std::vector<Child> children;
  const double share = 1.0 / static_cast<double>(m * m * m);
  for (Index l : by_rank) {
    const auto c = leaf_coords(r.leaves[l], r.depth);
    for (std::uint32_t z = 0; z < m; ++z)
      for (std::uint32_t y = 0; y < m; ++y)
        for (std::uint32_t x = 0; x < m; ++x) {
          const LeafId id = (c[0] * m + x) + n * ((c[1] * m + y) + n * (c[2] * m + z));
          children.push_back({id, static_cast<Index>(children.size()), r.task_s[l] * share});
        }
  }
  std::sort(children.begin(), children.end(), [](const Child& a, const Child& b) { return a.id < b.id; });
  RoundRecord out;
  out.name = r.name;
  out.depth = depth;
  out.wall_s = r.wall_s;
  for (const Child& c : children) {
    out.leaves.push_back(c.id);
    out.rank.push_back(c.order);
    out.task_s.push_back(c.s);
  }
  out.n1 = grid_n1(out.leaves, depth);
  return out;
}

ProjectedRun project_run(const std::vector<RoundRecord>& rounds, const SerialModel& outside, std::size_t workers) {
  ProjectedRun p;
  p.workers = std::max<std::size_t>(workers, 1);
  double one = outside.at(1);
  for (const RoundRecord& r : rounds) {
    const ReplayResult rr = replay_schedule(r.n1, r.task_s, p.workers, SchedulePolicy::kDynamic, {}, r.rank);
    p.leaf_total_s += rr.total_s;
    p.leaf_makespan_s += rr.makespan_s;
    one += rr.total_s;
  }
  p.leaf_speedup = p.leaf_makespan_s > 0 ? p.leaf_total_s / p.leaf_makespan_s : 1.0;
  p.run_s = outside.at(p.workers) + p.leaf_makespan_s;
  p.run_speedup = p.run_s > 0 ? one / p.run_s : 1.0;
  return p;
}

}  // namespace pdrmesh
