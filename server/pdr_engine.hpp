// SPDX-License-Identifier: AGPL-3.0-or-later
// PdrEngine: the coordinator's MeshEngine. It runs the same pipeline as
// `pdrmesh run` (mesh_parallel, core/pipeline.hpp) with the job's options, its
// leaves refined by the kernel a LeafDispatch gives for the job (in this
// process, or on workers), reports the phase, leaves done of total and tets
// to the job, and stops when the job is cancelled, the coordinator stops or
// the job's time limit passes. The result is byte-identical to
// `pdrmesh run SURFACE -o OUT.meshb` with the same options.
#pragma once

#include <chrono>
#include <memory>

#include "job_runner.hpp"
#include "leaf_dispatch.hpp"
#include "pdrmesh/pipeline.hpp"

namespace pdrmesh::server {

/// The ParallelOptions of `pdrmesh run` for these job options (workers: 1,
/// progress unset; the caller sets both).
ParallelOptions parallel_options(const JobOptions& options);

class PdrEngine final : public MeshEngine {
 public:
  /// test_checkpoint_delay: Options::test_checkpoint_delay (coordinator.hpp).
  explicit PdrEngine(std::shared_ptr<LeafDispatch> dispatch,
                     std::chrono::milliseconds test_checkpoint_delay = std::chrono::milliseconds{0})
      : dispatch_(std::move(dispatch)), test_checkpoint_delay_(test_checkpoint_delay) {}
  /// With `checkpoint`, goes on from the round it holds (and stores one after
  /// each round); a checkpoint that cannot be stored is logged, the job goes on.
  Result<VolumeMesh> mesh(const JobRecord& job, const JobDomain& domain, const JobOptions& options,
                          JobProgress& progress, const JobCheckpoint* checkpoint) override;

 private:
  std::shared_ptr<LeafDispatch> dispatch_;
  std::chrono::milliseconds test_checkpoint_delay_;
};

}  // namespace pdrmesh::server
