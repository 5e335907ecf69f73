// Typed errors of the ARAP engine. Every public entry point checks its input
// in release builds and throws arap::Error with a message a user can act on.
#pragma once

#include <stdexcept>
#include <string>

namespace arap {

enum class ErrorCode {
  InvalidInput,      // wrong shapes, empty arrays, bad option values
  IndexOutOfRange,   // a face or constraint index outside [0, #V)
  NonFinite,         // NaN or Inf in rest positions or targets
  NoTriangles,       // nothing to deform
  NoConstraints,     // the constraint set is empty
  DuplicateConstraint,
  NotBound,          // solve() before bind()
  Factorization,     // the sparse Cholesky failed (should not happen after checks)
  Busy,              // the solver is in use by a SolveWorker on another thread
  OutOfMemory,       // a bind would need more memory than the process may use (nothing was changed)
};

const char* error_code_name(ErrorCode code);

class Error : public std::runtime_error {
 public:
  Error(ErrorCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ErrorCode code() const { return code_; }

 private:
  ErrorCode code_;
};

}  // namespace arap
