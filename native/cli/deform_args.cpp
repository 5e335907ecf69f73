#include "deform_args.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <optional>
#include <sstream>
#include <utility>

#include "arap/errors.h"
#include "arap/io/files.h"
#include "arap/io/numbers.h"

namespace arap::cli {

namespace {

// The text of --help. In it, {NAME} stands for the default of option NAME as
// users write it, {NAME choices} for its choices ("a | b | c") and {NAME list}
// for one line per choice with its note from kChoiceNotes, the default's
// marked: every default and choice it prints comes from arap::option_specs().
const char* const kUsageTemplate = R"(Usage:
  arap-deform --scenario S.json [--max-iterations N] [options] --output OUT.off [--report R.json]
  arap-deform INPUT.obj [--fixed fixed.txt] --handle handle.txt --translate DX,DY,DZ
              [--rotate AXIS,DEGREES] [--handle h2.txt --translate ...] ... [options] --output OUT.obj

Deforms a mesh as-rigidly-as-possible (Sorkine & Alexa 2007): fixed vertices
stay at rest, handle vertices move to their targets, the rest follows.

Inputs:
  --scenario S.json     scenario file: {"mesh": path relative to the JSON file,
                        "fixed": [...], "handles": [{"vertices": [...],
                        "matrix": 4x4 row-major affine, "translate": [x,y,z]}]};
                        handle target = matrix * rest + translate
  INPUT                 mesh (.off .obj .ply .stl); every face is kept, polygons
                        are fan-triangulated for the solver and written as given
  --fixed FILE          whitespace-separated 0-based vertex indices held at rest
  --handle FILE         vertex indices moved rigidly by the flags that follow it:
  --translate DX,DY,DZ    translation of the current handle (default 0,0,0)
  --rotate AXIS,DEG       rotation about x, y or z through the handle's rest
                          centroid, applied before the translation
  A vertex both fixed and in a handle stays fixed (fixed wins); a vertex in
  two handles follows the first of them (the first handle wins); a warning
  names the group that kept the vertex.

Solver options (the defaults solve until the pose has settled):
  --method NAME         how the energy is minimised:
{method list}
  --max-iterations N    safety cap on the iterations (default {max_iterations}); a solve that
                        reaches it says so on stderr
  --tolerance T         stop when an iteration lowers the energy by <= T * E
                        (default {tolerance}; 0 = run until the energy stops falling
                        or the cap)
  --init NAME           first guess: {init choices} (default {init})
  --weights NAME        {weights choices} (default {weights})
  --threads K           worker threads (default {threads})
  --anderson-window M   Anderson window (default {anderson_window}); alone it implies --method anderson
  --volume MODE         what keeps thick parts from losing volume where they bend:
{volume list}
  --infill-resolution N lattice cells along the mesh's longest side (default {infill_resolution})
  --contact MODE        none (default) or self: the surface never passes through
                        itself, parts stay a gap apart (docs/contact.md);
                        quasi-newton or local-global
  The textbook iteration of the paper, e.g. to compare energies with other
  implementations: --volume none --method local-global --max-iterations N
  --tolerance 0 (with a volume mode, local-global runs quasi-newton).
  The flags are named after the solver's options; --iterations and --anderson
  are accepted as the short forms of --max-iterations and --anderson-window.

Output:
  --output OUT          result mesh (.off .obj .ply), same faces as the input
  --report R.json       timings, energies per iteration and mesh checks
  --quiet               no per-iteration energy log on stdout
  --help                this text

Exit status: 0 on success; 2 on bad input (arguments, unreadable or malformed
files, out-of-range indices, non-finite targets), with one line on stderr and
no output or report file written; 1 on an internal error.
)";

// What each method and volume mode does, for {method list} and {volume list}:
// lines of the note, the first beside the name.
const std::map<std::string, std::vector<const char*>> kChoiceNotes = {
    {"quasi-newton",
     {"L-BFGS with the factored Laplacian as its", "first Hessian and a line search (Liu et",
      "al. 2017): 4-5x less CPU to the same", "minimum than local-global"}},
    {"local-global",
     {"the textbook alternation of Sorkine &", "Alexa 2007, one local and one global step", "per iteration"}},
    {"anderson",
     {"local-global with Anderson acceleration", "(Peng et al. 2018), window --anderson-window M;",
      "solves Surface Only unless --volume is given"}},
    {"none", {"surface ARAP only (the paper's energy): its", "pose depends on the tessellation"}},
    {"global",
     {"the enclosed volume of every closed part kept", "exactly (open parts are left alone);",
      "quasi-newton or local-global"}},
    {"infill",
     {"a coarse lattice filling the inside, posed", "as-rigid-as-possible with the surface bound",
      "to it: keeps local volume and cross-sections,", "on any mesh (open ones too), and the same",
      "pose at any tessellation"}},
};

// --init warm: one solve has no previous solution to start from.
bool refused_here(const std::string& option, const std::string& choice) { return option == "init" && choice == "warm"; }

// A number as users write it: 1000, 0.5, 1e-6.
std::string shown(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", x);
  std::string s = text;
  const std::size_t e = s.find('e');
  if (e == std::string::npos) return s;
  std::size_t digits = e + 1;
  if (s[digits] == '+')
    s.erase(digits, 1);
  else if (s[digits] == '-')
    ++digits;
  while (digits + 1 < s.size() && s[digits] == '0') s.erase(digits, 1);
  return s;
}

std::string default_of(const OptionSpec& spec) {
  const Options defaults;
  return spec.kind == OptionKind::Choice ? spec.get_choice(defaults) : shown(spec.get_number(defaults));
}

std::string choices_of(const OptionSpec& spec) {
  std::string out;
  for (const std::string& c : spec.choices)
    if (!refused_here(spec.name, c)) out += (out.empty() ? "" : " | ") + c;
  return out;
}

// One line per choice, its note in a column after the longest name; " (default)" after the default's.
std::string list_of(const OptionSpec& spec) {
  std::size_t width = 0;
  for (const std::string& c : spec.choices) width = std::max(width, c.size());
  const std::string indent(26, ' '), note_indent(26 + width + 2, ' ');
  const std::string default_choice = default_of(spec);
  std::string out;
  for (const std::string& c : spec.choices) {
    const auto found = kChoiceNotes.find(c);
    const std::vector<const char*> note = found == kChoiceNotes.end() ? std::vector<const char*>{""} : found->second;
    for (std::size_t k = 0; k < note.size(); ++k) {
      std::string line = k == 0 ? indent + c + std::string(width + 2 - c.size(), ' ') : note_indent;
      line += note[k];
      if (c == default_choice && k + 1 == note.size()) line += " (default)";
      while (!line.empty() && line.back() == ' ') line.pop_back();
      out += (out.empty() ? "" : "\n") + line;
    }
  }
  return out;
}

}  // namespace

std::string deform_usage() {
  std::string text = kUsageTemplate;
  auto fill = [&](const std::string& placeholder, const std::string& value) {
    for (std::size_t at = text.find(placeholder); at != std::string::npos;
         at = text.find(placeholder, at + value.size()))
      text.replace(at, placeholder.size(), value);
  };
  for (const OptionSpec& spec : option_specs()) {
    const std::string name = spec.name;
    fill("{" + name + " list}", list_of(spec));
    fill("{" + name + " choices}", choices_of(spec));
    fill("{" + name + "}", default_of(spec));
  }
  return text;
}

namespace {

// A value for a one-line message: at most 40 characters of it, quoted, bytes outside printable ASCII as \xNN.
std::string quoted(const std::string& text) {
  std::string out = "'";
  for (const char c : text.substr(0, 40)) {
    const auto byte = static_cast<unsigned char>(c);
    char escaped[5];
    std::snprintf(escaped, sizeof escaped, "\\x%02x", byte);
    out += byte >= 0x20 && byte < 0x7f ? std::string(1, c) : std::string(escaped);
  }
  return out + (text.size() > 40 ? "'..." : "'");
}

// A finite decimal number (io::parse_finite: no spaces, hex, NaN or Inf); -0 is 0.
double parse_number(const std::string& flag, const std::string& s) {
  double v = 0;
  if (!io::parse_finite(s, v)) throw UsageError(flag + " expects a finite number, got " + quoted(s));
  return v + 0.0;
}

// The solver options on the command line: flag -> arap::option_specs() name,
// which gives their parsing, limits and messages. The flags are the names with '-' for '_'.
constexpr std::pair<const char*, const char*> kOptionFlags[] = {{"--method", "method"},
                                                                {"--weights", "weights"},
                                                                {"--init", "init"},
                                                                {"--max-iterations", "max_iterations"},
                                                                {"--tolerance", "tolerance"},
                                                                {"--threads", "threads"},
                                                                {"--anderson-window", "anderson_window"},
                                                                {"--volume", "volume"},
                                                                {"--infill-resolution", "infill_resolution"},
                                                                {"--contact", "contact"}};

// The short forms older scripts use, each the same option as its flag.
constexpr std::pair<const char*, const char*> kShortFlags[] = {{"--iterations", "max_iterations"},
                                                               {"--anderson", "anderson_window"}};

const char* option_of_flag(const std::string& flag) {
  for (const auto& [f, name] : kOptionFlags)
    if (flag == f) return name;
  for (const auto& [f, name] : kShortFlags)
    if (flag == f) return name;
  return nullptr;
}

std::string flag_of_option(const std::string& name) {
  for (const auto& [flag, option] : kOptionFlags)
    if (name == option) return flag;
  return "--" + name;
}

// Sets the option behind `flag` from its text, within the option's limits.
void set_option_from_flag(Options& options, const std::string& flag, const char* name, const std::string& text) {
  const std::string key = name;  // named: the table's entry outlives it, but a temporary argument looks dangling
  const OptionSpec& spec = option_spec(key);
  auto refuse = [&] { throw UsageError(flag + " expects " + option_limits(spec) + ", got " + quoted(text)); };
  double v = 0;
  long long integer = 0;
  if (spec.kind == OptionKind::Integer && !io::parse_integer(text, integer)) refuse();
  if (spec.kind == OptionKind::Real && !io::parse_finite(text, v)) refuse();
  if (spec.kind == OptionKind::Integer) v = static_cast<double>(integer);
  try {
    if (spec.kind == OptionKind::Choice)
      arap::set_option(options, spec, text);
    else
      arap::set_option(options, spec, v + 0.0, text);  // -0 is 0
  } catch (const Error&) {
    refuse();
  }
}

std::vector<std::string> split_commas(const std::string& s) {
  std::vector<std::string> parts;
  std::stringstream ss(s);
  std::string part;
  while (std::getline(ss, part, ',')) parts.push_back(part);
  if (!s.empty() && s.back() == ',') parts.push_back("");
  return parts;
}

Eigen::Vector3d parse_vector(const std::string& flag, const std::string& s) {
  const auto parts = split_commas(s);
  if (parts.size() != 3) throw UsageError(flag + " expects DX,DY,DZ, got " + quoted(s));
  return {parse_number(flag, parts[0]), parse_number(flag, parts[1]), parse_number(flag, parts[2])};
}

}  // namespace

DeformArgs parse_deform_args(int argc, const char* const* argv) {
  DeformArgs a;
  bool method_given = false, infill_resolution_given = false, volume_given = false;
  std::string anderson_flag;  // the spelling of the Anderson window's flag given, if any
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError(arg + " needs a value");
      return argv[++i];
    };
    auto current_handle = [&]() -> HandleArg& {
      if (a.handles.empty()) throw UsageError(arg + " must follow a --handle FILE");
      return a.handles.back();
    };
    if (arg == "--help" || arg == "-h") {
      a.help = true;
    } else if (arg == "--scenario") {
      a.scenario = value();
    } else if (arg == "--fixed") {
      if (!a.fixed_file.empty()) throw UsageError("--fixed given twice");
      a.fixed_file = value();
    } else if (arg == "--handle") {
      a.handles.push_back(HandleArg{value()});
    } else if (arg == "--translate") {
      HandleArg& h = current_handle();
      h.translate = parse_vector(arg, value());
    } else if (arg == "--rotate") {
      HandleArg& h = current_handle();
      const std::string v = value();
      const auto parts = split_commas(v);
      if (parts.size() != 2 || parts[0].size() != 1 || parts[0].find_first_of("xyz") != 0)
        throw UsageError("--rotate expects AXIS,DEGREES with AXIS x, y or z, got " + quoted(v));
      h.rotate_axis = parts[0][0] - 'x';
      h.rotate_degrees = parse_number(arg, parts[1]);
    } else if (const char* option = option_of_flag(arg)) {
      const std::string text = value();
      if (refused_here(option, text)) throw UsageError(arg + " " + text + " makes no sense for a single solve");
      set_option_from_flag(a.options, arg, option, text);
      method_given = method_given || arg == "--method";
      if (std::string(option) == "anderson_window") anderson_flag = arg;
      infill_resolution_given = infill_resolution_given || arg == "--infill-resolution";
      volume_given = volume_given || arg == "--volume";
    } else if (arg == "--output" || arg == "-o") {
      a.output = value();
    } else if (arg == "--report") {
      a.report = value();
    } else if (arg == "--quiet" || arg == "-q") {
      a.quiet = true;
    } else if (arg.size() > 1 && arg[0] == '-') {
      throw UsageError("unknown option " + quoted(arg));
    } else {
      if (!a.input.empty()) throw UsageError("more than one input mesh (" + quoted(a.input) + ", " + quoted(arg) + ")");
      a.input = arg;
    }
  }
  if (a.help) return a;
  // --anderson-window M (or --anderson M) alone keeps its old meaning: the Anderson-accelerated alternation.
  if (!anderson_flag.empty() && !method_given) a.options.method = Method::Anderson;
  if (!volume_given) surface_only_for_anderson(a.options);
  if (!anderson_flag.empty() && a.options.method != Method::Anderson)
    throw UsageError(anderson_flag + " applies to --method anderson only");
  if (infill_resolution_given && a.options.volume != Volume::Infill)
    throw UsageError("--infill-resolution applies to --volume infill only");
  if (const std::optional<OptionConflict> conflict = method_conflict(a.options))
    throw UsageError(flag_of_option(conflict->option) + " " + conflict->value +
                     " works with --method quasi-newton or local-global, not anderson");
  if (a.scenario.empty() == a.input.empty()) throw UsageError("give either --scenario S.json or an INPUT mesh");
  if (!a.scenario.empty() && (!a.fixed_file.empty() || !a.handles.empty()))
    throw UsageError("--fixed/--handle cannot be combined with --scenario");
  if (!a.input.empty() && a.fixed_file.empty() && a.handles.empty())
    throw UsageError("an INPUT mesh needs --fixed and/or --handle constraints");
  if (a.output.empty()) throw UsageError("--output is required");
  const std::string ext = io::extension_of(a.output);
  if (ext != "off" && ext != "obj" && ext != "ply")
    throw UsageError("--output must end in .off, .obj or .ply, got " + quoted(a.output));
  if (!a.report.empty() && a.report == a.output) throw UsageError("--report and --output name the same file");
  return a;
}

}  // namespace arap::cli
