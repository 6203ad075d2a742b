// SPDX-License-Identifier: Apache-2.0
// Stages from Python. Every stage runs exactly as `terracl <stage>` runs it (apps/cmd_stages.cpp):
// the options go through the stage table's resolve_options (same names, defaults, ranges and
// units as the CLI and pipelines), then the stage's own run function on the device. `edit`
// mirrors `terracl edit` (apps/cmd_edit.cpp), `run_pipeline` is `terracl run`.
#include "common.hpp"

#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/memory.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/render.hpp>
#include <terracl/stage.hpp>
#include <terracl/stage_memory.hpp>

#include "pipeline/builtin.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cstring>
#include <cstdio>
#include <filesystem>

namespace terracl::python {
namespace {

const StageInfo& find_stage(const std::string& name) {
  const StageInfo* s = StageRegistry::instance().find(name);
  if (!s) {
    std::string names;
    for (const auto& st : StageRegistry::instance().all()) names += (names.empty() ? "" : ", ") + st.name;
    throw UsageError("python", fmt::format("no stage named '{}' (stages: {})", name, names));
  }
  return *s;
}

// Python keyword options -> the stage's JSON options; None means "not given" (the default).
json options_of(const py::dict& kwargs) {
  json o = json::object();
  for (auto [k, v] : kwargs) {
    if (v.is_none()) continue;
    const std::string key = k.cast<std::string>();
    o[key] = to_json(v, "/" + key);
  }
  return o;
}

// Bad options are usage errors of the stage, as the CLI reports them (exit 2 there).
json resolve(const StageInfo& s, const json& options) {
  try {
    return resolve_options(s, options, s.name);
  } catch (const UsageError&) {
    throw;
  } catch (const MissingFileError&) {
    throw;  // a FileNotFoundError in Python
  } catch (const Error& e) {
    throw UsageError(s.name, std::string(e.what()).substr(e.stage().size() + 2));
  }
}

py::object run_stage(const std::string& name, py::object input, const py::dict& kwargs, py::object device,
                     py::object progress) {
  const StageInfo& s = find_stage(name);
  const json resolved = resolve(s, options_of(kwargs));
  StageData data;
  if (!input.is_none()) {
    if (py::isinstance<GradientField>(input)) {
      data.gradient = input.cast<const GradientField&>();
      data.current = DataKind::Gradient;
    } else {
      data.height = to_heightfield(input, name + " input");
      data.current = DataKind::Heightfield;
    }
  } else if (s.input != DataKind::None) {
    throw UsageError(s.name, fmt::format("needs an input {}", data_kind_name(s.input)));
  }
  if (s.input == DataKind::Gradient && data.current != DataKind::Gradient)
    throw UsageError(s.name, "needs a terracl.GradientField as input");
  const std::string spec = device_spec(device);
  // The memory column, as `terracl <stage>` checks it before running (a CPU device's buffers
  // count as host memory): a stage too large is refused here instead of killed half-way.
  {
    RasterShape shape;
    if (data.height) shape = {data.height->width, data.height->height};
    if (data.gradient) shape = {data.gradient->width, data.gradient->height};
    const MemoryNeed need = memory_of(s.name, resolved, shape);
    std::optional<DeviceInfo> info;
    if (need.device > 0) {
      try {
        info = choose_device(spec);
      } catch (const Error&) {  // no device: the stage itself reports it
      }
    }
    require_stage_memory_info(s.name, "terracl." + s.name + "()", need, info ? &*info : nullptr);
  }
  ProgressBridge bridge(progress);
  Metadata prov = provenance("terracl." + s.name + "()");
  prov["terracl:stages"] = json::array({json{{"type", s.name}, {"options", resolved}}}).dump();
  run_released(nullptr, bridge, [&] {
    LazyDevice lazy(spec);  // released (and unlocked) when the stage is done
    StageContext ctx{data, resolved, [&lazy]() -> Device& { return lazy(); }, bridge.progress(), s.name, prov};
    s.run(ctx);
    // What the CLI writes carries the provenance; so does what Python gets back.
    if (data.height)
      for (const auto& [k, v] : ctx.provenance) data.height->metadata[k] = v;
    if (data.gradient)
      for (const auto& [k, v] : ctx.provenance) data.gradient->metadata[k] = v;
    return 0;
  });
  if (data.current == DataKind::Gradient && data.gradient) return py::cast(std::move(*data.gradient));
  if (data.height) return py::cast(std::move(*data.height));
  if (data.gradient) return py::cast(std::move(*data.gradient));
  return py::none();
}

// For python/bench_overhead.py: the same stage call made from C++ `repeats` times (options
// resolved and the stage run, as a C++ program or the CLI does; the input's copy into the stage
// data is not timed), so that the Python call's wall time can be compared with it.
std::vector<double> time_stage(const std::string& name, py::object input, const py::dict& kwargs, py::object device,
                               int repeats) {
  const StageInfo& s = find_stage(name);
  const json options = options_of(kwargs);
  const std::string spec = device_spec(device);
  StageData proto;
  if (py::isinstance<GradientField>(input)) {
    proto.gradient = input.cast<const GradientField&>();
    proto.current = DataKind::Gradient;
  } else if (!input.is_none()) {
    proto.height = to_heightfield(input, name + " input");
    proto.current = DataKind::Heightfield;
  }
  ProgressBridge bridge;
  return run_released(nullptr, bridge, [&] {
    std::vector<double> ms;
    for (int i = 0; i < repeats; ++i) {
      StageData data = proto;
      const auto t0 = std::chrono::steady_clock::now();
      LazyDevice lazy(spec);
      const json resolved = resolve(s, options);
      StageContext ctx{data, resolved, [&lazy]() -> Device& { return lazy(); }, Progress{}, s.name, Metadata{}};
      s.run(ctx);
      ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    return ms;
  });
}

py::dict stage_table() {
  py::dict out;
  for (const auto& s : StageRegistry::instance().all()) {
    py::list opts;
    for (const auto& o : s.options) {
      py::dict d;
      d["name"] = o.name;
      d["type"] = option_type_name(o.type);
      d["default"] = from_json(o.default_value);
      d["unit"] = o.unit;
      d["help"] = o.help;
      d["choices"] = o.choices;
      d["required"] = o.required;
      opts.append(d);
    }
    py::dict d;
    d["name"] = s.name;
    d["description"] = s.description;
    d["input"] = data_kind_name(s.input);
    d["output"] = data_kind_name(s.output);
    d["options"] = opts;
    out[py::str(s.name)] = d;
  }
  return out;
}

// `terracl edit BASE --script S -o OUT` without the files: returns the reconstructed heightfield
// and the session's report (operations, warnings, last solve).
py::tuple edit(py::object base_obj, py::object script_obj, py::object base_dir_obj, py::object device,
               py::object progress) {
  json script;
  std::string base_dir = base_dir_obj.is_none() ? "" : py::str(base_dir_obj).cast<std::string>();
  if (py::isinstance<py::str>(script_obj) || py::hasattr(script_obj, "__fspath__")) {
    const std::string path = py::str(script_obj).cast<std::string>();
    script = read_edit_script(path);
    if (base_dir_obj.is_none()) base_dir = std::filesystem::path(path).parent_path().string();
  } else {
    script = to_json(script_obj, "");
  }
  Heightfield base;
  if (base_obj.is_none()) {
    if (!(script.is_object() && script.contains("base") && script["base"].is_string()))
      throw UsageError("edit", "needs a base terrain (a Heightfield, an array, a file or 'flat:WxH[@cell]'), or \"base\" in the script");
    base_obj = py::str(resolve_path(script["base"].get<std::string>(), base_dir));
  }
  if (py::isinstance<py::str>(base_obj) || py::hasattr(base_obj, "__fspath__")) {
    const std::string spec = py::str(base_obj).cast<std::string>();
    if (auto flat = parse_flat_spec(spec)) {
      base = std::move(*flat);
    } else {
      if (!std::filesystem::exists(spec)) throw UsageError("edit", fmt::format("base terrain '{}' not found", spec));
      py::gil_scoped_release release;
      base = read_heightfield(spec);
    }
  } else {
    base = to_heightfield(base_obj, "edit base");
  }
  DeviceSlot& slot = device_slot(device);
  ProgressBridge bridge(progress);
  json report;
  Heightfield h = run_released(&slot, bridge, [&] {
    if (base.count_nodata()) fill_nodata_harmonic(base);  // as `terracl edit` does
    require_memory("edit", fmt::format("a {} x {} edit", base.width, base.height),
                   double(base.size()) * edit_host_bytes_per_cell, double(base.size()) * edit_device_bytes_per_cell,
                   double(base.size()) * 8, slot.device.get(), "use a smaller base (flat:WxH, or crop the DEM)");
    EditOptions o;
    o.progress = bridge.progress();
    o.base_dir = base_dir;
    EditSession s(*slot.device, base, o);
    s.apply(script);
    Heightfield out = s.height();
    out.georef = base.georef;
    out.metadata = base.metadata;
    for (const auto& [k, v] : provenance("terracl.edit()")) out.metadata[k] = v;
    report = s.report();
    report["warnings"] = s.warnings();
    return out;
  });
  return py::make_tuple(py::cast(std::move(h)), from_json(report));
}

// The `render` stage from Python: pictures as (height, width, 3) RGB or (height, width, 4) RGBA uint8
// arrays (grey pictures expanded to three equal channels, so that every picture displays as it is),
// value modes (slope, aspect, tri, tpi, roughness) as (height, width) float32 arrays, NaN where
// gdaldem writes nodata. `file` is written exactly as `terracl render IN --file FILE` writes it: a
// value mode to .tif is gdaldem's Float32 raster, slope to .png the grey picture. The options are
// resolved by the stage table and mapped by render_stage_options, as the stage itself maps them.
py::array render_image(py::object input, const py::dict& kwargs, py::object device, py::object progress) {
  const StageInfo& s = find_stage("render");
  json opts = options_of(kwargs);
  const bool to_file = opts.contains("file");
  if (!to_file) opts["file"] = "unused.png";  // required by the table; nothing is written
  const json r = resolve(s, opts);
  Heightfield h = to_heightfield(input, "render input");
  StageData unused;
  StageContext ctx{unused, r, nullptr, Progress{}, "render", Metadata{}};
  render::Options o = render_stage_options(ctx);
  const std::string file = r.at("file").get<std::string>();
  const bool tif = to_file && format_from_extension(file) == FileFormat::GeoTIFF;
  if (o.mode == render::Mode::Perspective && to_file && format_from_extension(file) != FileFormat::PNG)
    fail("render", "{}: a perspective picture has no georeferencing; write it as .png", file);
  const bool values = render::is_value_mode(o.mode);
  if (values && to_file && !tif && o.mode != render::Mode::Slope)
    fail("render", "{}: mode {} writes values; use a .tif name", file, r.at("mode").get<std::string>());
  const bool host = r.at("backend").get<std::string>() == "host";
  DeviceSlot* slot = host ? nullptr : &device_slot(device);
  ProgressBridge bridge(progress);
  o.progress = bridge.progress();
  Metadata prov = provenance("terracl.render()");
  prov["terracl:stages"] = json::array({json{{"type", "render"}, {"options", r}}}).dump();
  Heightfield v;
  render::Image img;
  run_released(slot, bridge, [&] {
    auto picture = [&] { return host ? render::render(h, o) : render::render(h, o, *slot->device); };
    if (values) {
      v = host ? render::values(h, o) : render::values(h, o, *slot->device);
      if (tif) {
        for (const auto& [k, val] : prov) v.metadata[k] = val;
        write_heightfield(v, file);
      } else if (to_file) {
        render::write_image(picture(), file, prov);  // slope to .png: the CLI's grey picture
      }
    } else {
      img = picture();
      if (to_file) render::write_image(img, file, prov);
    }
    return 0;
  });
  if (values) {
    py::array_t<float> out({py::ssize_t(v.height), py::ssize_t(v.width)});
    std::memcpy(out.mutable_data(), v.z.data(), v.z.size() * sizeof(float));
    return std::move(out);
  }
  const int c = img.channels, oc = (c == 2 || c == 4) ? 4 : 3;
  py::array_t<uint8_t> out({py::ssize_t(img.height), py::ssize_t(img.width), py::ssize_t(oc)});
  uint8_t* dst = out.mutable_data();
  const size_t n = size_t(img.width) * size_t(img.height);
  for (size_t i = 0; i < n; ++i) {
    const uint8_t* p = img.pixels.data() + i * size_t(c);
    uint8_t* q = dst + i * size_t(oc);
    if (c <= 2) {
      q[0] = q[1] = q[2] = p[0];
      if (c == 2) q[3] = p[1];
    } else {
      std::memcpy(q, p, size_t(c));
    }
  }
  return std::move(out);
}

py::dict run_pipeline(py::object doc_obj, std::vector<std::string> overrides, std::string name, bool write_resolved,
                      py::object device, py::object progress) {
  Pipeline p = (py::isinstance<py::str>(doc_obj) || py::hasattr(doc_obj, "__fspath__"))
                   ? Pipeline::load(py::str(doc_obj).cast<std::string>())
                   : Pipeline::parse(to_json(doc_obj, ""), name, name);
  for (const auto& o : overrides) p.set(o);
  p.validate();
  const std::string spec = device_spec(device);
  ProgressBridge bridge(progress);
  RunReport report;
  RunOptions ro;
  LazyDevice lazy(spec);
  ro.device = [&lazy]() -> Device& { return lazy(); };
  ro.write_resolved = write_resolved;
  ro.progress = [&](const std::string& tag, size_t index, size_t count) -> Progress {
    Progress inner = bridge.progress();
    return [inner, tag, index, count](double f, const std::string& m) {
      return inner((double(index) + f) / double(count), tag + ": " + m);
    };
  };
  run_released(nullptr, bridge, [&] {
    p.run(ro, report);
    return 0;
  });
  py::list stages;
  for (const auto& s : report.stages) {
    py::dict d;
    d["type"] = s.type;
    d["tag"] = s.tag;
    d["seconds"] = s.seconds;
    d["outputs"] = s.outputs;
    stages.append(d);
  }
  py::dict out;
  out["stages"] = stages;
  out["outputs"] = report.outputs();
  out["resolved"] = report.resolved_path;
  out["seconds"] = report.seconds;
  out["pipeline_hash"] = p.hash();
  return out;
}

}  // namespace

void init_stages(py::module_& m) {
  m.def("_run_stage", &run_stage, py::arg("name"), py::arg("input"), py::arg("options"), py::arg("device") = py::none(),
        py::arg("progress") = py::none());
  m.def("_stage_table", &stage_table);
  m.def("_time_stage", &time_stage, py::arg("name"), py::arg("input"), py::arg("options"), py::arg("device") = py::none(),
        py::arg("repeats") = 1);
  m.def("_edit", &edit, py::arg("base"), py::arg("script"), py::arg("base_dir") = py::none(),
        py::arg("device") = py::none(), py::arg("progress") = py::none());
  m.def("_render", &render_image, py::arg("input"), py::arg("options"), py::arg("device") = py::none(),
        py::arg("progress") = py::none());
  m.def("_run_pipeline", &run_pipeline, py::arg("pipeline"), py::arg("overrides"), py::arg("name"),
        py::arg("write_resolved"), py::arg("device") = py::none(), py::arg("progress") = py::none());
}

}  // namespace terracl::python
