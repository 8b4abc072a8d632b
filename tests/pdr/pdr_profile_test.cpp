// SPDX-License-Identifier: AGPL-3.0-or-later
// PDR profile files and the projected scaling: JSON round trip, rejection of
// bad files, deeper synthetic rounds, and the projection's bounds.
#include "pdrmesh/pdr_profile.hpp"

#include <gtest/gtest.h>

#include <numeric>

#include "pdrmesh/decomposition.hpp"

namespace pdrmesh {
namespace {

/// A round over a full 4 x 4 x 4 grid (depth 2) with unequal task times.
RoundRecord full_round() {
  RoundRecord r;
  r.name = "refinement";
  r.depth = 2;
  for (LeafId id = 0; id < 64; ++id) {
    r.leaves.push_back(id);
    r.task_s.push_back(0.5 + 0.01 * static_cast<double>((id * 37) % 17));
    r.rank.push_back(63 - id);
  }
  r.n1 = grid_n1(r.leaves, 2);
  r.wall_s = 20;
  return r;
}

PdrProfile sample_profile() {
  PdrProfile p;
  p.depth = 2;
  p.initial_tets = 1000;
  p.final_tets = 50000;
  p.initial = 1.5;
  p.merge = 0.25;
  p.total = 50;
  p.task_busy = 40;
  p.rounds = {full_round(), full_round()};
  p.rounds[1].name = "interface round";
  return p;
}

TEST(PdrProfile, JsonRoundTrips) {
  const PdrProfile p = sample_profile();
  Result<PdrProfile> back = profile_from_json(profile_to_json(p, 2));
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->depth, 2);
  EXPECT_EQ(back->final_tets, 50000u);
  EXPECT_EQ(back->initial, 1.5);
  EXPECT_EQ(back->total, 50.0);
  ASSERT_EQ(back->rounds.size(), 2u);
  EXPECT_EQ(back->rounds[1].name, "interface round");
  EXPECT_EQ(back->rounds[0].n1, p.rounds[0].n1);
  EXPECT_EQ(back->rounds[0].task_s, p.rounds[0].task_s);
  EXPECT_EQ(back->rounds[0].rank, p.rounds[0].rank);
  EXPECT_EQ(profile_to_json(*back, 2), profile_to_json(p, 2));
  EXPECT_EQ(back->requested_depth, -1);  // not written when the run went as deep as asked
  PdrProfile shallower = p;
  shallower.requested_depth = 5;
  Result<PdrProfile> back5 = profile_from_json(profile_to_json(shallower, 2));
  ASSERT_TRUE(back5.ok()) << back5.status().to_string();
  EXPECT_EQ(back5->requested_depth, 5);
  EXPECT_DOUBLE_EQ(serial_seconds(*back), 10.0);  // total less the rounds' wall time
  PdrProfile short_run = p;
  short_run.total = 30;
  EXPECT_DOUBLE_EQ(serial_seconds(short_run), 0.0);
}

TEST(PdrProfile, WholeRunPhasesRoundTripAndSetTheSerialShare) {
  PdrProfile p = sample_profile();
  p.read = 0.5;
  p.sizing = 2;
  p.validation = 3;
  p.wall = 58;  // the engine's 50 s and 8 s around it
  Result<PdrProfile> back = profile_from_json(profile_to_json(p, 2));
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->read, 0.5);
  EXPECT_EQ(back->validation, 3.0);
  EXPECT_EQ(back->wall, 58.0);
  EXPECT_DOUBLE_EQ(serial_seconds(*back), 18.0);  // the wall less the rounds' 40 s
  // A file without the whole-run phases (written before they existed) still reads.
  std::string old = profile_to_json(sample_profile(), 2);
  for (const char* name : {"\"read\":", "\"wall\":"}) {
    const std::size_t at = old.find(name);
    ASSERT_NE(at, std::string::npos) << name;
    old.erase(at, old.find(',', at) + 1 - at);
  }
  Result<PdrProfile> older = profile_from_json(old);
  ASSERT_TRUE(older.ok()) << older.status().to_string();
  EXPECT_EQ(older->wall, 0.0);
  EXPECT_DOUBLE_EQ(serial_seconds(*older), 10.0);
}

TEST(PdrProfile, TheWorkOutsideTheTasksSplitsIntoInitialSerialAndParallel) {
  PdrProfile p = sample_profile();
  p.wall = 61;  // 21 s outside the rounds' 40 s
  p.initial = 4;
  p.background = 3;
  p.threads = 2;
  p.task_cpu = 70;
  // Besides the initial mesh (TetGen, then the seeds: 7 s), 14 s of wall and
  // 26 CPU seconds: 2 s serial and 24 s of parallel work on 2 threads.
  p.cpu = 70 + 4 + 3 + 26;
  Result<PdrProfile> back = profile_from_json(profile_to_json(p, 2));
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->threads, 2u);
  EXPECT_EQ(back->cpu, p.cpu);
  EXPECT_EQ(back->task_cpu, 70.0);
  const SerialModel m = serial_model(*back);
  EXPECT_DOUBLE_EQ(m.initial_s, 7.0);
  EXPECT_NEAR(m.serial_s, 2.0, 1e-9);
  EXPECT_NEAR(m.parallel_s, 24.0, 1e-9);
  EXPECT_NEAR(m.at(1), 7 + 2 + 24, 1e-9);
  EXPECT_NEAR(m.at(2), 21.0, 1e-9);  // what was measured
  EXPECT_NEAR(m.at(16), 7 + 2 + 1.5, 1e-9);
  // Without CPU figures, all of it is serial.
  p.cpu = 0;
  EXPECT_DOUBLE_EQ(serial_model(p).at(16), 21.0);
  EXPECT_DOUBLE_EQ(serial_model(p).at(1), 21.0);
}

TEST(PdrProfile, RejectsBadFiles) {
  EXPECT_FALSE(profile_from_json("not json").ok());
  EXPECT_FALSE(profile_from_json("{\"version\": 2}").ok());
  EXPECT_FALSE(profile_from_json("{\"version\": 1}").ok());  // fields missing
  PdrProfile p = sample_profile();
  p.rounds[0].task_s.pop_back();
  Result<PdrProfile> r = profile_from_json(profile_to_json(p, 1));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("refinement"), std::string::npos) << r.status().to_string();
  p = sample_profile();
  p.rounds[0].n1[3].push_back(64);
  EXPECT_FALSE(profile_from_json(profile_to_json(p, 1)).ok());
}

TEST(PdrProfile, DeeperRoundsKeepTheWorkAndGiveEightTimesTheLeaves) {
  const RoundRecord r = full_round();
  Result<RoundRecord> f = refine_round(r, 1);
  ASSERT_TRUE(f.ok()) << f.status().to_string();
  EXPECT_EQ(f->depth, 3);
  ASSERT_EQ(f->leaves.size(), 8 * r.leaves.size());
  EXPECT_TRUE(std::is_sorted(f->leaves.begin(), f->leaves.end()));
  EXPECT_NEAR(std::accumulate(f->task_s.begin(), f->task_s.end(), 0.0),
              std::accumulate(r.task_s.begin(), r.task_s.end(), 0.0), 1e-9);
  EXPECT_EQ(f->n1, grid_n1(f->leaves, 3));
  // Ranks: a permutation; the children of the parent ranked first come first.
  std::vector<Index> sorted = f->rank;
  std::sort(sorted.begin(), sorted.end());
  for (Index i = 0; i < sorted.size(); ++i) EXPECT_EQ(sorted[i], i);
  const auto parent_of_first = std::find(f->rank.begin(), f->rank.end(), Index{0}) - f->rank.begin();
  const auto c = leaf_coords(f->leaves[static_cast<std::size_t>(parent_of_first)], 3);
  EXPECT_EQ(c[0] / 2 + 4 * (c[1] / 2 + 4 * (c[2] / 2)), 63u);  // rank 0 was leaf 63
  EXPECT_FALSE(refine_round(r, kMaxDepth).ok());
}

TEST(PdrProfile, ProjectionIsBoundedByWorkersAndAmdahl) {
  const PdrProfile p = sample_profile();
  const double serial = 5;
  const ProjectedRun one = project_run(p.rounds, SerialModel{.serial_s = serial}, 1);
  EXPECT_NEAR(one.leaf_speedup, 1.0, 1e-12);
  EXPECT_NEAR(one.run_speedup, 1.0, 1e-12);
  EXPECT_NEAR(one.run_s, serial + one.leaf_total_s, 1e-9);
  double last = 0;
  for (std::size_t w : {2u, 4u, 8u, 16u}) {
    const ProjectedRun r = project_run(p.rounds, SerialModel{.serial_s = serial}, w);
    EXPECT_LE(r.leaf_speedup, static_cast<double>(w) + 1e-9) << w;
    EXPECT_GE(r.leaf_speedup, 1.0) << w;
    EXPECT_LE(r.run_speedup, (serial + r.leaf_total_s) / serial) << w;  // Amdahl
    EXPECT_LE(r.run_speedup, r.leaf_speedup + 1e-9) << w;
    EXPECT_GE(r.run_speedup, last - 1e-9) << w;
    last = r.run_speedup;
  }
  // A 4^3 grid holds at most 8 disjoint lock sets ({L} and its 26 neighbours).
  EXPECT_LE(project_run(p.rounds, SerialModel{}, 64).leaf_speedup, 8.0 + 1e-9);
}

}  // namespace
}  // namespace pdrmesh
