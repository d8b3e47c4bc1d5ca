// palpate_module.cpp — the `palpate` Python module (pybind11): scenes, the Simulation stepped with
// tool poses from Python, tissue state as read-only numpy views of palpate's own memory, and the
// CLI's info / precompute / run as functions. Everything goes through the Simulation API
// (palpate/simulation.h, palpate/run.h); no pybind11 header is seen anywhere else. docs/python.md.
// The parts: convert.cpp (palpate.Error, conversions), scenes.cpp, simulation.cpp, commands.cpp.
#include "module.h"

#include <string>

PYBIND11_MODULE(_palpate, m) {
  using namespace palpate;
  using namespace palpate::python;
  m.doc() = "palpate: soft-tissue simulation with force feedback (docs/python.md)";
  g_error = PyErr_NewExceptionWithDoc("palpate.Error",
                                      "A load-time error: its text is the command line's (file, line, key).",
                                      PyExc_RuntimeError, nullptr);
  m.attr("Error") = py::handle(g_error);
  m.attr("__version__") = std::string(palpate::version());
  bind_scenes(m);
  bind_simulation(m);
  bind_commands(m);
}
