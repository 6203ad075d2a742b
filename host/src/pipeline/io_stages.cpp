// SPDX-License-Identifier: Apache-2.0
// The pipeline's reader and writer stages (`"in.tif"` and `"out.exr"` in a pipeline are shorthands
// for them). Pipeline-only: on the command line, `terracl convert` and every stage's IN/-o do this.
#include <filesystem>
#include "io/io_common.hpp"

#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include "pipeline/builtin.hpp"

namespace terracl {
namespace {

using io::drop_terracl_keys;

DataKind check_read(const json& o, DataKind, const std::string& where) {
  const std::string f = o.at("filename").get<std::string>();
  const bool quantised = format_from_extension(f) == FileFormat::PNG || format_from_extension(f) == FileFormat::RAW16;
  for (const char* k : {"zmin", "zmax"})
    if (!o.at(k).is_null() && !quantised)
      fail("pipeline", "{}/{}: only PNG and RAW16 inputs take a vertical range", where, k);
  if (path_exists(f) && is_gradient_file(f)) return DataKind::Gradient;
  return DataKind::Heightfield;
}

void run_read(StageContext& c) {
  const std::string f = c.get<std::string>("filename");
  c.data = StageData{};
  if (is_gradient_file(f)) {
    c.data.gradient = read_gradient(f);
    // The convention (staggered / central) is part of the data: reconstruct reads it.
    Metadata& md = c.data.gradient->metadata;
    const auto conv = md.find("terracl:gradient");
    const std::string convention = conv == md.end() ? std::string() : conv->second;
    drop_terracl_keys(md);
    if (!convention.empty()) md["terracl:gradient"] = convention;
    c.data.current = DataKind::Gradient;
    return;
  }
  ReadOptions ro;
  if (c.has("zmin")) ro.zmin = c.get<double>("zmin");
  if (c.has("zmax")) ro.zmax = c.get<double>("zmax");
  if (c.has("width")) ro.width = c.get<int>("width");
  if (c.has("height")) ro.height = c.get<int>("height");
  if (c.has("cell_size")) ro.cell_size = c.get<double>("cell_size");
  ro.fill_nodata = c.get<bool>("fill_nodata");
  c.data.height = read_heightfield(f, ro);
  drop_terracl_keys(c.data.height->metadata);
  c.data.current = DataKind::Heightfield;
}

DataKind check_write(const json& o, DataKind input, const std::string& where) {
  const std::string f = o.at("filename").get<std::string>();
  const FileFormat fmt = format_from_extension(f);
  if (input == DataKind::Gradient && fmt != FileFormat::EXR && fmt != FileFormat::GeoTIFF)
    fail("pipeline", "{}/filename: {}: a gradient is written as .exr (two float channels) or .tif (two float32 bands)",
         where, f);
  // Other extensions go to the GDAL driver that claims them (.asc, .img, .gpkg, ...).
  const bool terracl_written = fmt == FileFormat::GeoTIFF || fmt == FileFormat::EXR || fmt == FileFormat::PNG ||
                               fmt == FileFormat::RAW16 || fmt == FileFormat::NPY;
  if (input == DataKind::Heightfield && !terracl_written) {
    try {
      (void)io::gdal_driver_for_output(f, "");
    } catch (const Error& e) {
      fail("pipeline", "{}/filename: cannot write a heightfield there: {}", where,
           std::string(e.what()).substr(e.stage().size() + 2));
    }
  }
  const bool quantised = fmt == FileFormat::PNG || fmt == FileFormat::RAW16;
  for (const char* k : {"zmin", "zmax"})
    if (!o.at(k).is_null() && (!quantised || input != DataKind::Heightfield))
      fail("pipeline", "{}/{}: only PNG16 and RAW16 heightfield outputs take a vertical range", where, k);
  const bool gdal_options = !o.at("creation_options").is_null() || o.at("cog").get<bool>() ||
                            o.at("output_type").get<std::string>() != "Float32";
  const bool terracl_format = fmt == FileFormat::EXR || fmt == FileFormat::PNG || fmt == FileFormat::RAW16 ||
                              fmt == FileFormat::NPY;
  if (gdal_options && (terracl_format || input != DataKind::Heightfield))
    fail("pipeline", "{}: creation_options, cog and output_type apply to heightfield outputs written by GDAL (.tif, .asc, "
         ".img, ...) only", where);
  if (!o.at("zmin").is_null() && !o.at("zmax").is_null() && !(o.at("zmax").get<double>() > o.at("zmin").get<double>()))
    fail("pipeline", "{}/zmax: must be above zmin ({} <= {})", where, o.at("zmax").get<double>(),
         o.at("zmin").get<double>());
  return input;
}

// Writes the current data with the provenance of the chain behind it. The metadata is swapped in
// and out rather than copied with the raster.
void run_write(StageContext& c) {
  const std::string f = c.get<std::string>("filename");
  auto with_provenance = [&](Metadata& md, auto&& write) {
    Metadata saved = md;
    drop_terracl_keys(md);
    for (const auto& [k, v] : c.provenance) md[k] = v;
    try {
      write();
    } catch (...) {
      md.swap(saved);
      throw;
    }
    md.swap(saved);
  };
  if (c.data.current == DataKind::Gradient) {
    GradientField& g = c.gradient();
    // The convention (staggered / central) is part of the data, not provenance: it stays.
    const auto conv = g.metadata.find("terracl:gradient");
    const std::string convention = conv == g.metadata.end() ? std::string() : conv->second;
    with_provenance(g.metadata, [&] {
      if (!convention.empty()) g.metadata["terracl:gradient"] = convention;
      write_gradient(g, f);
    });
    return;
  }
  Heightfield& h = c.height();
  WriteOptions wo;
  if (c.has("zmin")) wo.zmin = c.get<double>("zmin");
  if (c.has("zmax")) wo.zmax = c.get<double>("zmax");
  wo.cog = c.get<bool>("cog");
  wo.output_type = c.get<std::string>("output_type");
  if (c.has("creation_options")) {
    const json& co = c.options.at("creation_options");
    if (!co.is_array()) fail(c.tag, "creation_options: expected an array of \"KEY=VALUE\" strings, got {}", co.dump());
    for (const auto& kv : co) {
      if (!kv.is_string()) fail(c.tag, "creation_options: expected \"KEY=VALUE\" strings, got {}", kv.dump());
      wo.creation_options.push_back(kv.get<std::string>());
    }
  }
  with_provenance(h.metadata, [&] { write_heightfield(h, f, wo); });
}

}  // namespace

void register_crop_stage(StageRegistry& r);  // crop_stage.cpp
void register_downsample_stage(StageRegistry& r);  // downsample_stage.cpp
void register_warp_stages(StageRegistry& r);  // warp_stage.cpp

void register_io_stages(StageRegistry& r) {
  StageInfo read{
      "read",
      "Read a heightfield (any raster terracl reads) or a gradient field (two-channel .exr, or a gx/gy two-band .tif); format from the "
      "extension.",
      DataKind::None,
      DataKind::Any,  // what the file holds; check_read tells which
      {{"filename", OptionType::Path, nullptr, "", "Input file (.tif .hgt .asc .png .exr .r16 .raw ...)", {}, true},
       {"fill_nodata", OptionType::Bool, false, "", "Fill nodata cells by harmonic interpolation after reading"},
       {"zmin", OptionType::Float, nullptr, "m", "PNG/RAW16 input: elevation of code 0 (default: from the sidecar)"},
       {"zmax", OptionType::Float, nullptr, "m",
        "PNG/RAW16 input: elevation of the largest code (default: from the sidecar)"},
       {"width", OptionType::Int, nullptr, "cells", "RAW16 input: width (default: from the sidecar)"},
       {"height", OptionType::Int, nullptr, "cells", "RAW16 input: height (default: from the sidecar)"},
       {"cell_size", OptionType::Float, nullptr, "m", "Cell size for inputs without georeferencing"}},
      run_read,
      false,
      check_read};
  r.add(std::move(read));

  StageInfo write{
      "write",
      "Write the current heightfield (.tif .exr .png .r16 .raw) or gradient field (.exr, .tif) with provenance; format from "
      "the extension.",
      DataKind::Any,
      DataKind::Any,
      {{"filename",
        OptionType::OutputPath,
        nullptr,
        "",
        "Output file (written atomically; its folder is created)",
        {},
        true},
       {"zmin", OptionType::Float, nullptr, "m", "PNG16/RAW16 output: elevation of code 0 (default: data minimum)"},
       {"zmax", OptionType::Float, nullptr, "m",
        "PNG16/RAW16 output: elevation of code 65535 (default: data maximum)"},
       {"creation_options", OptionType::Json, nullptr, "",
        "GeoTIFF output: GDAL creation options [\"KEY=VALUE\", ...] (gdal_translate -co)"},
       {"cog", OptionType::Bool, false, "", "GeoTIFF output: Cloud Optimized GeoTIFF (GDAL's COG driver)"},
       {"output_type", OptionType::Enum, "Float32", "", "GeoTIFF output: band type (rounded for integer types)",
        {"Float32", "Float64", "Int16", "UInt16", "Int32"}}},
      run_write,
      false,
      check_write};
  r.add(std::move(write));
  register_crop_stage(r);
  register_downsample_stage(r);
  register_warp_stages(r);
}

}  // namespace terracl
