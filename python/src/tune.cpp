// saulproto.tune_report(): the tuning analysis of `saulctl tune report` (libsaulproto host/tune) for Python, as the
// same JSON object --json prints (parsed by the package's __init__.py), so a notebook and a script see one schema.
#include <pybind11/pybind11.h>

#include <string>

#include "saulproto/host/tune/analysis.hpp"
#include "saulproto/host/tune/report.hpp"
#include "saulproto/host/tune/series.hpp"

namespace py = pybind11;

namespace saulpy {

void bind_tune(py::module_& m) {
  m.def(
      "tune_report_json",
      [](const std::string& path) {
        namespace tune = saul::host::tune;
        try {
          py::gil_scoped_release unlocked;  // reading and the FFTs: no Python objects touched
          return tune::to_json(tune::analyse(tune::read_series(path))).dump();
        } catch (const tune::SeriesError& e) {
          throw py::value_error(e.what());  // the file and why, as saulctl tune report prints it
        }
      },
      py::arg("path"), "The tuning report of a trace, CSV or CAN capture as a JSON text (saulctl tune report --json).");
}

}  // namespace saulpy
