// SPDX-License-Identifier: AGPL-3.0-or-later
// LocalLeafDispatch: the job's kernel, run in this process.
#include "leaf_dispatch.hpp"

#include "pdrmesh/leaf_kernels.hpp"

namespace pdrmesh::server {

Result<std::unique_ptr<LeafKernel>> LocalLeafDispatch::kernel_for(const LeafJob& job) {
  return make_leaf_kernel(job.kernel);
}

}  // namespace pdrmesh::server
