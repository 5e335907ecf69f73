// Settings of the ARAP engine, and their one definition (option_specs()):
// names, defaults and limits that check_options(), the command line and the
// Python module (OPTIONS) read from here; a Blender test checks the add-on's
// settings against OPTIONS (same defaults, limits within these).
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace arap {

// Edge weights w_ij of the energy and of the Laplacian.
enum class Weights {
  Cotan,         // (cot a + cot b) / 2 as in Sorkine & Alexa 2007; may be negative
  CotanClamped,  // each negative cotangent set to 0 before summing (default, see docs/design.md)
  Uniform,       // w_ij = 1
};

// How the positions are initialised before the first local step.
enum class InitialGuess {
  Differential,  // Lipman et al. 2004: uniform-Laplacian coordinates, constraints hard
  Naive,         // rest shape with the constrained vertices moved to their targets (default, see docs/design.md)
  Laplacian,     // one global step with identity rotations (Laplacian editing)
  WarmStart,     // the last solution (falls back to `cold_start` before the first solve)
};

// How the energy is minimised (see docs/design.md, "Defaults, and why").
enum class Method {
  QuasiNewton,  // L-BFGS on the ARAP energy, the factored Laplacian as its initial Hessian and a
                // line search (Liu et al. 2017); energy monotone; the default
  LocalGlobal,  // Sorkine & Alexa's alternation of local and global steps (the textbook iteration)
  Anderson,     // local/global with Anderson acceleration over `anderson_window` iterates (Peng et al. 2018)
};

// What keeps the volume of thick parts where they bend (see docs/volume.md).
enum class Volume {
  None,    // surface ARAP only (Sorkine & Alexa 2007)
  Global,  // the enclosed volume of every closed component kept at its rest value, exactly
  Infill,  // a coarse lattice filling the interior, posed as-rigid-as-possible with the surface bound to it
};

// What keeps the surface from passing through itself (see docs/contact.md).
enum class Contact {
  None,  // nothing: parts of the surface may cross
  Self,  // a barrier on near pairs and collision detection on every step: no two parts apart at rest ever cross
};

struct Options {
  Method method = Method::QuasiNewton;
  Weights weights = Weights::CotanClamped;
  InitialGuess init = InitialGuess::Naive;
  // Used when init == WarmStart and there is no previous solution yet.
  InitialGuess cold_start = InitialGuess::Naive;
  // A safety cap: solves stop at the tolerance long before it on the measured meshes.
  int max_iterations = 1000;
  // Stop when (E_prev - E) <= tolerance * |E_prev| (quasi-Newton: and the next step's predicted decrease
  // too); 0 runs the whole budget. With Volume::Infill, also only when the pose is estimated within
  // 100 * tolerance of the rest bounding box's diagonal of where the iteration converges (1e-4 at the
  // default; docs/engine_internals.md, "The stop rule"). Volume::None and Global stop on the energy alone.
  double tolerance = 1e-6;
  // Threads for the local step and the right-hand side (meshes of 2048+ vertices) and, from 20 000 free
  // vertices, for the bind's ordering and factorization and the triangular solves; 1 = none started.
  int threads = 1;
  // Anderson acceleration window (Peng et al. 2018) of Method::Anderson; 0 = plain local/global.
  int anderson_window = 5;
  // Stop after the iteration that passes this many milliseconds of solve()
  // (e.g. a viewport frame); the result is then not `converged`. 0 = no limit.
  double time_budget_ms = 0;
  // Needs a bind (like `weights`). Volume::Global works with the quasi-Newton and local/global methods.
  Volume volume = Volume::Infill;
  // Volume::Infill: lattice cells along the longest side of the mesh's bounding box (2..256).
  int infill_resolution = 10;
  // Needs a bind. Contact::Self works with the quasi-Newton and local/global methods.
  Contact contact = Contact::None;
};

// One option as users name and set it. A new option is a field of Options
// and one entry of option_specs(): the command line, the module, the report
// and the add-on's properties take it from there.
enum class OptionKind { Choice, Integer, Real };

struct OptionSpec {
  const char* name;  // the field's name: Python keyword and property, report key ("max_iterations")
  OptionKind kind;
  // Integer and Real: the accepted range, bounds included (Real: also finite).
  double min = 0, max = 0;
  // Choice: the accepted names ("cotan-clamped", ...).
  std::vector<std::string> choices;
  // Read and write the field: Choice as its name, Integer and Real as a number
  // (set() stores without checking; check_options() checks).
  std::string (*get_choice)(const Options&) = nullptr;
  void (*set_choice)(Options&, const std::string&) = nullptr;
  double (*get_number)(const Options&) = nullptr;
  void (*set_number)(Options&, double) = nullptr;
  // Fixed at Solver::bind() (the weights, the volume terms): changing it needs a new bind.
  bool needs_bind = false;
};

// Every option, in a fixed order; the defaults are those of Options().
const std::vector<OptionSpec>& option_specs();
// The option called `name`; throws Error(InvalidInput) naming the known ones.
const OptionSpec& option_spec(const std::string& name);
// What the option accepts, for messages: "an integer between 0 and 20",
// "a finite number >= 0", "quasi-newton, local-global or anderson".
std::string option_limits(const OptionSpec& spec);
// Throws Error(InvalidInput), naming the option and its limits, unless every
// option is within them (and cold_start is not WarmStart), or naming the
// method_conflict() when there is one.
void check_options(const Options& options);

// Sets one option to the choice called `choice` (a Choice option) or to
// `number` (an Integer or Real one) when the value is within the option's
// limits; otherwise changes nothing and throws Error(InvalidInput) naming the
// option, its limits and the value (a number as its user wrote it: `as_given`).
// The command line and the Python module set options through these.
void set_option(Options& options, const OptionSpec& spec, const std::string& choice);
void set_option(Options& options, const OptionSpec& spec, double number, const std::string& as_given);

// Two settings that cannot be combined: `option` ("volume" or "contact") set to
// `value` works with the quasi-newton and local-global methods, not anderson,
// for `reason`.
struct OptionConflict {
  const char* option;
  std::string value;
  const char* reason;
};
// Every conflict among `options` (volume's before contact's; none unless the
// method is anderson): the add-on names them and solves with quasi-newton.
std::vector<OptionConflict> method_conflicts(const Options& options);
// The first of them, if any: check_options() refuses it, the command line
// names it by its flags.
std::optional<OptionConflict> method_conflict(const Options& options);

// Anderson accelerates the surface energy's alternation and cannot carry the volume terms: options whose
// caller chose it without naming a volume mode solve Surface Only (the command line and the module call
// this when no volume was given; the add-on solves with quasi-newton instead and says so).
void surface_only_for_anderson(Options& options);

// Parse / print the names used on the command line and in Python ("cotan-clamped").
Weights parse_weights(const std::string& name);
Method parse_method(const std::string& name);
std::string to_string(Method m);
InitialGuess parse_initial_guess(const std::string& name);
std::string to_string(Weights w);
std::string to_string(InitialGuess g);
Volume parse_volume(const std::string& name);
std::string to_string(Volume v);
Contact parse_contact(const std::string& name);
std::string to_string(Contact c);

}  // namespace arap
