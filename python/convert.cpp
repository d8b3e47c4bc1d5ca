// convert.cpp — palpate.Error and the conversions between palpate's types and Python's.
#include "module.h"

#include <cmath>
#include <string>

namespace palpate::python {

using namespace pybind11::literals;

PyObject* g_error = nullptr;

[[noreturn]] void raise(const Error& e) {
  PyErr_SetString(g_error, e.message.c_str());
  throw py::error_already_set();
}
void check(const Status& s) {
  if (!s) raise(s.error());
}

py::array_t<double> vec3_copy(const Vec3& v) {
  py::array_t<double> a(3);
  auto m = a.mutable_unchecked<1>();
  for (int i = 0; i < 3; ++i) m(i) = v[i];
  return a;
}

Vec3 to_vec3(const py::handle& h, const char* what) {
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(h);
  if (!a || a.size() != 3) throw py::value_error(std::string(what) + ": expected 3 numbers (m)");
  return Vec3(a.data()[0], a.data()[1], a.data()[2]);
}

// A quaternion from Python: (w, x, y, z), normalised; None = identity.
Quat to_quat(const py::handle& h) {
  if (h.is_none()) return Quat::Identity();
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(h);
  if (!a || a.size() != 4) throw py::value_error("orientation: expected a quaternion (w, x, y, z)");
  Quat q(a.data()[0], a.data()[1], a.data()[2], a.data()[3]);
  if (!(q.norm() > 0) || !std::isfinite(q.norm())) throw py::value_error("orientation: a zero or non-finite quaternion");
  return q.normalized();
}

py::dict timing(const TimingFigures& t) { return py::dict("median"_a = t.median, "p99"_a = t.p99, "max"_a = t.max); }

py::dict safety_dict(const SafetyCounters& c) {
  return py::dict("non_finite"_a = c.non_finite, "step_failed"_a = c.step_failed, "clamped"_a = c.clamped,
                  "rate_limited"_a = c.rate_limited, "overrun"_a = c.overrun, "stalled"_a = c.stalled,
                  "device_failed"_a = c.device_failed, "blade_teleport"_a = c.blade_teleport);
}

py::dict metrics_dict(const TrainingMetrics& m) {
  auto opt = [](double v) -> py::object { return v < 0 ? py::object(py::none()) : py::float_(v); };
  return py::dict("outcome"_a = outcome_name(m.outcome), "skin_punctures"_a = m.skin_punctures,
                  "passes"_a = m.passes, "redirections"_a = m.redirections, "flashback"_a = m.flashback,
                  "flashback_time"_a = m.flashback ? py::object(py::float_(m.flashback_time)) : py::object(py::none()),
                  "first_skin_puncture"_a = opt(m.first_skin_puncture), "time_to_flashback"_a = opt(m.time_to_flashback),
                  "deepest_depth"_a = m.deepest_depth, "peak_force"_a = m.peak_force,
                  "arterial_flashback"_a = m.arterial_flashback,
                  "arterial_flashback_time"_a = m.arterial_flashback ? py::object(py::float_(m.arterial_flashback_time))
                                                                     : py::object(py::none()));
}

py::dict stages_dict(const std::array<TimingFigures, kTickStageCount>& stages) {
  py::dict d;
  for (size_t i = 0; i < kTickStageCount; ++i) d[tick_stage_name(TickStage(i))] = timing(stages[i]);
  return d;
}

}  // namespace palpate::python
