// SPDX-License-Identifier: AGPL-3.0-or-later
// Final optimization (optimize.hpp): validate() and the driver, which runs the passes
// of Optimizer (optimizer.hpp) in order: sweeps of reconnection, sliver insertion and
// smoothing, then the polishing, repair, cap, margin, absorption and size passes. Each
// pass only takes changes that keep the mesh valid and its worst tets no worse.
#include "pdrmesh/optimize.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <span>
#include <vector>

#include "optimizer.hpp"
#include "pdrmesh/stopwatch.hpp"

namespace pdrmesh {

std::string outcome_summary(const OptimizeStats& stats) {
  static constexpr std::array<const char*, OptimizeStats::kOperationKinds> kKinds{"flips", "insertions", "removals",
                                                                                "collapses", "moves"};
  std::string out;
  for (std::size_t k = 0; k < kKinds.size(); ++k) {
    const auto& row = stats.tried[k];
    std::size_t total = 0;
    for (std::size_t n : row) total += n;
    if (total == 0) continue;
    out += fmt::format("{}{} {} done", out.empty() ? "" : "; ", kKinds[k], row[0]);
    for (std::size_t o = 1; o < kOutcomeCount; ++o)
      if (row[o] > 0) out += fmt::format(", {} {}", row[o], to_string(static_cast<Outcome>(o)));
  }
  return out.empty() ? "no operations tried" : out;
}

Status validate(const OptimizeOptions& o) {
  const auto bad = [](const char* name, double v) {
    return invalid_input(fmt::format("optimize option {} = {} is out of range", name, v));
  };
  if (!std::isfinite(o.target_min_dihedral) || o.target_min_dihedral < 0)
    return bad("target_min_dihedral", o.target_min_dihedral);
  if (!std::isfinite(o.target_max_dihedral) || o.target_max_dihedral > 180 ||
      o.target_max_dihedral <= o.target_min_dihedral)
    return bad("target_max_dihedral", o.target_max_dihedral);
  if (o.sweeps < 0) return bad("sweeps", o.sweeps);
  if (o.repair_cycles < 0) return bad("repair_cycles", o.repair_cycles);
  return Status{};
}

namespace optimize_detail {
namespace {

/// How often a stage of a schedule runs its round. After each round the
/// driver takes the bad tets again (Optimizer::bad_tets).
enum class Repeat {
  kOnce,                ///< one round
  kUntilSettled,        ///< up to `most` rounds while tets are bad, until a round changes nothing
  kWhileInteriorFalls,  ///< up to `most` rounds while the bad tets with no fixed point get fewer
  kWhileFewerLately,    ///< up to `most` rounds while one of the last kAbsorbPatience found fewer of them
};

/// One line of a schedule: a pass, or a cycle of passes, and its repeat policy.
struct Stage {
  const char* name;
  Repeat repeat;
  int most;                           ///< most rounds (kOnce: 1)
  int* rounds;                        ///< counts the rounds run (OptimizeStats), or null
  std::function<bool()> when;         ///< whether the stage runs at all (asked as it comes)
  std::function<std::size_t()> round;  ///< one round; returns the changes it made
};

/// One optimize() call: the optimizer, the bad tets the last round left, and
/// the repeat policies of Stage.
class Driver {
 public:
  Driver(TetMesh& mesh, const SizingField* sizing, const OptimizeOptions& o, OptimizeStats& st)
      : mesh_(mesh), opt(mesh, sizing, o, st), bad(opt.bad_tets()) {}

  /// Runs the stages in order; in a debug build, checks the mesh after every round.
  Status run(std::span<const Stage* const> schedule) {
    for (const Stage* s : schedule) PDR_TRY(run(*s));
    return Status{};
  }

  Status run(const Stage& s) {
    if (s.when && !s.when()) return Status{};
    std::size_t inner = opt.interior(bad).size(), fewest = inner;
    for (int r = 0, stale = 0; r < s.most; ++r) {
      if ((s.repeat == Repeat::kUntilSettled && bad.empty()) ||
          (s.repeat == Repeat::kWhileInteriorFalls && inner == 0) ||
          (s.repeat == Repeat::kWhileFewerLately && (stale >= kAbsorbPatience || fewest == 0)))
        break;
      if (s.rounds != nullptr) ++*s.rounds;
      opt.start_sweep();
      const std::size_t changes = s.round();
      bad = opt.bad_tets();
#ifndef NDEBUG
      if (Status c = mesh_.check(); !c.ok()) return internal_error(fmt::format("after {}: {}", s.name, c.message()));
#endif
      const std::size_t now = s.repeat == Repeat::kUntilSettled ? 0 : opt.interior(bad).size();
      if (s.repeat == Repeat::kUntilSettled && changes == 0) {
        settled = true;
        break;
      }
      if (s.repeat == Repeat::kWhileInteriorFalls) {
        if (now >= inner) break;
        inner = now;
      }
      stale = now < fewest ? 0 : stale + 1;
      fewest = std::min(fewest, now);
    }
    return Status{};
  }

  TetMesh& mesh_;
  Optimizer opt;
  std::vector<Index> bad;  ///< the bad tets after the last round
  bool settled = false;    ///< a sweep changed nothing
};

}  // namespace
}  // namespace optimize_detail

Result<OptimizeStats> optimize(TetMesh& mesh, const SizingField* sizing,
                               const OptimizeOptions& options) {
  using namespace optimize_detail;  // Driver, Stage and the round counts (tuning.hpp)
  PDR_TRY(validate(options));
  const auto clock_start = std::chrono::steady_clock::now();
  const OptimizeOptions& o = options;
  OptimizeStats st;
  Driver d(mesh, sizing, o, st);
  Optimizer& opt = d.opt;
  const AngleRange before = opt.angles();
  st.min_dihedral_before = before.min;
  st.max_dihedral_before = before.max;
  st.bad_before = d.bad.size();

  // The passes (optimize.hpp, Steps), each one round of its stage.
  const auto sweep = [&] {  // 1. 2. 3.
    std::size_t changes = opt.reconnect(std::move(d.bad));
    changes += opt.insert_into_slivers();
    return o.smooth ? changes + opt.smooth() : changes;
  };
  const auto polish_round = [&] {  // 1. and 3. on the interior bad tets alone
    return opt.reconnect(opt.interior(d.bad)) + opt.smooth({.interior_only = true, .pin_fixed = o.polish_pins_fixed});
  };
  double floor = 0.0;  // the repair rounds' floor for tets with a surface point, set as they begin
  const auto repair_round = [&] {  // 4.
    Optimizer::RepairCriterion criterion(opt, floor);
    const std::size_t done = opt.repair_flips(opt.interior(d.bad), criterion, {.insert = true});
    return o.smooth ? done + opt.smooth({.interior_only = true, .pin_fixed = true, .pin_floor = floor}) : done;
  };
  const Stage repair_rounds{"repair round", Repeat::kWhileInteriorFalls, kRepairRounds, &st.repair_rounds, {},
                            repair_round};
  const auto repair = [&]() -> std::size_t {  // 4. as a whole: the floor, then the rounds
    opt.find_fixed();
    floor = opt.repair_floor();
    (void)d.run(repair_rounds);
    return 0;
  };
  const auto absorb_cycle = [&] {  // 10.
    std::size_t done = opt.absorb(opt.interior(d.bad));
    d.bad = opt.bad_tets();
    repair();
    return done + opt.polish_margins(kFineSearchEnd, /*extremes=*/true, kAbsorbRingLayers);
  };
  const bool margins = o.smooth && o.polish_margins;
  const bool repairs = o.interior_repair;
  const auto swept = [&] { return st.sweeps_run > 0; };
  const auto once = [](const char* name, std::function<bool()> when, std::function<std::size_t()> round) {
    return Stage{name, Repeat::kOnce, 1, nullptr, std::move(when), std::move(round)};
  };

  const Stage sweeps{"sweep", Repeat::kUntilSettled, o.sweeps, &st.sweeps_run, {}, sweep};
  const Stage polishing{"polish round", Repeat::kWhileInteriorFalls, kPolishRounds, &st.polish_rounds,
                        [&] { return o.smooth && swept() && !d.settled; }, polish_round};
  const Stage repairing = once("repair rounds", [&] { return repairs && swept(); }, repair);
  const Stage caps = once("cap repair", [&] { return o.repair_caps; },
                          [&] { return opt.repair_caps(false) + opt.repair_caps(true); });
  const Stage angles = once("angle polish", [&] { return o.smooth && o.polish_angles; },
                            [&] { return opt.polish_angles(); });
  const Stage margin = once("margin polish", [&] { return margins; }, [&] { return opt.polish_margins(); });
  const Stage cycles{"repair cycle", Repeat::kWhileInteriorFalls, o.repair_cycles, &st.repair_cycles,
                     [&] { return repairs && swept() && margins; }, [&] { return repair() + opt.polish_margins(); }};
  const Stage fine = once("fine margin polish", [&] { return margins && !opt.interior(d.bad).empty(); },
                          [&] { return opt.polish_margins(kFineSearchEnd); });
  const Stage absorption{"absorption", Repeat::kWhileFewerLately, kAbsorbCycles, &st.absorb_cycles,
                         [&] { return repairs && swept() && margins && o.absorb && o.surface_room; }, absorb_cycle};
  const Stage late_caps = once("late caps", [&] { return o.repair_caps && o.late_caps; },
                               [&] { return opt.repair_caps(true); });
  const auto size_polish = [&](bool room) {
    return once("size polish", [&] { return o.smooth && o.polish_sizes && sizing != nullptr; },
                [&opt, room] { return opt.polish_sizes(room); });
  };
  const Stage sizes = size_polish(o.surface_room), sizes_no_room = size_polish(false);

  // The schedules: the whole mesh's, and a parallel leaf task's, whose
  // extremes are not the mesh's (so no absorption and no room for the tets
  // with a surface point) and whose caps the merged mesh does not need again.
  const Stage* const whole_mesh[] = {&sweeps, &polishing, &repairing, &caps, &angles, &margin,
                                     &cycles, &fine,      &absorption, &late_caps, &sizes};
  const Stage* const leaf_task[] = {&sweeps, &polishing, &repairing, &caps, &angles,
                                    &margin, &cycles,    &fine,      &sizes_no_room};
  if (o.schedule == OptimizeOptions::Schedule::kLeafTask) {
    PDR_TRY(d.run(leaf_task));
  } else {
    PDR_TRY(d.run(whole_mesh));
  }

  st.bad_after = d.bad.size();
  if (st.points_removed + st.edges_collapsed > 0 && !options.keep_point_indices) mesh.remove_unused_points();
  const AngleRange after = opt.angles();
  st.min_dihedral_after = after.min;
  st.max_dihedral_after = after.max;
  st.seconds = seconds_since(clock_start);
  return st;
}

}  // namespace pdrmesh
