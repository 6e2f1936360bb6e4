// The compiled part of the Python package `porthole` (python/porthole/__init__.py wraps it): the
// libraries' functions for notebooks. Options are keyword arguments (a typo raises TypeError); bad
// input raises ValueError naming the Python keyword. Results leave here as the CLI's JSON (Python
// dicts) or numpy arrays; the package turns them into typed objects (python/porthole/_results.py).
#include <pybind11/pybind11.h>

#include <optional>
#include <string>
#include <string_view>

#include "porthole/core/error.h"
#include "porthole/core/field_names.h"
#include "register.h"

PYBIND11_MODULE(_porthole, m) {
  m.doc() = "porthole's compiled bindings (use the package `porthole`, which wraps them)";
  m.attr("__version__") = PORTHOLE_VERSION;
  // Another field a library rule names (`extrapolate`) in Python's words.
  pybind11::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const porthole::InvalidInput& e) {
      // Then any other field a rule names is a keyword: `free` → free=.
      const porthole::InvalidInput named = porthole::RenameFields(
          {{"extrapolate", "extrapolate=True"}, {"allow_adapter", "allow_adapter=True"}}, e, /*keep_unknown=*/true);
      const std::string rule = std::string(named.what()).substr(named.field().size() + 2);
      const porthole::InvalidInput py(
          named.field(), porthole::RenameQuotedFieldsBy([](std::string_view) { return std::optional<std::string>(); },
                                                        rule, "="));
      PyErr_SetString(PyExc_ValueError, py.what());
    }
  });
  porthole::python::RegisterMaterials(m);
  porthole::python::RegisterPorts(m);
  porthole::python::RegisterCalib(m);
  porthole::python::RegisterPlanning(m);
  porthole::python::RegisterSimulate(m);
  porthole::python::RegisterFit(m);
  porthole::python::RegisterReport(m);
  porthole::python::RegisterMeasure(m);
  porthole::python::RegisterUndistort(m);
  porthole::python::RegisterConvert(m);
  porthole::python::RegisterRender(m);
}
