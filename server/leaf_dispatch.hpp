// SPDX-License-Identifier: AGPL-3.0-or-later
// LeafDispatch: where the coordinator's PDR engine sends a job's leaf tasks.
// The engine (mesh_parallel, core/pipeline.hpp) calls LeafKernel::run once per
// leaf from several threads at once; a dispatch hands it a kernel that runs the
// leaf in this process (LocalLeafDispatch) or on a remote worker daemon
// (RemoteLeafDispatch, worker_pool.hpp); the optimization rounds' tasks go the
// same way (kernels "optimize" and "optimize-final"). Both give the same bytes for the same
// leaf: a worker runs make_leaf_kernel(job.kernel) on the task it receives,
// and the engine's merge order does not depend on where or when a leaf ran.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>

#include "pdrmesh/leaf_task.hpp"
#include "pdrmesh/status.hpp"

namespace pdrmesh::server {

/// The job a kernel works for.
struct LeafJob {
  std::string job_id;
  std::string user;    ///< for fair sharing of workers between users
  std::string kernel;  ///< make_leaf_kernel name: "native", "tetgen", "optimize" or "optimize-final"
  /// False once the job must stop (cancelled, coordinator shutting down): a
  /// kernel waiting for a worker gives up with a kCancelled status.
  std::function<bool()> keep_going;
};

class LeafDispatch {
 public:
  virtual ~LeafDispatch() = default;
  /// A kernel whose run() refines one leaf of `job`; it lives while the job
  /// meshes and is called concurrently.
  virtual Result<std::unique_ptr<LeafKernel>> kernel_for(const LeafJob& job) = 0;
  /// Leaf tasks one job keeps in flight now (PdrOptions::concurrency: asked
  /// whenever the job hands out leaf tasks, from its merging thread).
  virtual std::size_t concurrency() const = 0;
};

/// Leaves run in the coordinator's process on `threads` threads.
class LocalLeafDispatch final : public LeafDispatch {
 public:
  explicit LocalLeafDispatch(std::size_t threads) : threads_(threads < 1 ? 1 : threads) {}
  Result<std::unique_ptr<LeafKernel>> kernel_for(const LeafJob& job) override;
  std::size_t concurrency() const override { return threads_; }

 private:
  std::size_t threads_;
};

/// Leaves go to `remote` while `has_workers()` is true, and run through
/// `local` otherwise: a coordinator with a worker registry but no worker at
/// all refines its leaves itself instead of waiting. Decided per leaf (the
/// bytes are the same either way), so a worker that registers mid-job takes
/// the next leaves.
class FallbackLeafDispatch final : public LeafDispatch {
 public:
  FallbackLeafDispatch(std::shared_ptr<LeafDispatch> remote, std::shared_ptr<LeafDispatch> local,
                       std::function<bool()> has_workers)
      : remote_(std::move(remote)), local_(std::move(local)), has_workers_(std::move(has_workers)) {}
  Result<std::unique_ptr<LeafKernel>> kernel_for(const LeafJob& job) override;
  std::size_t concurrency() const override {
    return has_workers_() ? remote_->concurrency() : local_->concurrency();
  }

 private:
  std::shared_ptr<LeafDispatch> remote_, local_;
  std::function<bool()> has_workers_;
};

}  // namespace pdrmesh::server
