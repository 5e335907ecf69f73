#include "arap/errors.h"
#include "bindings.h"

namespace arap_python {

// ArapError(message).code is the kind of error as arap::error_code_name() names it
// ("non-finite value", "index out of range", "invalid input", ...).
void bind_errors(py::module_& m) {
  static py::exception<arap::Error> arap_error(m, "ArapError", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const arap::Error& e) {
      py::object exc = py::handle(arap_error.ptr())(e.what());
      exc.attr("code") = arap::error_code_name(e.code());
      PyErr_SetObject(arap_error.ptr(), exc.ptr());
    }
  });
}

}  // namespace arap_python
