// SPDX-License-Identifier: Apache-2.0
// Devices: terracl.devices(), terracl.select_device(spec), and the table of opened devices that
// every call's `device=` argument goes through (same rules as the CLI's --device).
#include "common.hpp"

#include <fmt/format.h>

#include <map>

namespace terracl::python {
namespace {

struct Devices {
  std::mutex mutex;
  std::map<std::string, DeviceSlot*> by_spec;  // leaked: see device_slot()
  std::string selected;                        // select_device's spec; "" = OCL_* / default rule
};
Devices& devices() {
  static auto* d = new Devices();
  return *d;
}

std::string spec_of(py::handle spec) {
  if (spec.is_none()) return devices().selected;
  if (py::isinstance<py::bool_>(spec)) throw py::type_error("device: expected an index or a name substring, got a bool");
  if (py::isinstance<py::int_>(spec)) {
    const auto i = spec.cast<long long>();
    if (i < 0) throw py::value_error(fmt::format("device: index {} is negative (see terracl.devices())", i));
    return std::to_string(i);
  }
  if (py::isinstance<py::str>(spec)) return spec.cast<std::string>();
  if (py::hasattr(spec, "index") && py::hasattr(spec, "platform")) return std::to_string(spec.attr("index").cast<int>());
  throw py::type_error("device: expected None, an index, a name substring or a terracl.DeviceInfo");
}

}  // namespace

std::string device_spec(py::handle spec) { return spec_of(spec); }

DeviceSlot& open_device(const std::string& spec) {
  Devices& d = devices();
  std::lock_guard<std::mutex> lock(d.mutex);
  auto it = d.by_spec.find(spec);
  if (it != d.by_spec.end()) return *it->second;
  std::shared_ptr<Device> opened = Device::open(spec);  // throws terracl::Error naming the spec
  // One slot per physical device, whatever spec reached it ("0", "cpu", "pthread").
  for (auto& [s, slot] : d.by_spec)
    if (slot->device->device()() == opened->device()()) {
      d.by_spec[spec] = slot;
      return *slot;
    }
  // Never destroyed: OpenCL platforms (oclgrind's, some GPU drivers) tear down their own state in
  // atexit handlers, and releasing our objects after that corrupts their heap.
  auto* slot = new DeviceSlot();
  slot->device = std::move(opened);
  d.by_spec[spec] = slot;
  return *slot;
}

DeviceSlot& device_slot(py::handle spec_obj) {
  const std::string spec = spec_of(spec_obj);
  py::gil_scoped_release release;  // opening a platform can take a while; other threads run on
  return open_device(spec);
}

void init_devices(py::module_& m) {
  py::class_<DeviceInfo>(m, "DeviceInfo", "One OpenCL device as `terracl devices` lists it.")
      .def_readonly("index", &DeviceInfo::index)
      .def_readonly("platform", &DeviceInfo::platform)
      .def_readonly("name", &DeviceInfo::name)
      .def_readonly("type", &DeviceInfo::type)
      .def_readonly("compute_units", &DeviceInfo::compute_units)
      .def_readonly("global_mem", &DeviceInfo::global_mem)
      .def_readonly("max_alloc", &DeviceInfo::max_alloc)
      .def_readonly("local_mem", &DeviceInfo::local_mem)
      .def_readonly("max_work_group", &DeviceInfo::max_work_group)
      .def_readonly("opencl_c_version", &DeviceInfo::opencl_c_version)
      .def_readonly("driver_version", &DeviceInfo::driver_version)
      .def_readonly("launch", &DeviceInfo::launch)
      .def("__repr__", [](const DeviceInfo& i) {
        return fmt::format("terracl.DeviceInfo(index={}, name='{}', platform='{}', type={}, launch={})", i.index, i.name,
                           i.platform, i.type, i.launch);
      });
  m.def("devices", [] { return list_devices(); }, "All OpenCL devices of all platforms (as `terracl devices`).");
  m.def(
      "select_device",
      [](py::object spec) {
        DeviceSlot& slot = device_slot(spec);  // refuses a bad spec before it becomes the default
        devices().selected = spec_of(spec);
        return slot.device->info();
      },
      py::arg("spec") = py::none(),
      "Chooses the default device for later calls: an index or a name substring (as the CLI's --device); None "
      "goes back to OCL_PLATFORM / OCL_DEVICE / OCL_TYPE and the default rule (first GPU, else first device). "
      "Returns its DeviceInfo; raises terracl.Error when no device matches.");
  m.def(
      "device", [](py::object spec) { return device_slot(spec).device->info(); }, py::arg("spec") = py::none(),
      "The DeviceInfo of the device a call with device=spec runs on (default: the selected one).");
}

}  // namespace terracl::python
