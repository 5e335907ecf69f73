#include <algorithm>
#include <string>
#include <vector>

#include "arap/constraints.h"
#include "arrays.h"
#include "bindings.h"

namespace arap_python {

namespace {

void bind_constraint_set_class(py::module_& m) {
  py::class_<arap::ConstraintSet>(
      m, "ConstraintSet",
      "Constrained vertices by the rules of arap/constraints.h (docs/design.md, 'Constraints: the rules').")
      .def_property_readonly(
          "constrained",
          [](const arap::ConstraintSet& s) {
            py::array_t<int64_t> a(static_cast<py::ssize_t>(s.constrained.size()));
            std::copy(s.constrained.begin(), s.constrained.end(), a.mutable_data());
            return a;
          },
          "int64 vertex indices for Solver.bind(): the fixed ones first, then each kept handle's block")
      .def_readonly("fixed_count", &arap::ConstraintSet::fixed_count)
      .def_property_readonly(
          "handles",
          [](const arap::ConstraintSet& s) {
            py::list out;
            for (const arap::HandleBlock& b : s.handles) out.append(py::make_tuple(b.handle, b.start, b.stop));
            return out;
          },
          "(handle, start, stop) per kept handle: rows [start, stop) of `constrained` follow input handle `handle`")
      .def_readonly("warnings", &arap::ConstraintSet::warnings);
}

arap::ConstraintSet constraint_set(int vertex_count, const py::object& fixed, const std::string& fixed_label,
                                   const py::list& handles) {
  arap::ConstraintGroup fixed_group{fixed_label, {}};
  if (!fixed.is_none()) fixed_group.vertices = to_indices(fixed, fixed_label);
  std::vector<arap::ConstraintGroup> groups;
  for (const py::handle h : handles) {
    const py::tuple pair = py::reinterpret_borrow<py::tuple>(h);
    if (!py::isinstance<py::tuple>(h) || pair.size() != 2)
      throw py::type_error("handles: expected (label, vertex indices) pairs");
    const std::string label = py::cast<std::string>(pair[0]);
    groups.push_back({label, to_indices(pair[1], label)});
  }
  py::gil_scoped_release release;
  return arap::make_constraint_set(vertex_count, fixed_group, groups);
}

}  // namespace

void bind_constraints(py::module_& m) {
  bind_constraint_set_class(m);
  m.def("constraint_set", &constraint_set, py::arg("vertex_count"), py::arg("fixed"), py::arg("fixed_label"),
        py::arg("handles"),
        "Fixed first, then each handle's vertices; fixed wins, the first handle wins; warnings name the group\n"
        "that took the vertices. handles: a list of (label, vertex indices); labels name the groups in messages\n"
        "(\"handle 'Arm'\", \"the fixed group 'Feet'\").");
}

}  // namespace arap_python
