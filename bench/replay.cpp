// SPDX-License-Identifier: AGPL-3.0-or-later
// pdrmesh_bench_replay: projects the scaling of a recorded PDR run. Reads the
// profile that `pdrmesh run --profile-json FILE` wrote, replays every round's
// measured leaf task times on P = 1, 2, 4, ..., 1024 simulated workers under the
// lock table (kDynamic, the run's priorities; pdr_profile.hpp) and prints the
// projected leaf-schedule speedup and the whole-run speedup (the work outside
// the tasks as pdr_profile.hpp's SerialModel projects it). Not a test: it asserts nothing.
//   usage: pdrmesh_bench_replay PROFILE.json [DEEPER]
//   DEEPER (default 0): replay the rounds split DEEPER octree levels finer, a
//   synthetic stand-in for a bigger job meshed at a deeper octree.
#include <fmt/format.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "pdrmesh/pdr_profile.hpp"

int main(int argc, char** argv) {
  using namespace pdrmesh;
  if (argc < 2 || argc > 3) {
    fmt::print(stderr, "usage: {} PROFILE.json [DEEPER]\n", argv[0]);
    return 64;
  }
  std::ifstream in(argv[1], std::ios::binary);
  if (!in) {
    fmt::print(stderr, "{}: cannot open\n", argv[1]);
    return 66;
  }
  std::stringstream text;
  text << in.rdbuf();
  Result<PdrProfile> profile = profile_from_json(text.str());
  if (!profile.ok()) {
    fmt::print(stderr, "{}: {}\n", argv[1], profile.status().message());
    return 65;
  }
  const int deeper = argc == 3 ? std::atoi(argv[2]) : 0;
  std::vector<RoundRecord> rounds;
  std::size_t leaves = 0;
  for (const RoundRecord& r : profile->rounds) {
    Result<RoundRecord> f = refine_round(r, deeper);
    if (!f.ok()) {
      fmt::print(stderr, "{}\n", f.status().message());
      return 65;
    }
    leaves += f->leaves.size();
    rounds.push_back(std::move(*f));
  }
  const double serial = serial_seconds(*profile);
  const SerialModel outside = serial_model(*profile);
  fmt::print("profile {}: depth {}{}, {} final tets, {} rounds, {} leaf tasks, {:.2f} s of tasks, {:.2f} s serial "
             "(of {:.2f} s)\n",
             argv[1], profile->depth, deeper > 0 ? fmt::format(" replayed at depth {}", profile->depth + deeper) : "",
             profile->final_tets, rounds.size(), leaves, profile->task_busy, serial,
             profile->wall > 0 ? profile->wall : profile->total);
  fmt::print("outside the tasks: initial mesh {:.2f} s (serial: TetGen's boundary mesh and the seeds not left to "
             "leaf tasks), the rest {:.2f} s serial and {:.2f} CPU s parallel (from wall and CPU time on {} threads)\n",
             outside.initial_s, outside.serial_s, outside.parallel_s, profile->threads);
  fmt::print("{:>6} {:>12} {:>12} {:>10} {:>12} {:>12}\n", "P", "leaf_span_s", "leaf_speedup", "leaf_eff",
             "run_s", "run_speedup");
  for (std::size_t p = 1; p <= 1024; p *= 2) {
    const ProjectedRun r = project_run(rounds, outside, p);
    fmt::print("{:>6} {:>12.3f} {:>12.2f} {:>10.2f} {:>12.3f} {:>12.2f}\n", p, r.leaf_makespan_s, r.leaf_speedup,
               r.leaf_speedup / static_cast<double>(p), r.run_s, r.run_speedup);
  }
  return 0;
}
