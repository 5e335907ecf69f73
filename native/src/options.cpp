#include "arap/options.h"

#include "arap/errors.h"

namespace arap {

Weights parse_weights(const std::string& name) {
  if (name == "cotan") return Weights::Cotan;
  if (name == "cotan-clamped") return Weights::CotanClamped;
  if (name == "uniform") return Weights::Uniform;
  throw Error(ErrorCode::InvalidInput, "unknown weights '" + name + "' (expected cotan, cotan-clamped or uniform)");
}

Method parse_method(const std::string& name) {
  if (name == "quasi-newton") return Method::QuasiNewton;
  if (name == "local-global") return Method::LocalGlobal;
  if (name == "anderson") return Method::Anderson;
  throw Error(ErrorCode::InvalidInput,
              "unknown method '" + name + "' (expected quasi-newton, local-global or anderson)");
}

std::string to_string(Method m) {
  switch (m) {
    case Method::QuasiNewton: return "quasi-newton";
    case Method::LocalGlobal: return "local-global";
    case Method::Anderson: return "anderson";
  }
  return "?";
}

InitialGuess parse_initial_guess(const std::string& name) {
  if (name == "differential") return InitialGuess::Differential;
  if (name == "naive") return InitialGuess::Naive;
  if (name == "laplacian") return InitialGuess::Laplacian;
  if (name == "warm" || name == "warm-start") return InitialGuess::WarmStart;
  throw Error(ErrorCode::InvalidInput,
              "unknown first guess '" + name + "' (expected differential, naive, laplacian or warm)");
}

std::string to_string(Weights w) {
  switch (w) {
    case Weights::Cotan: return "cotan";
    case Weights::CotanClamped: return "cotan-clamped";
    case Weights::Uniform: return "uniform";
  }
  return "?";
}

std::string to_string(InitialGuess g) {
  switch (g) {
    case InitialGuess::Differential: return "differential";
    case InitialGuess::Naive: return "naive";
    case InitialGuess::Laplacian: return "laplacian";
    case InitialGuess::WarmStart: return "warm";
  }
  return "?";
}

Volume parse_volume(const std::string& name) {
  if (name == "none") return Volume::None;
  if (name == "global") return Volume::Global;
  if (name == "infill") return Volume::Infill;
  throw Error(ErrorCode::InvalidInput, "unknown volume mode '" + name + "' (expected none, global or infill)");
}

std::string to_string(Volume v) {
  switch (v) {
    case Volume::None: return "none";
    case Volume::Global: return "global";
    case Volume::Infill: return "infill";
  }
  return "?";
}

}  // namespace arap
