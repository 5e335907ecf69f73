#include <string>

#include "arap/errors.h"
#include "arap/options.h"
#include "bindings.h"

namespace arap_python {

namespace {

// An option's value as Python sees it: str for a choice, int or float for a number.
py::object option_value(const arap::OptionSpec& spec, const arap::Options& o) {
  if (spec.kind == arap::OptionKind::Choice) return py::str(spec.get_choice(o));
  if (spec.kind == arap::OptionKind::Integer) return py::int_(static_cast<long long>(spec.get_number(o)));
  return py::float_(spec.get_number(o));
}

// A limit as Python sees it: int for an Integer option, float for a Real one.
py::object limit_value(const arap::OptionSpec& spec, double limit) {
  return spec.kind == arap::OptionKind::Integer ? py::object(py::int_(static_cast<long long>(limit)))
                                                : py::object(py::float_(limit));
}

// Sets one option from a Python value of its type (str for a choice, int for
// an integer, int or float for a number); arap::set_option() checks its limits.
void set_option_from_python(arap::Options& o, const std::string& name, const py::handle& value) {
  const arap::OptionSpec& spec = arap::option_spec(name);
  if (spec.kind == arap::OptionKind::Choice) {
    if (!py::isinstance<py::str>(value)) throw py::type_error(name + ": expected one of " + arap::option_limits(spec));
    arap::set_option(o, spec, py::cast<std::string>(value));
    return;
  }
  const bool is_int = py::isinstance<py::int_>(value) && !py::isinstance<py::bool_>(value);
  if (spec.kind == arap::OptionKind::Integer && !is_int) throw py::type_error(name + ": expected an int");
  if (!is_int && !py::isinstance<py::float_>(value)) throw py::type_error(name + ": expected a number");
  arap::set_option(o, spec, py::cast<double>(value), std::string(py::str(value)));
}

// `o` with `kwargs` (option names) set, unchecked.
arap::Options set_from(arap::Options o, const py::kwargs& kwargs) {
  for (const auto& [key, value] : kwargs) set_option_from_python(o, py::cast<std::string>(key), value);
  return o;
}

// The defaults with `kwargs` set, as bind() takes them: Surface Only for a method anderson given without a volume.
arap::Options unchecked_bind_options(const py::kwargs& kwargs) {
  arap::Options o = set_from(arap::Options(), kwargs);
  if (!kwargs.contains("volume")) arap::surface_only_for_anderson(o);
  return o;
}

}  // namespace

arap::Options with_options(arap::Options o, const py::kwargs& kwargs) {
  o = set_from(o, kwargs);
  arap::check_options(o);
  return o;
}

arap::Options bind_options(const py::kwargs& kwargs) {
  const arap::Options o = unchecked_bind_options(kwargs);
  arap::check_options(o);
  return o;
}

arap::Options with_unbound_options(const arap::Options& bound, const py::kwargs& kwargs) {
  const arap::Options o = with_options(bound, kwargs);
  for (const arap::OptionSpec& spec : arap::option_specs())
    if (spec.needs_bind && option_value(spec, o).not_equal(option_value(spec, bound)))
      throw arap::Error(arap::ErrorCode::InvalidInput,
                        std::string("the option ") + spec.name + " is fixed at bind(): bind again to change it");
  return o;
}

// One property per option (OPTIONS); those fixed at bind() (weights, volume) are read-only.
void bind_option_properties(py::class_<arap::Solver>& solver) {
  for (const arap::OptionSpec& spec : arap::option_specs()) {
    const std::string name = spec.name;
    auto get =
        py::cpp_function([name](const arap::Solver& s) { return option_value(arap::option_spec(name), s.options()); });
    if (spec.needs_bind) {
      solver.def_property_readonly(spec.name, get);
      continue;
    }
    solver.def_property(spec.name, get, py::cpp_function([name](arap::Solver& s, const py::object& value) {
                          py::dict one;
                          one[py::str(name)] = value;
                          idle(s).options() = with_options(s.options(), py::kwargs(one));
                        }),
                        ("the option " + name + ": " + arap::option_limits(spec)).c_str());
  }
}

// Every option: {name: {"default", "min", "max"} or {"default", "choices"}}, defaults as in arap::Options().
void bind_option_table(py::module_& m) {
  py::dict specs;
  const arap::Options defaults;
  for (const arap::OptionSpec& spec : arap::option_specs()) {
    py::dict d;
    d["default"] = option_value(spec, defaults);
    if (spec.kind == arap::OptionKind::Choice) {
      d["choices"] = py::cast(spec.choices);
    } else {
      d["kind"] = spec.kind == arap::OptionKind::Integer ? "int" : "float";
      d["min"] = limit_value(spec, spec.min);
      d["max"] = limit_value(spec, spec.max);
    }
    specs[spec.name] = d;
  }
  m.attr("OPTIONS") = specs;
}

// method_conflicts(**options): the options (the others at their defaults, the volume as bind() takes it) that cannot
// be combined with the method,
// [(option, value, reason)], by arap::method_conflicts(); each option's own limits are checked as configure() does.
void bind_method_conflicts(py::module_& m) {
  m.def(
      "method_conflicts",
      [](const py::kwargs& kwargs) {
        py::list found;
        for (const arap::OptionConflict& c : arap::method_conflicts(unchecked_bind_options(kwargs)))
          found.append(py::make_tuple(c.option, c.value, c.reason));
        return found;
      },
      "The options (by name; the others at their defaults) that cannot be combined with the method: a list of "
      "(option, value, reason), empty when they all can.");
}

}  // namespace arap_python
