// SPDX-License-Identifier: Apache-2.0
#pragma once
// Shared pieces of the terracl Python module: conversions (JSON, numpy), the device table, and
// the bridge that runs library work with the GIL released while progress callbacks run in Python.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <terracl/device.hpp>
#include <terracl/error.hpp>
#include <terracl/heightfield.hpp>
#include <terracl/progress.hpp>

#include <nlohmann/json.hpp>

#include <memory>
#include <mutex>
#include <string>

namespace py = pybind11;

// Hidden like pybind11's own types (the module is built with -fvisibility=hidden).
#pragma GCC visibility push(hidden)
namespace terracl::python {

using json = nlohmann::json;

void init_errors(py::module_& m);
void init_arrays(py::module_& m);
void init_devices(py::module_& m);
void init_stages(py::module_& m);
void init_session(py::module_& m);

/// Python value (dict, list, str, number, bool, None, numpy scalar or 1-D array) -> JSON; throws
/// TypeError naming `where` (a JSON path) for anything else.
json to_json(py::handle value, const std::string& where = "");
py::object from_json(const json& j);

/// A 2-D float32 numpy array copied into a row-major float vector (any strides); TypeError or
/// ValueError naming `what` for another dtype, ndim or an empty array.
void copy_from_array(py::handle array, const std::string& what, int& width, int& height, std::vector<float>& out);
/// A float32 (height, width) view of `data` that keeps `owner` alive (zero copy).
py::array_t<float> view_of(std::vector<float>& data, int width, int height, py::handle owner);
/// `value` as a Heightfield: a terracl.Heightfield (copied) or a 2-D float32 array.
Heightfield to_heightfield(py::handle value, const std::string& what);

/// An opened device with the lock that serialises the module's calls on it.
struct DeviceSlot {
  std::shared_ptr<Device> device;
  std::mutex mutex;
};
/// The device for `spec` (None: the one chosen by select_device, else OCL_* / the default rule;
/// int: index; str: index or name substring), opened once and kept for the process (never closed:
/// some OpenCL platforms tear down their state in atexit handlers first).
DeviceSlot& device_slot(py::handle spec);
/// The spec string of `spec` (GIL held) and the slot for it (no GIL needed: opens lazily).
std::string device_spec(py::handle spec);
DeviceSlot& open_device(const std::string& spec);

/// Opens the device on first use and holds its lock from then on (stages that need no device,
/// such as read, write, fill_depressions, never open one). Use inside run_released(nullptr, ...).
class LazyDevice {
 public:
  explicit LazyDevice(std::string spec) : m_spec(std::move(spec)) {}
  Device& operator()() {
    if (!m_slot) {
      m_slot = &open_device(m_spec);
      m_lock = std::unique_lock<std::mutex>(m_slot->mutex);
    }
    return *m_slot->device;
  }

 private:
  std::string m_spec;
  DeviceSlot* m_slot = nullptr;
  std::unique_lock<std::mutex> m_lock;
};

/// Raises RuntimeError when this thread is inside a progress callback: the stage that called the
/// callback holds the device lock, so a stage called from there waited for it forever (GIL released,
/// 0 % CPU, deaf to Ctrl-C).
void refuse_from_callback();
/// Raises TypeError unless `callback` is None or callable (a number was reported as "cancelled").
void require_callable(py::handle callback, const char* what);

/// Progress callback of one call: Python `callback(fraction, message)` run with the GIL held; a
/// False return or an exception asks the library to stop (it throws terracl::Cancelled). Also
/// checks for Ctrl-C (KeyboardInterrupt) at each report, so that a long solve stays interruptible.
class ProgressBridge {
 public:
  explicit ProgressBridge(py::object callback = py::none()) : m_callback(std::move(callback)) {
    require_callable(m_callback, "progress");
  }
  ~ProgressBridge();
  Progress progress();
  /// Rethrows `e` as terracl.Cancelled, chained (`raise ... from`) to the callback's exception;
  /// a KeyboardInterrupt (Ctrl-C) is re-raised as itself, as Python code would.
  [[noreturn]] void raise_cancelled(const Cancelled& e);
  py::object m_callback;

 private:
  PyObject* m_error = nullptr;  // owned reference to the callback's exception (GIL held when touched)
};

/// Runs `f` with the GIL released and the device lock held; turns a Cancelled into
/// terracl.Cancelled chained to the callback's exception, or into KeyboardInterrupt on Ctrl-C.
template <typename F>
auto run_released(DeviceSlot* slot, ProgressBridge& bridge, F&& f) -> decltype(f()) {
  refuse_from_callback();
  try {
    py::gil_scoped_release release;
    std::unique_lock<std::mutex> lock;
    if (slot) lock = std::unique_lock<std::mutex>(slot->mutex);
    return f();
  } catch (const Cancelled& e) {
    bridge.raise_cancelled(e);
  }
}

/// The terracl.Cancelled type (errors.cpp).
PyObject* cancelled_type();

/// Provenance written into outputs made from Python ("terracl:command" = "python: <what>").
Metadata provenance(const std::string& what);

}  // namespace terracl::python
#pragma GCC visibility pop
