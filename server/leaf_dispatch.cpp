// SPDX-License-Identifier: AGPL-3.0-or-later
// LocalLeafDispatch: the job's kernel, run in this process; FallbackLeafDispatch.
#include "leaf_dispatch.hpp"

#include "pdrmesh/leaf_kernels.hpp"

namespace pdrmesh::server {

namespace {

/// FallbackLeafDispatch's kernel: the remote one while there are workers.
class FallbackKernel final : public LeafKernel {
 public:
  FallbackKernel(std::unique_ptr<LeafKernel> remote, std::unique_ptr<LeafKernel> local,
                 std::function<bool()> has_workers)
      : remote_(std::move(remote)), local_(std::move(local)), has_workers_(std::move(has_workers)) {}
  Result<LeafTaskOutput> run(const LeafTaskInput& in, const SizingField& sizing) const override {
    return has_workers_() ? remote_->run(in, sizing) : local_->run(in, sizing);
  }
  std::string_view name() const override { return local_->name(); }
  bool needs_manifold_hull() const override { return local_->needs_manifold_hull(); }

 private:
  std::unique_ptr<LeafKernel> remote_, local_;
  std::function<bool()> has_workers_;
};

}  // namespace

Result<std::unique_ptr<LeafKernel>> LocalLeafDispatch::kernel_for(const LeafJob& job) {
  return make_leaf_kernel(job.kernel);
}

Result<std::unique_ptr<LeafKernel>> FallbackLeafDispatch::kernel_for(const LeafJob& job) {
  PDR_ASSIGN_OR_RETURN(std::unique_ptr<LeafKernel> remote, remote_->kernel_for(job));
  PDR_ASSIGN_OR_RETURN(std::unique_ptr<LeafKernel> local, local_->kernel_for(job));
  return std::unique_ptr<LeafKernel>(
      std::make_unique<FallbackKernel>(std::move(remote), std::move(local), has_workers_));
}

}  // namespace pdrmesh::server
