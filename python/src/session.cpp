// SPDX-License-Identifier: Apache-2.0
// terracl.Session: an editing session that keeps its state on the device between calls (the
// EditSession the studio and `terracl edit` use): the gradient field, the constraints and the
// multigrid hierarchy stay resident, and each solve starts warm from the previous solution.
#include "common.hpp"

#include <terracl/edit.hpp>
#include <terracl/io.hpp>
#include <terracl/memory.hpp>

#include <fmt/format.h>

#include <filesystem>

namespace terracl::python {
namespace {

class Session {
 public:
  Session(py::object base, py::object device, py::object progress, py::object base_dir, py::object local)
      : m_slot(&device_slot(device)), m_bridge(std::move(progress)) {
    if (py::isinstance<py::str>(base) || py::hasattr(base, "__fspath__")) {
      const std::string spec = py::str(base).cast<std::string>();
      if (auto flat = parse_flat_spec(spec)) {
        m_base = std::move(*flat);
      } else {
        if (!std::filesystem::exists(spec))
          throw MissingFileError("session", fmt::format("base terrain '{}' not found", spec), spec);
        py::gil_scoped_release release;
        m_base = read_heightfield(spec);
      }
    } else {
      m_base = to_heightfield(base, "Session base");
    }
    EditOptions o;
    o.progress = m_bridge.progress();
    if (!base_dir.is_none()) o.base_dir = py::str(base_dir).cast<std::string>();
    if (!local.is_none()) o.locality = local.cast<bool>();
    run([&] {
      if (m_base.count_nodata()) fill_nodata_harmonic(m_base);
      require_memory("session", fmt::format("a {} x {} edit", m_base.width, m_base.height),
                     double(m_base.size()) * edit_host_bytes_per_cell, double(m_base.size()) * edit_device_bytes_per_cell,
                     double(m_base.size()) * 8, m_slot->device.get(), "use a smaller base (flat:WxH, or crop the DEM)");
      m_edit = std::make_unique<EditSession>(*m_slot->device, m_base, o);
      return 0;
    });
  }
  ~Session() {
    // The session's device buffers are released by another thread's call at worst; keep the lock.
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(m_slot->mutex);
    m_edit.reset();
  }

  template <typename F>
  auto run(F&& f) -> decltype(f()) {
    return run_released(m_slot, m_bridge, std::forward<F>(f));
  }
  EditSession& edit() { return *m_edit; }
  const Heightfield& base() const { return m_base; }
  ProgressBridge& bridge() { return m_bridge; }

 private:
  DeviceSlot* m_slot;
  ProgressBridge m_bridge;
  Heightfield m_base;
  std::unique_ptr<EditSession> m_edit;
};

json script_of(py::handle s) {
  if (py::isinstance<py::str>(s) || py::hasattr(s, "__fspath__")) return read_edit_script(py::str(s).cast<std::string>());
  return to_json(s, "");
}

Heightfield with_base_georef(const Heightfield& h, const Heightfield& base) {
  Heightfield out = h;
  out.georef = base.georef;
  out.metadata = base.metadata;
  return out;
}

}  // namespace

void init_session(py::module_& m) {
  py::class_<Session>(m, "Session",
                      "An editing session on the device: Session(base, device=None, progress=None, base_dir=None, "
                      "local=None). base: a Heightfield, a float32 array, a raster file or 'flat:WxH[@cell]'. "
                      "apply(script) adds operations (an edit script dict, a list of operations or a file); "
                      "height() reconstructs warm from the previous solution.")
      .def(py::init<py::object, py::object, py::object, py::object, py::object>(), py::arg("base"), py::kw_only(),
           py::arg("device") = py::none(), py::arg("progress") = py::none(), py::arg("base_dir") = py::none(),
           py::arg("local") = py::none())
      .def(
          "apply",
          [](Session& s, py::object script) {
            const json j = script_of(script);
            s.run([&] {
              s.edit().apply(j);
              return 0;
            });
          },
          py::arg("script"), "Validates every operation (errors name the JSON path), then applies them.")
      .def(
          "check", [](Session& s, py::object script) { return s.edit().check(script_of(script)); }, py::arg("script"),
          "Validates without applying; returns the warnings.")
      .def(
          "height",
          [](Session& s) {
            return s.run([&] { return with_base_georef(s.edit().height(), s.base()); });
          },
          "The current terrain (reconstructs, warm, when an operation changed anything).")
      .def(
          "solve",
          [](Session& s, bool warm) { return from_json(s.run([&] { return s.edit().solve(warm).to_json(); })); },
          py::arg("warm") = true, "Reconstructs now (warm: from the previous solution); returns the solver's figures.")
      .def("gradient", [](Session& s) { return s.run([&] { return s.edit().gradient(); }); })
      // Under the device lock: with lake operations the report fills them (a solve when stale).
      .def("report", [](Session& s) { return from_json(s.run([&] { return s.edit().report(); })); })
      .def(
          "water",
          [](Session& s) -> py::object {
            std::optional<Heightfield> w = s.run([&] { return s.edit().water(); });
            if (!w) return py::none();
            return py::cast(with_base_georef(*w, s.base()));
          },
          "The lake operations' water depth in metres (0 where dry) on the current terrain, or None without a "
          "lake (docs/authoring.md, \"Lakes\").")
      .def(
          "lakes", [](Session& s) { return from_json(s.run([&] { return s.edit().lakes(); })); },
          "Each lake's figures on the current terrain (level_m, cells, volume_m3, max_depth_m, ...).")
      .def("warnings", [](Session& s) { return s.edit().warnings(); })
      .def_property_readonly("local", [](Session& s) { return s.edit().local(); })
      .def_property_readonly("hard_cells", [](Session& s) { return s.edit().hard_cells(); })
      .def_property_readonly("base", [](Session& s) { return s.base(); })
      .def_property(
          "progress", [](Session& s) { return s.bridge().m_callback; },
          [](Session& s, py::object cb) {
            require_callable(cb, "progress");
            s.bridge().m_callback = std::move(cb);
          },
          "callback(fraction, message) -> bool|None for later calls; False or an exception cancels")
      .def("hard_constraints", [](Session& s) {
        const auto& v = s.edit().hard_constraints();
        py::array_t<float> a({py::ssize_t(s.base().height), py::ssize_t(s.base().width)});
        std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(float));
        return a;
      }, "Hard elevation constraints as a float32 array, NaN for free cells (a copy).");
}

}  // namespace terracl::python
