// SPDX-License-Identifier: AGPL-3.0-or-later
// Engine surface ids from the user's and back (surface_ids.hpp).
#include "pdrmesh/surface_ids.hpp"

#include <algorithm>
#include <cstddef>
#include <limits>

#include <fmt/format.h>

namespace pdrmesh {

Result<SurfaceIdMap> SurfaceIdMap::to_engine(std::vector<int>& ids) {
  SurfaceIdMap map;
  if (std::all_of(ids.begin(), ids.end(), [](int id) { return id >= 1; })) return map;
  map.user_ = ids;
  std::sort(map.user_.begin(), map.user_.end());
  map.user_.erase(std::unique(map.user_.begin(), map.user_.end()), map.user_.end());
  if (map.user_.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    return invalid_input(fmt::format("{} distinct surface ids: more than {} cannot be numbered", map.user_.size(),
                                     std::numeric_limits<int>::max()));
  for (int& id : ids)
    id = static_cast<int>(std::lower_bound(map.user_.begin(), map.user_.end(), id) - map.user_.begin()) + 1;
  return map;
}

void SurfaceIdMap::to_user(std::vector<int>& ids) const {
  if (user_.empty()) return;
  for (int& id : ids)
    if (id >= 1 && static_cast<std::size_t>(id) <= user_.size()) id = user_[static_cast<std::size_t>(id) - 1];
}

}  // namespace pdrmesh
