// SPDX-License-Identifier: AGPL-3.0-or-later
// JobCheckpoint: a running job's last round checkpoint (PdrCheckpoint, core
// pdr.hpp) in its directory, so that a job interrupted by a coordinator
// restart goes on from its last finished round instead of from the start,
// with the same result bytes.
//
// The file is the checkpoint's bytes (which end with their own digest) after a
// header with the digest of the job's key: the pdrmesh version, the digest of
// the coordinator's executable, the job's options and the digest of its input.
// A file written for another key (the coordinator was rebuilt or upgraded, say)
// or cut short is not used: the job runs from the start and the file is
// replaced at its first round.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "pdrmesh/pdr.hpp"
#include "pdrmesh/status.hpp"

namespace pdrmesh::server {

/// content_digest of this process's executable (/proc/self/exe), read once;
/// 0 where it cannot be read. Another build of the engine may mesh otherwise,
/// so a checkpoint is resumed only by the binary that wrote it.
std::uint64_t executable_digest();

class JobCheckpoint {
 public:
  /// `key`: everything the job's result depends on besides the checkpoint.
  JobCheckpoint(std::filesystem::path file, std::string_view key);

  /// The checkpoint stored for this key; none when there is no file, or when
  /// it was written for another key or does not decode (logged, and removed).
  std::optional<PdrCheckpoint> load() const;
  /// Replaces the stored checkpoint: written beside it, then renamed over it,
  /// so a crash leaves the old one or the new one.
  Status store(const PdrCheckpoint& checkpoint) const;
  /// Removes the file (absent: nothing).
  void remove() const;

  const std::filesystem::path& file() const { return file_; }

 private:
  std::filesystem::path file_;
  std::uint64_t key_digest_;
};

}  // namespace pdrmesh::server
