// SPDX-License-Identifier: Apache-2.0
// Conversions between Python values and the library's JSON options, and the progress bridge.
#include "common.hpp"

#include <terracl/json_limits.hpp>

#include <fmt/format.h>

namespace terracl::python {

json to_json(py::handle v, const std::string& where) {
  // As deep as the library's own JSON limit (terracl/json_limits.hpp): a self-referencing list
  // must be an error, not a stack overflow.
  const auto depth = std::count(where.begin(), where.end(), '/');
  if (depth > 64) throw py::value_error(fmt::format("{}: nested deeper than 64 levels", where));
  if (v.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>();
  if (py::isinstance<py::int_>(v)) {
    // Beyond int64 (steps=2**63 said "Unable to cast"): a float, so that the option's range check
    // names the accepted range.
    int overflow = 0;
    const long long i = PyLong_AsLongLongAndOverflow(v.ptr(), &overflow);
    if (!overflow) return int64_t(i);
    const double d = PyLong_AsDouble(v.ptr());
    if (d == -1.0 && PyErr_Occurred()) {
      PyErr_Clear();
      throw py::value_error(fmt::format("{}: the integer {} is too large for any option", where.empty() ? "/" : where,
                                        abbreviate(py::str(v).cast<std::string>(), 30)));
    }
    return d;
  }
  if (py::isinstance<py::float_>(v)) return v.cast<double>();
  if (py::isinstance<py::str>(v)) return v.cast<std::string>();
  if (py::isinstance<py::dict>(v)) {
    json o = json::object();
    for (auto [k, item] : v.cast<py::dict>()) {
      if (!py::isinstance<py::str>(k))
        throw py::type_error(fmt::format("{}: dictionary keys must be strings, got {}", where.empty() ? "/" : where,
                                         py::repr(k).cast<std::string>()));
      const std::string key = k.cast<std::string>();
      o[key] = to_json(item, where + "/" + key);
    }
    return o;
  }
  if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
    json a = json::array();
    size_t i = 0;
    for (auto item : v) a.push_back(to_json(item, where + "/" + std::to_string(i++)));
    return a;
  }
  // numpy scalars and arrays (points as an (N, 2) array): through their Python equivalents.
  if (py::hasattr(v, "tolist") && py::hasattr(v, "dtype")) return to_json(v.attr("tolist")(), where);
  if (py::isinstance<py::bytes>(v) || !py::hasattr(v, "__fspath__"))
    throw py::type_error(fmt::format("{}: cannot pass a {} as an option value (expected a number, string, bool, "
                                     "list or dict)",
                                     where.empty() ? "/" : where, py::str(v.get_type().attr("__name__")).cast<std::string>()));
  return py::str(v.attr("__fspath__")()).cast<std::string>();  // pathlib.Path
}

py::object from_json(const json& j) {
  switch (j.type()) {
    case json::value_t::null: return py::none();
    case json::value_t::boolean: return py::bool_(j.get<bool>());
    case json::value_t::number_integer: return py::int_(j.get<int64_t>());
    case json::value_t::number_unsigned: return py::int_(j.get<uint64_t>());
    case json::value_t::number_float: return py::float_(j.get<double>());
    case json::value_t::string: return py::str(j.get<std::string>());
    case json::value_t::array: {
      py::list l;
      for (const auto& e : j) l.append(from_json(e));
      return std::move(l);
    }
    case json::value_t::object: {
      py::dict d;
      for (const auto& [k, e] : j.items()) d[py::str(k)] = from_json(e);
      return std::move(d);
    }
    default: return py::none();
  }
}

namespace {
thread_local int t_callback_depth = 0;  // progress callbacks running on this thread
}  // namespace

void refuse_from_callback() {
  if (t_callback_depth > 0) {
    PyErr_SetString(PyExc_RuntimeError,
                    "terracl: a stage cannot be called from inside a progress callback (the running stage holds the "
                    "device); call it after the stage returns");
    throw py::error_already_set();
  }
}

void require_callable(py::handle callback, const char* what) {
  if (!callback.is_none() && !PyCallable_Check(callback.ptr()))
    throw py::type_error(fmt::format("{} must be callable (callback(fraction, message)) or None, got {}", what,
                                     py::str(callback.get_type().attr("__name__")).cast<std::string>()));
}

ProgressBridge::~ProgressBridge() {
  if (m_error) {
    py::gil_scoped_acquire gil;
    Py_DECREF(m_error);
  }
}

Progress ProgressBridge::progress() {
  return [this](double fraction, const std::string& message) -> bool {
    py::gil_scoped_acquire gil;
    if (m_error) return false;
    try {
      // Ctrl-C while the GIL was released: its KeyboardInterrupt surfaces here (main thread only).
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      if (m_callback.is_none()) return true;
      struct Depth {
        Depth() { ++t_callback_depth; }
        ~Depth() { --t_callback_depth; }
      } depth;
      py::object r = m_callback(fraction, message);
      return r.is_none() || PyObject_IsTrue(r.ptr()) == 1;
    } catch (py::error_already_set& e) {
      m_error = e.value().inc_ref().ptr();
      return false;
    }
  };
}

void ProgressBridge::raise_cancelled(const Cancelled& e) {
  // GIL held here (run_released's release scope has ended).
  const std::string full = e.what();
  const std::string prefix = e.stage() + ": ";
  const std::string message = full.rfind(prefix, 0) == 0 ? full.substr(prefix.size()) : full;
  py::object exc = py::reinterpret_borrow<py::object>(cancelled_type())(py::str(full));
  exc.attr("stage") = e.stage();
  exc.attr("message") = message;
  if (m_error && PyErr_GivenExceptionMatches(m_error, PyExc_KeyboardInterrupt)) {
    PyObject* interrupt = m_error;  // the reference goes to PyErr_Restore
    m_error = nullptr;
    PyErr_Restore(PyObject_Type(interrupt), interrupt, PyException_GetTraceback(interrupt));
    throw py::error_already_set();
  }
  if (m_error) {
    // Both steal a reference; the bridge's own goes to the cause, so the next call starts clean
    // (a Session keeps its bridge across calls).
    PyException_SetContext(exc.ptr(), py::reinterpret_borrow<py::object>(m_error).release().ptr());
    PyException_SetCause(exc.ptr(), m_error);
    m_error = nullptr;
  }
  PyErr_SetObject(cancelled_type(), exc.ptr());
  throw py::error_already_set();
}

}  // namespace terracl::python
