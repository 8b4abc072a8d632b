// SPDX-License-Identifier: AGPL-3.0-or-later
// Surface ids inside the meshing engines, and the user's ids around them.
//
// The rule: inside the pipelines (mesh_serial, run_pdr and everything they
// call) a boundary face on the input surface carries an engine id >= 1, and id
// 0 marks a frozen face that is not on the surface: a leaf's interface in a
// leaf task (leaf_task.hpp), the hull of a selection of tets given to the
// optimizer. The optimizer's surface-only steps (the relaxed floor of the
// interior repair, the cap repair; optimize.hpp) go by that id. A user's
// surface may carry any int as id (a Medit triangle ref of 0 is common; PLY
// and OBJ may give 0 or negative ids), so the pipelines turn the user's ids
// into engine ids on entry (SurfaceIdMap::to_engine) and back on exit
// (to_user): the output mesh's boundary carries the user's ids.
#pragma once

#include <vector>

#include "pdrmesh/status.hpp"

namespace pdrmesh {

class SurfaceIdMap {
 public:
  /// Turns the user's ids into engine ids in place: unchanged when every id is
  /// already >= 1 (the map is then the identity); otherwise the distinct ids,
  /// in ascending order, become 1, 2, ... (so every int, INT_MIN included, has
  /// an engine id, and their order is kept). invalid_input, `ids` untouched,
  /// when there are more distinct ids than engine ids (above INT_MAX).
  static Result<SurfaceIdMap> to_engine(std::vector<int>& ids);

  /// Gives engine ids made by to_engine back as the user's ids, in place (an
  /// id the map did not make is left as it is).
  void to_user(std::vector<int>& ids) const;

  /// True when to_engine changed nothing.
  bool identity() const { return user_.empty(); }

 private:
  std::vector<int> user_;  ///< user_[k - 1]: the user's id of engine id k; empty: identity
};

}  // namespace pdrmesh
