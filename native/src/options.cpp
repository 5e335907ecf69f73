#include "arap/options.h"

#include <cmath>
#include <limits>
#include <sstream>

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
    case Method::QuasiNewton:
      return "quasi-newton";
    case Method::LocalGlobal:
      return "local-global";
    case Method::Anderson:
      return "anderson";
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
    case Weights::Cotan:
      return "cotan";
    case Weights::CotanClamped:
      return "cotan-clamped";
    case Weights::Uniform:
      return "uniform";
  }
  return "?";
}

std::string to_string(InitialGuess g) {
  switch (g) {
    case InitialGuess::Differential:
      return "differential";
    case InitialGuess::Naive:
      return "naive";
    case InitialGuess::Laplacian:
      return "laplacian";
    case InitialGuess::WarmStart:
      return "warm";
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
    case Volume::None:
      return "none";
    case Volume::Global:
      return "global";
    case Volume::Infill:
      return "infill";
  }
  return "?";
}

Contact parse_contact(const std::string& name) {
  if (name == "none") return Contact::None;
  if (name == "self") return Contact::Self;
  throw Error(ErrorCode::InvalidInput, "unknown contact mode '" + name + "' (expected none or self)");
}

std::string to_string(Contact c) {
  switch (c) {
    case Contact::None:
      return "none";
    case Contact::Self:
      return "self";
  }
  return "?";
}

namespace {

// A number as users write it: 1000000 rather than 1e+06.
std::string shown(double x) {
  std::ostringstream out;
  out.precision(15);
  out << x;
  return out.str();
}

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t k = 0; k < names.size(); ++k)
    out += (k == 0 ? "" : k + 1 == names.size() ? " or " : ", ") + names[k];
  return out;
}

bool is_choice_of(const OptionSpec& spec, const std::string& name) {
  for (const std::string& c : spec.choices)
    if (c == name) return true;
  return false;
}

constexpr double kUnbounded = std::numeric_limits<double>::infinity();

// An option with nothing read or written yet; Integer and Real ones accept [min, max].
OptionSpec option(const char* name, OptionKind kind, double min = 0, double max = 0) {
  OptionSpec o;
  o.name = name;
  o.kind = kind;
  o.min = min;
  o.max = max;
  return o;
}

std::vector<OptionSpec> make_specs() {
  std::vector<OptionSpec> specs;
  OptionSpec o = option("method", OptionKind::Choice);
  o.choices = {"quasi-newton", "local-global", "anderson"};
  o.get_choice = [](const Options& x) { return to_string(x.method); };
  o.set_choice = [](Options& x, const std::string& v) { x.method = parse_method(v); };
  specs.push_back(o);
  o = option("weights", OptionKind::Choice);
  o.choices = {"cotan-clamped", "cotan", "uniform"};
  o.get_choice = [](const Options& x) { return to_string(x.weights); };
  o.set_choice = [](Options& x, const std::string& v) { x.weights = parse_weights(v); };
  o.needs_bind = true;
  specs.push_back(o);
  o = option("init", OptionKind::Choice);
  o.choices = {"naive", "laplacian", "differential", "warm"};
  o.get_choice = [](const Options& x) { return to_string(x.init); };
  o.set_choice = [](Options& x, const std::string& v) { x.init = parse_initial_guess(v); };
  specs.push_back(o);
  o = option("cold_start", OptionKind::Choice);
  o.choices = {"naive", "laplacian", "differential"};
  o.get_choice = [](const Options& x) { return to_string(x.cold_start); };
  o.set_choice = [](Options& x, const std::string& v) { x.cold_start = parse_initial_guess(v); };
  specs.push_back(o);
  // The cap bounds what a solve reserves for its statistics (16 bytes an iteration).
  o = option("max_iterations", OptionKind::Integer, 0, 1000000);
  o.get_number = [](const Options& x) { return double(x.max_iterations); };
  o.set_number = [](Options& x, double v) { x.max_iterations = static_cast<int>(v); };
  specs.push_back(o);
  o = option("tolerance", OptionKind::Real, 0, 1);
  o.get_number = [](const Options& x) { return x.tolerance; };
  o.set_number = [](Options& x, double v) { x.tolerance = v; };
  specs.push_back(o);
  o = option("threads", OptionKind::Integer, 1, 64);
  o.get_number = [](const Options& x) { return double(x.threads); };
  o.set_number = [](Options& x, double v) { x.threads = static_cast<int>(v); };
  specs.push_back(o);
  o = option("anderson_window", OptionKind::Integer, 0, 20);
  o.get_number = [](const Options& x) { return double(x.anderson_window); };
  o.set_number = [](Options& x, double v) { x.anderson_window = static_cast<int>(v); };
  specs.push_back(o);
  o = option("volume", OptionKind::Choice);
  o.choices = {"none", "global", "infill"};
  o.get_choice = [](const Options& x) { return to_string(x.volume); };
  o.set_choice = [](Options& x, const std::string& v) { x.volume = parse_volume(v); };
  o.needs_bind = true;
  specs.push_back(o);
  o = option("infill_resolution", OptionKind::Integer, 2, 256);
  o.get_number = [](const Options& x) { return double(x.infill_resolution); };
  o.set_number = [](Options& x, double v) { x.infill_resolution = static_cast<int>(v); };
  o.needs_bind = true;
  specs.push_back(o);
  o = option("contact", OptionKind::Choice);
  o.choices = {"none", "self"};
  o.get_choice = [](const Options& x) { return to_string(x.contact); };
  o.set_choice = [](Options& x, const std::string& v) { x.contact = parse_contact(v); };
  o.needs_bind = true;
  specs.push_back(o);
  o = option("time_budget_ms", OptionKind::Real, 0, kUnbounded);
  o.get_number = [](const Options& x) { return x.time_budget_ms; };
  o.set_number = [](Options& x, double v) { x.time_budget_ms = v; };
  specs.push_back(o);
  return specs;
}

}  // namespace

const std::vector<OptionSpec>& option_specs() {
  static const std::vector<OptionSpec> specs = make_specs();
  return specs;
}

const OptionSpec& option_spec(const std::string& name) {
  std::vector<std::string> names;
  for (const OptionSpec& o : option_specs()) {
    if (name == o.name) return o;
    names.push_back(o.name);
  }
  throw Error(ErrorCode::InvalidInput, "unknown option '" + name + "' (expected " + joined(names) + ")");
}

std::string option_limits(const OptionSpec& o) {
  if (o.kind == OptionKind::Choice) return joined(o.choices);
  const std::string what = o.kind == OptionKind::Integer ? "an integer" : "a finite number";
  return what + (std::isfinite(o.max) ? " between " + shown(o.min) + " and " + shown(o.max) : " >= " + shown(o.min));
}

void check_options(const Options& options) {
  for (const OptionSpec& o : option_specs()) {
    if (o.kind == OptionKind::Choice) {
      const std::string value = o.get_choice(options);
      if (!is_choice_of(o, value))
        throw Error(ErrorCode::InvalidInput, std::string(o.name) + " must be " + option_limits(o) + ", not " + value);
      continue;
    }
    const double v = o.get_number(options);
    if (!(std::isfinite(v) && v >= o.min && v <= o.max))
      throw Error(ErrorCode::InvalidInput, std::string(o.name) + " must be " + option_limits(o) + ", got " + shown(v));
  }
  if (const std::optional<OptionConflict> conflict = method_conflict(options))
    throw Error(ErrorCode::InvalidInput, std::string(conflict->option) + " " + conflict->value +
                                             " works with the quasi-newton and local-global methods, not anderson (" +
                                             conflict->reason + ")");
}

void set_option(Options& options, const OptionSpec& spec, const std::string& choice) {
  Options changed = options;
  spec.set_choice(changed, choice);  // throws for a name it does not know
  if (!is_choice_of(spec, choice))
    throw Error(ErrorCode::InvalidInput,
                std::string(spec.name) + " must be " + option_limits(spec) + ", not " + choice);
  options = changed;
}

void set_option(Options& options, const OptionSpec& spec, double number, const std::string& as_given) {
  // Checked before it is stored: an integer beyond the option's range must not wrap.
  const bool whole = spec.kind != OptionKind::Integer || number == std::floor(number);
  if (!(std::isfinite(number) && number >= spec.min && number <= spec.max && whole))
    throw Error(ErrorCode::InvalidInput,
                std::string(spec.name) + " must be " + option_limits(spec) + ", got " + as_given);
  spec.set_number(options, number);
}

std::vector<OptionConflict> method_conflicts(const Options& options) {
  std::vector<OptionConflict> found;
  if (options.method != Method::Anderson) return found;
  if (options.volume != Volume::None)
    found.push_back(
        {"volume", to_string(options.volume), "its extrapolated points are not checked against the volume terms"});
  if (options.contact != Contact::None)
    found.push_back({"contact", to_string(options.contact),
                     "its extrapolated points skip the collision check that keeps parts of the surface from "
                     "crossing"});
  return found;
}

void surface_only_for_anderson(Options& options) {
  if (options.method == Method::Anderson) options.volume = Volume::None;
}

std::optional<OptionConflict> method_conflict(const Options& options) {
  const std::vector<OptionConflict> found = method_conflicts(options);
  if (found.empty()) return std::nullopt;
  return found.front();
}

}  // namespace arap
