// SPDX-License-Identifier: AGPL-3.0-or-later
// Exit codes of the pdrmesh program (BSD sysexits where one fits).
#pragma once

#include <string_view>
#include <utility>

#include "pdrmesh/status.hpp"

namespace pdrmesh::cli {

enum ExitCode : int {
  kExitOk = 0,
  kExitJobFailed = 1,     ///< the service ran the job and it failed or was cancelled
  kExitUsage = 64,        ///< bad command line, unknown file suffix
  kExitBadInput = 65,     ///< the input is defective (surface check, malformed file, invalid mesh)
  kExitNoInput = 66,      ///< an input file does not exist or cannot be opened (or no such job)
  kExitUnavailable = 69,  ///< the coordinator cannot be reached
  kExitInternal = 70,     ///< a bug, or TetGen failed unexpectedly
  kExitIo = 74,           ///< reading or writing failed
  kExitTempFail = 75,     ///< a time or resource limit was hit; trying again may help
  kExitNoPerm = 77,       ///< the coordinator refused the token (missing or unknown)
};

/// Each exit code and what it means, for the help footers.
inline constexpr std::pair<int, std::string_view> kExitCodeMeanings[] = {
    {kExitOk, "success"},
    {kExitJobFailed, "the job failed or was cancelled (submit --wait, watch)"},
    {kExitUsage, "usage error: an unknown command or option, a bad value, an output that cannot be written"},
    {kExitBadInput, "the input is defective (surface check, malformed file, invalid mesh)"},
    {kExitNoInput, "an input file or job does not exist or cannot be opened"},
    {kExitUnavailable, "the coordinator cannot be reached"},
    {kExitInternal, "internal error (a bug; please report it with the input)"},
    {kExitIo, "reading or writing failed"},
    {kExitTempFail, "a time limit (--time-limit) or resource limit was hit"},
    {kExitNoPerm, "the coordinator refused the token"},
};

inline int exit_code_for(const Status& s) {
  switch (s.code()) {
    case StatusCode::kOk: return kExitOk;
    case StatusCode::kInvalidInput: return kExitBadInput;
    case StatusCode::kNotFound: return kExitNoInput;
    case StatusCode::kIoError: return kExitIo;
    case StatusCode::kUnsupported: return kExitUsage;
    case StatusCode::kResourceExhausted:
    case StatusCode::kDeadlineExceeded:
    case StatusCode::kCancelled: return kExitTempFail;
    case StatusCode::kInternal: return kExitInternal;
  }
  return kExitInternal;
}

}  // namespace pdrmesh::cli
