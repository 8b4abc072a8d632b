// SPDX-License-Identifier: AGPL-3.0-or-later
// Final optimization (optimize.hpp): validate() and the driver, which runs the passes
// of Optimizer (optimizer.hpp) in order: sweeps of reconnection, sliver insertion and
// smoothing, then the polishing, repair, cap, margin, absorption and size passes. Each
// pass only takes changes that keep the mesh valid and its worst tets no worse.
#include "pdrmesh/optimize.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
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
  if (!std::isfinite(o.insert_min_distance) || o.insert_min_distance < 0)
    return bad("insert_min_distance", o.insert_min_distance);
  if (!std::isfinite(o.max_flips_per_tet) || !(o.max_flips_per_tet > 0))
    return bad("max_flips_per_tet", o.max_flips_per_tet);
  return Status{};
}

Result<OptimizeStats> optimize(TetMesh& mesh, const SizingField* sizing,
                               const OptimizeOptions& options) {
  using namespace optimize_detail;  // Optimizer and the round counts (tuning.hpp)
  PDR_TRY(validate(options));
  const auto clock_start = std::chrono::steady_clock::now();
  OptimizeStats st;
  Optimizer opt(mesh, sizing, options, st);

  const AngleRange before = opt.angles();
  st.min_dihedral_before = before.min;
  st.max_dihedral_before = before.max;
  std::vector<Index> bad = opt.bad_tets();
  st.bad_before = bad.size();
  bool settled = false;  // a sweep changed nothing
  for (int sweep = 0; sweep < options.sweeps && !bad.empty(); ++sweep) {
    ++st.sweeps_run;
    opt.start_sweep();
    std::size_t changes = opt.reconnect(std::move(bad));
    changes += opt.insert_into_slivers();
    if (options.smooth) changes += opt.smooth();
    bad = opt.bad_tets();
    if (changes == 0) {
      settled = true;
      break;
    }
  }
  // Runs `round` up to `rounds` times while the number of bad tets with no
  // fixed point falls (the polishing and the repair rounds).
  const auto while_interior_falls = [&](int rounds, int& count, const auto& round) {
    std::size_t inner = opt.interior(bad).size();
    for (int r = 0; r < rounds && inner > 0; ++r) {
      ++count;
      opt.start_sweep();
      round();
      bad = opt.bad_tets();
      const std::size_t now = opt.interior(bad).size();
      if (now >= inner) break;
      inner = now;
    }
  };
  // Polishing rounds: reconnection and smoothing of the bad tets with no fixed
  // point alone, while their number falls (their work is small; the full sweeps
  // spend theirs on tets next to the boundary, many beyond repair).
  if (options.smooth && st.sweeps_run > 0 && !settled) {
    while_interior_falls(kPolishRounds, st.polish_rounds, [&] {
      opt.reconnect(opt.interior(bad));
      opt.smooth({.interior_only = true, .pin_fixed = options.polish_pins_fixed});
    });
  }
  // Interior repair: flips judged by the full measure, then smoothing of the
  // vertices of the bad tets with no fixed point, where a tet with a fixed
  // point may give way down to the repair floor, while their number falls.
  const bool repair = options.interior_repair && st.sweeps_run > 0;
  const auto repair_rounds = [&] {
    opt.find_fixed();
    const double floor = opt.repair_floor();
    Optimizer::RepairCriterion criterion(opt, floor);
    while_interior_falls(kRepairRounds, st.repair_rounds, [&] {
      opt.repair_flips(opt.interior(bad), criterion, {.insert = true});
      if (options.smooth) opt.smooth({.interior_only = true, .pin_fixed = true, .pin_floor = floor});
    });
  };
  if (repair) repair_rounds();
  // Cap repair: a point into a cavity around each bad tet with two or three
  // kept faces, two of them on the surface (a flat tet on a nearly flat patch
  // of the surface). No smoothing follows (it may trade an angle near 180
  // degrees elsewhere for the worst tet of a star).
  // Then the relaxed pass (optimize.hpp, 5.): the caps the first left and the
  // flat tets of four surface points, with the new tets within [10, 165].
  if (options.repair_caps) {
    const std::size_t strict = opt.repair_caps(false);
    const std::size_t relaxed = opt.repair_caps(true);  // a statement of its own: after the first
    if (strict + relaxed > 0) bad = opt.bad_tets();
  }
  // Angle polish (optimize.hpp, 6.): the free points of the tets under the
  // smallest-angle target, raising their stars' smallest angle.
  if (options.smooth && options.polish_angles && opt.polish_angles() > 0) bad = opt.bad_tets();
  // Margin polish (optimize.hpp, 7.): the free points of the bad tets with
  // no surface point, raising their stars' worst margin to the targets.
  const bool margins = options.smooth && options.polish_margins;
  if (margins && opt.polish_margins() > 0) bad = opt.bad_tets();
  // Repair cycles (optimize.hpp, 8.): the repair rounds and the margin polish
  // again, while the bad tets with no fixed point get fewer.
  for (int cycle = 0; repair && margins && cycle < options.repair_cycles; ++cycle) {
    const std::size_t inner = opt.interior(bad).size();
    if (inner == 0) break;
    ++st.repair_cycles;
    repair_rounds();
    if (opt.polish_margins() > 0) bad = opt.bad_tets();
    if (opt.interior(bad).size() >= inner) break;
  }
  // The margin polish's last pass (optimize.hpp, 7.), with a finer search.
  if (margins && !opt.interior(bad).empty() && opt.polish_margins(kFineSearchEnd) > 0) bad = opt.bad_tets();
  // Absorption (optimize.hpp, 10.): the bad tets with no fixed point handed to
  // the tets on the surface where they can take them, then the repair rounds
  // and a margin polish within the mesh's extremes, while cycles find fewer.
  if (repair && margins && options.absorb && options.surface_room) {
    std::size_t best = opt.interior(bad).size();
    for (int cycle = 0, stale = 0; cycle < kAbsorbCycles && stale < kAbsorbPatience && best > 0; ++cycle) {
      ++st.absorb_cycles;
      opt.start_sweep();
      if (opt.absorb(opt.interior(bad)) > 0) bad = opt.bad_tets();
      repair_rounds();
      if (opt.polish_margins(kFineSearchEnd, /*extremes=*/true, kAbsorbRingLayers) > 0) bad = opt.bad_tets();
      const std::size_t now = opt.interior(bad).size();
      stale = now < best ? 0 : stale + 1;
      best = std::min(best, now);
    }
  }
  // The cap repair's relaxed pass again (optimize.hpp, 5.): the caps and flat
  // tets of four surface points that the steps since made, or left in changed
  // cavities.
  if (options.repair_caps && options.late_caps && opt.repair_caps(true) > 0) bad = opt.bad_tets();
  // Size polish (optimize.hpp, 9.): the free points of the edges off the
  // surface out of the size band, moved back towards it where no tet gets worse.
  if (options.smooth && options.polish_sizes && sizing != nullptr && opt.polish_sizes(options.surface_room) > 0) bad = opt.bad_tets();
  st.bad_after = bad.size();
  if (st.points_removed + st.edges_collapsed > 0 && !options.keep_point_indices) mesh.remove_unused_points();
  const AngleRange after = opt.angles();
  st.min_dihedral_after = after.min;
  st.max_dihedral_after = after.max;
  st.seconds = seconds_since(clock_start);
  return st;
}

}  // namespace pdrmesh
