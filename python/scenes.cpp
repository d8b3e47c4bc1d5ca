// scenes.cpp — palpate.Scene: a scene file read and validated (load_scene, parse_scene, a dict
// through palpate.scene_from_dict), and orientation_towards.
#include "module.h"

#include <filesystem>
#include <string>

namespace palpate::python {

using namespace pybind11::literals;

py::list tissue_names(const SceneDef& s) {
  py::list l;
  for (const TissueDef& t : s.tissues) l.append(t.name);
  return l;
}

// A Scene, a dict (palpate.scene_from_dict: the same YAML parser, so the same errors) or a path.
PyScene to_scene(const py::handle& h) {
  if (py::isinstance<PyScene>(h)) return h.cast<PyScene>();
  if (py::isinstance<py::dict>(h)) return py::module_::import("palpate").attr("scene_from_dict")(h).cast<PyScene>();
  return {take(load_scene(h.cast<std::filesystem::path>()))};
}

void bind_scenes(py::module_& m) {
  py::class_<PyScene>(m, "Scene", "A scene file's contents (a SceneDef), validated.")
      .def_property_readonly("name", [](const PyScene& s) { return s.def.name; })
      .def_property_readonly("file", [](const PyScene& s) { return s.def.file; })
      .def_property_readonly("dt", [](const PyScene& s) { return s.def.dt; })
      .def_property_readonly("duration", [](const PyScene& s) { return s.def.duration; })
      .def_property_readonly("output", [](const PyScene& s) { return s.def.output; })
      .def_property_readonly("tool_kind", [](const PyScene& s) { return s.def.tool.kind; })
      .def_property_readonly("has_probe", [](const PyScene& s) { return s.def.probe.has_value(); })
      .def_property_readonly("has_anatomy", [](const PyScene& s) { return s.def.anatomy.has_value(); })
      .def_property_readonly("warnings", [](const PyScene& s) { return s.def.warnings; },
                             "What loads but looks wrong (a scripted needle moved sideways to its shaft): "
                             "each names the file, line and key and what to do.")
      .def_property_readonly("tissues", [](const PyScene& s) { return tissue_names(s.def); },
                             "Tissue names in scene order (the anatomy's layers are added when it is built).")
      .def("__repr__", [](const PyScene& s) { return "<palpate.Scene '" + s.def.name + "' from '" + s.def.file.string() + "'>"; });

  m.def("load_scene", [](const std::filesystem::path& file) { return PyScene{take(load_scene(file))}; }, "file"_a,
        "Read and validate a YAML scene; palpate.Error names the file, line and key.");
  m.def("parse_scene",
        [](const std::string& text, const std::string& name, const std::filesystem::path& base_dir) {
          return PyScene{take(parse_scene(text, name, base_dir))};
        },
        "text"_a, "name"_a = "<text>", "base_dir"_a = std::filesystem::path(),
        "A scene from YAML text: `name` stands for the file in messages, `base_dir` resolves paths.");
  m.def("orientation_towards",
        [](const py::handle& axis, const py::handle& direction) {
          const Quat q = orientation_towards(to_vec3(axis, "axis"), to_vec3(direction, "direction"));
          return py::make_tuple(q.w(), q.x(), q.y(), q.z());
        },
        "axis"_a, "direction"_a,
        "The device orientation (w, x, y, z) that points a tool whose axis at identity is `axis` along `direction`.");
}

}  // namespace palpate::python
