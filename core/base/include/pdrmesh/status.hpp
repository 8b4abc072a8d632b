// SPDX-License-Identifier: AGPL-3.0-or-later
// One status type for the whole kernel, and the macros that propagate it.
//
// A Status is either ok or an error with a code and a message that names the
// problem and where it is (file:line, triangle index, coordinates). Expected
// outcomes of local operations ("declined": not better, constrained) are not
// errors and never travel as a Status; they are plain return values.
// Exceptions are used only at the edges (TetGen, gRPC, CLI parsing).
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <variant>

namespace pdrmesh {

/// True in debug builds (NDEBUG unset), where the consistency checks that a
/// release build leaves to the end of a run also run after each step.
#ifdef NDEBUG
inline constexpr bool kDebugChecks = false;
#else
inline constexpr bool kDebugChecks = true;
#endif

enum class StatusCode {
  kOk = 0,
  kInvalidInput,       ///< the user's data is wrong (malformed file, defective surface)
  kNotFound,           ///< a named file or entity does not exist
  kIoError,            ///< reading or writing failed for reasons outside the data
  kUnsupported,        ///< a valid request we do not handle (unknown suffix, ...)
  kResourceExhausted,  ///< a limit was hit (memory, size)
  kDeadlineExceeded,   ///< a time limit was hit
  kCancelled,          ///< the caller asked to stop (a progress hook said no)
  kInternal,           ///< a bug or an external tool that failed unexpectedly
};

std::string_view to_string(StatusCode code);

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status ok_status() { return {}; }
  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }
  /// "invalid input: bunny.stl:12: ..." (or "ok").
  std::string to_string() const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

inline Status invalid_input(std::string m) { return {StatusCode::kInvalidInput, std::move(m)}; }
inline Status io_error(std::string m) { return {StatusCode::kIoError, std::move(m)}; }
inline Status not_found(std::string m) { return {StatusCode::kNotFound, std::move(m)}; }
inline Status unsupported(std::string m) { return {StatusCode::kUnsupported, std::move(m)}; }
inline Status internal_error(std::string m) { return {StatusCode::kInternal, std::move(m)}; }
inline Status deadline_exceeded(std::string m) { return {StatusCode::kDeadlineExceeded, std::move(m)}; }
inline Status resource_exhausted(std::string m) { return {StatusCode::kResourceExhausted, std::move(m)}; }
inline Status cancelled(std::string m) { return {StatusCode::kCancelled, std::move(m)}; }

/// A value or the error that prevented it.
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}  // NOLINT: implicit by design
  Result(Status status) : v_(std::move(status)) {}  // NOLINT: must not be ok

  bool ok() const { return std::holds_alternative<T>(v_); }
  const Status& status() const {
    static const Status kOk;
    return ok() ? kOk : std::get<Status>(v_);
  }
  T& value() & { return std::get<T>(v_); }
  const T& value() const& { return std::get<T>(v_); }
  T&& value() && { return std::get<T>(std::move(v_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

 private:
  std::variant<T, Status> v_;
};

}  // namespace pdrmesh

#define PDR_CONCAT_INNER(a, b) a##b
#define PDR_CONCAT(a, b) PDR_CONCAT_INNER(a, b)

/// Return the status of `expr` from the enclosing function if it is an error.
#define PDR_TRY(expr)                                   \
  do {                                                  \
    ::pdrmesh::Status pdr_status_ = (expr);             \
    if (!pdr_status_.ok()) return pdr_status_;          \
  } while (false)

/// `PDR_ASSIGN_OR_RETURN(auto x, f())`: unwrap a Result or return its error.
#define PDR_ASSIGN_OR_RETURN(lhs, expr)                                            \
  auto PDR_CONCAT(pdr_result_, __LINE__) = (expr);                                 \
  if (!PDR_CONCAT(pdr_result_, __LINE__).ok())                                     \
    return PDR_CONCAT(pdr_result_, __LINE__).status();                             \
  lhs = std::move(PDR_CONCAT(pdr_result_, __LINE__)).value()
