// module.h — what the parts of the `palpate` Python module share (python/*.cpp): palpate.Error,
// the conversions between palpate's types and Python's, the loaded Scene, and each part's bindings.
// Internal to the module: no other target sees a pybind11 header (docs/python.md).
#pragma once

#include <palpate/palpate.h>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <array>

namespace palpate::python {

namespace py = pybind11;

// palpate.Error: a load-time error (bad scene, missing file, a value out of range), its text the
// CLI's (file, line, key). Set once by the module's init (palpate_module.cpp).
extern PyObject* g_error;

// Raise palpate.Error with the error's text.
[[noreturn]] void raise(const Error& e);
template <class T>
T take(Result<T>&& r) {
  if (!r) raise(r.error());
  return std::move(r).value();
}
void check(const Status& s);

py::array_t<double> vec3_copy(const Vec3& v);
Vec3 to_vec3(const py::handle& h, const char* what);
// A quaternion from Python: (w, x, y, z), normalised; None = identity.
Quat to_quat(const py::handle& h);
py::dict timing(const TimingFigures& t);
py::dict safety_dict(const SafetyCounters& c);
py::dict metrics_dict(const TrainingMetrics& m);
py::dict stages_dict(const std::array<TimingFigures, kTickStageCount>& stages);

// A loaded scene (a SceneDef): what Simulation and run take.
struct PyScene {
  SceneDef def;
};
py::list tissue_names(const SceneDef& s);
// A Scene, a dict (palpate.scene_from_dict: the same YAML parser, so the same errors) or a path.
PyScene to_scene(const py::handle& h);

// The bindings, one part each: Scene, load_scene, parse_scene, orientation_towards (scenes.cpp);
// Simulation and Tissue (simulation.cpp); info, precompute, run (commands.cpp).
void bind_scenes(py::module_& m);
void bind_simulation(py::module_& m);
void bind_commands(py::module_& m);

}  // namespace palpate::python
