#include "arap/errors.h"

namespace arap {

const char* error_code_name(ErrorCode code) {
  switch (code) {
    case ErrorCode::InvalidInput: return "invalid input";
    case ErrorCode::IndexOutOfRange: return "index out of range";
    case ErrorCode::NonFinite: return "non-finite value";
    case ErrorCode::NoTriangles: return "no triangles";
    case ErrorCode::NoConstraints: return "no constraints";
    case ErrorCode::DuplicateConstraint: return "duplicate constraint";
    case ErrorCode::NotBound: return "not bound";
    case ErrorCode::Factorization: return "factorization failed";
    case ErrorCode::Busy: return "solver busy";
    case ErrorCode::OutOfMemory: return "out of memory";
  }
  return "unknown error";
}

}  // namespace arap
