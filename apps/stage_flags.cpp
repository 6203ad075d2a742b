// SPDX-License-Identifier: Apache-2.0
#include "stage_flags.hpp"

#include <algorithm>
#include <fmt/format.h>

namespace terracl::cli {

std::string kebab(std::string s) {
  for (char& c : s)
    if (c == '_') c = '-';
  return s;
}

void StageFlags::add(CLI::App* sub, const StageInfo& stage, const std::string& output_option, bool enforce_required) {
  for (const auto& o : stage.options) {
    if (std::find(skip.begin(), skip.end(), o.name) != skip.end()) continue;
    std::string help = o.help;
    if (!o.unit.empty()) help += fmt::format(" [{}]", o.unit);
    if (o.type == OptionType::Enum) help += fmt::format(" ({})", fmt::join(o.choices, "|"));
    if (!o.default_value.is_null()) help += fmt::format(" (default {})", o.default_value.dump());
    std::string flag = "--" + kebab(o.name);
    if (o.name == output_option) flag = "-o,--output," + flag;
    if (o.type == OptionType::Bool) {
      sub->add_flag(flag + ",!--no-" + kebab(o.name), m_flags[o.name], help);
      continue;
    }
    auto* opt = sub->add_option(flag, m_values[o.name], help);
    opt->type_name(o.type == OptionType::Int     ? "INT"
                   : o.type == OptionType::Float ? (o.unit.empty() ? "NUMBER" : "NUMBER[" + o.unit + "]")
                   : o.type == OptionType::Enum  ? "CHOICE"
                   : o.type == OptionType::Path || o.type == OptionType::OutputPath ? "FILE"
                   : o.type == OptionType::Json  ? "JSON"
                                                 : "TEXT");
    if (o.required && enforce_required) opt->required();
  }
}

void check_stage_files(const StageInfo& stage, const json& resolved, std::vector<NamedPath> inputs,
                       std::vector<NamedPath> outputs) {
  for (const auto& o : stage.options) {
    if (!resolved.contains(o.name) || !resolved.at(o.name).is_string()) continue;
    const std::string file = resolved.at(o.name).get<std::string>();
    if (o.type == OptionType::Path && file.rfind("flat:", 0) != 0) inputs.push_back({"--" + kebab(o.name), file});
    if (o.type == OptionType::OutputPath) outputs.push_back({"--" + kebab(o.name), file});
  }
  check_output_paths(stage.name, inputs, outputs);
}

json StageFlags::given(const CLI::App* sub, const StageInfo& stage) const {
  json opts = json::object();
  for (const auto& o : stage.options) {
    if (std::find(skip.begin(), skip.end(), o.name) != skip.end()) continue;
    const std::string flag = "--" + kebab(o.name);
    if (o.type == OptionType::Bool) {
      if (sub->count(flag) || sub->count("--no-" + kebab(o.name))) opts[o.name] = m_flags.at(o.name);
    } else if (sub->count(flag)) {
      opts[o.name] = option_from_text(o, m_values.at(o.name));
    }
  }
  return opts;
}

void InputScaleFlags::add(CLI::App* sub) {
  sub->add_option("--zmin", zmin, "Input PNG/RAW16: elevation of code 0 [m] (default: from the sidecar)");
  sub->add_option("--zmax", zmax, "Input PNG/RAW16: elevation of the largest code [m] (default: from the sidecar)");
  sub->add_option("--cell-size", cell_size, "Input cell size [m] for rasters without georeferencing")
      ->check(CLI::PositiveNumber);
}

ReadOptions InputScaleFlags::read_options(bool fill_nodata) const {
  ReadOptions ro;
  ro.zmin = zmin;
  ro.zmax = zmax;
  ro.cell_size = cell_size;
  ro.fill_nodata = fill_nodata;
  return ro;
}

void OutputFlags::add(CLI::App* sub) {
  sub->add_option("--co", creation_options, "GDAL output (.tif and other GDAL formats): creation option KEY=VALUE (repeatable; as gdal_translate -co)")
      ->type_name("KEY=VALUE");
  sub->add_flag("--cog", cog, "GeoTIFF output: write a Cloud Optimized GeoTIFF (GDAL's COG driver)");
  m_ot = sub->add_option("--ot", output_type, "GDAL output (.tif and other GDAL formats): band type (rounded for integer types)")
      ->check(CLI::IsMember({"Float32", "Float64", "Int16", "UInt16", "Int32"}))
      ->capture_default_str();
  sub->add_option("--of", driver, "Output format: a GDAL raster driver (AAIGrid, HFA, GPKG, netCDF, ...; as gdal_translate -of); "
                  "default: from the extension");
}

WriteOptions OutputFlags::write_options_keeping_type(const std::string& input, const std::string& output) const {
  WriteOptions wo = write_options();
  const FileFormat f = format_from_extension(output);
  const bool terracl_format = driver.empty() && (f == FileFormat::PNG || f == FileFormat::EXR ||
                                                 f == FileFormat::RAW16 || f == FileFormat::NPY);
  if (m_ot && m_ot->count() == 0 && !terracl_format && !cog)
    if (const std::string t = stored_band_type(input); !t.empty()) wo.output_type = t;
  return wo;
}

WriteOptions OutputFlags::write_options() const {
  WriteOptions wo;
  wo.creation_options = creation_options;
  wo.cog = cog;
  wo.output_type = output_type;
  wo.driver = driver;
  return wo;
}

}  // namespace terracl::cli
