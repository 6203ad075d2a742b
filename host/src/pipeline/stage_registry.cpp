// SPDX-License-Identifier: Apache-2.0
// Option validation and unit conversion for self-describing stages. Every error names the JSON
// path of the offending value, so that a pipeline author can find it.
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/stage.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <sstream>

namespace terracl {

const char* option_type_name(OptionType t) {
  switch (t) {
    case OptionType::String: return "string";
    case OptionType::Int: return "int";
    case OptionType::Float: return "float";
    case OptionType::Bool: return "bool";
    case OptionType::Path: return "input file";
    case OptionType::OutputPath: return "output file";
    case OptionType::Enum: return "enum";
    case OptionType::Json: return "json";
  }
  return "?";
}

const char* data_kind_name(DataKind k) {
  switch (k) {
    case DataKind::None: return "nothing";
    case DataKind::Heightfield: return "heightfield";
    case DataKind::Gradient: return "gradient";
    case DataKind::Any: return "heightfield or gradient";
  }
  return "?";
}

Heightfield& StageContext::height() {
  if (!data.height) fail(tag, "needs a heightfield from the previous stage or an input file, and has none");
  return *data.height;
}

GradientField& StageContext::gradient() {
  if (!data.gradient) fail(tag, "needs a gradient field (from `extract` or a gradient .exr), and has none");
  return *data.gradient;
}

void StageRegistry::add(StageInfo info) {
  if (find(info.name)) fail("stages", "stage '{}' registered twice", info.name);
  m_stages.push_back(std::move(info));
}

const StageInfo* StageRegistry::find(const std::string& name) const {
  for (const auto& s : m_stages)
    if (s.name == name) return &s;
  return nullptr;
}

const BenchInfo* BenchRegistry::find(const std::string& name) const {
  for (const auto& b : m_benches)
    if (b.name == name) return &b;
  return nullptr;
}

namespace {

struct Unit {
  std::string dimension;
  double to_si;
};

// Units a stage may declare, with their dimension and factor to SI. A value may be written in
// any unit of the same dimension ("2 km" for a length in m).
const std::map<std::string, Unit>& unit_table() {
  static const std::map<std::string, Unit> t = {
      {"m", {"length", 1}},          {"km", {"length", 1000}},       {"cm", {"length", 0.01}},
      {"mm", {"length", 0.001}},     {"s", {"time", 1}},             {"ms", {"time", 0.001}},
      {"min", {"time", 60}},         {"h", {"time", 3600}},          {"deg", {"angle", M_PI / 180}},
      {"rad", {"angle", 1}},         {"m/s", {"speed", 1}},          {"mm/h", {"speed", 0.001 / 3600}},
      {"mm/s", {"speed", 0.001}},    {"m/h", {"speed", 1.0 / 3600}}, {"1/s", {"rate", 1}},
      {"1/h", {"rate", 1.0 / 3600}}, {"m/m", {"ratio", 1}},          {"%", {"ratio", 0.01}},
      {"m2", {"area", 1}},           {"km2", {"area", 1e6}},         {"cells", {"cells", 1}},
      {"m/s2", {"acceleration", 1}}, {"kg/m3", {"density", 1}},      {"px", {"cells", 1}},
  };
  return t;
}

}  // namespace

double convert_unit(const json& value, const std::string& unit, const std::string& where) {
  if (value.is_number()) return value.get<double>();
  if (!value.is_string()) fail("pipeline", "{}: expected a number{}, got {}", where, unit.empty() ? "" : " in " + unit, abbreviate(value.dump()));
  const std::string s = value.get<std::string>();
  const char* begin = s.c_str();
  char* end = nullptr;
  const double v = std::strtod(begin, &end);
  if (end == begin || !std::isfinite(v)) fail("pipeline", "{}: '{}' is not a number with a unit", where, abbreviate(s));
  std::string u(end);
  u.erase(0, u.find_first_not_of(" \t"));
  u.erase(u.find_last_not_of(" \t") + 1);
  if (u.empty() || u == unit) return v;
  if (unit.empty()) fail("pipeline", "{}: '{}' has a unit, but this option takes a plain number", where, s);
  const auto& t = unit_table();
  auto from = t.find(u), to = t.find(unit);
  if (from == t.end()) fail("pipeline", "{}: unknown unit '{}' in '{}' (expected {} or a unit of the same kind)", where, u, s, unit);
  if (to == t.end() || from->second.dimension != to->second.dimension)
    fail("pipeline", "{}: unit '{}' is not a {} unit like {}", where, u, to == t.end() ? unit : to->second.dimension, unit);
  return v * from->second.to_si / to->second.to_si;
}

json option_from_text(const OptionSpec& o, const std::string& text) {
  switch (o.type) {
    case OptionType::Int: {
      char* end = nullptr;
      const long long v = std::strtoll(text.c_str(), &end, 10);
      if (!text.empty() && end && *end == '\0') return v;
      return text;
    }
    case OptionType::Float: {
      char* end = nullptr;
      const double v = std::strtod(text.c_str(), &end);
      if (!text.empty() && end && *end == '\0') return v;
      return text;
    }
    case OptionType::Bool:
      if (text == "true" || text == "1" || text == "yes" || text == "on") return true;
      if (text == "false" || text == "0" || text == "no" || text == "off") return false;
      return text;
    case OptionType::Json:
      try {
        return parse_json_limited(text, "pipeline", "value");  // depth and size limits
      } catch (const Error&) {
        return text;
      }
    default:
      return text;
  }
}

namespace {
// The option a mistyped key most likely meant: one containing it or contained in it ("filename"
// for render's "file", which the write stage calls "filename"), else one within 2 edits; "" if none.
std::string nearest_option(const StageInfo& stage, const std::string& key) {
  if (key.size() < 3 || key.size() > 64) return "";
  auto edits = [](const std::string& a, const std::string& b) {
    std::vector<size_t> row(b.size() + 1);
    for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (size_t i = 1; i <= a.size(); ++i) {
      size_t diag = row[0];
      row[0] = i;
      for (size_t j = 1; j <= b.size(); ++j) {
        const size_t up = row[j];
        row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
        diag = up;
      }
    }
    return row[b.size()];
  };
  std::string best;
  size_t best_d = 3;
  for (const auto& o : stage.options) {
    if (o.name.size() >= 3 && (o.name.find(key) != std::string::npos || key.find(o.name) != std::string::npos)) return o.name;
    const size_t d = edits(key, o.name);
    if (d < best_d) best_d = d, best = o.name;
  }
  return best;
}
}  // namespace

json resolve_options(const StageInfo& stage, const json& options, const std::string& where,
                     const std::vector<std::string>& pending_outputs) {
  if (!options.is_object()) fail("pipeline", "{}: stage options must be a JSON object", where);
  json out = json::object();
  for (auto& [key, value] : options.items()) {
    if (key == "type" || key == "tag") continue;
    bool known = false;
    for (const auto& o : stage.options) known = known || o.name == key;
    if (!known) {
      std::string names;
      for (const auto& o : stage.options) names += (names.empty() ? "" : ", ") + o.name;
      const std::string near = nearest_option(stage, key);
      fail("pipeline", "{}/{}: stage '{}' has no option '{}'{} (options: {})", where, abbreviate(key), stage.name,
           abbreviate(key), near.empty() ? "" : fmt::format("; did you mean '{}'?", near), names.empty() ? "none" : names);
    }
  }
  for (const auto& o : stage.options) {
    const std::string path = where + "/" + o.name;
    json v = options.contains(o.name) ? options.at(o.name) : o.default_value;
    if (v.is_null() && options.contains(o.name) && !o.default_value.is_null())
      fail("pipeline", "{}: null is not a value for '{}'; leave the option out to get its default {}", path, o.name,
           o.default_value.dump());
    if (v.is_null()) {
      if (o.required) fail("pipeline", "{}: required option '{}' of stage '{}' is missing", path, o.name, stage.name);
      out[o.name] = nullptr;
      continue;
    }
    switch (o.type) {
      case OptionType::Int: {
        // Every int option is read as a C int: refuse what does not fit instead of wrapping
        // (4294967297 steps ran as 1, 2e300 became 0).
        double d = 0;
        if (v.is_number_integer()) {
          d = v.is_number_unsigned() ? double(v.get<uint64_t>()) : double(v.get<int64_t>());
        } else if (v.is_number_float() && std::floor(v.get<double>()) == v.get<double>()) {
          d = v.get<double>();
        } else if (v.is_string()) {
          d = convert_unit(v, o.unit, path);
          if (std::floor(d) != d)
            fail("pipeline", "{}: expected a whole number{}, got {}", path, o.unit.empty() ? "" : " of " + o.unit, d);
        } else {
          fail("pipeline", "{}: expected an integer, got {}", path, abbreviate(v.dump()));
        }
        const double lo = o.min ? std::max(*o.min, double(INT32_MIN)) : double(INT32_MIN);
        const double hi = o.max ? std::min(*o.max, double(INT32_MAX)) : double(INT32_MAX);
        if (!(d >= lo && d <= hi))
          fail("pipeline", "{}: {} is out of range; expected an integer from {} to {}", path, abbreviate(v.dump(), 40),
               int64_t(lo), int64_t(hi));
        v = int64_t(d);
        break;
      }
      case OptionType::Float: {
        v = convert_unit(v, o.unit, path);
        const double d = v.get<double>();
        if (!std::isfinite(d)) fail("pipeline", "{}: must be finite", path);
        if ((o.min && d < *o.min) || (o.max && d > *o.max))
          fail("pipeline", "{}: {} is out of range; expected {}{}{}{}", path, d, o.min ? fmt::format(">= {}", *o.min) : "",
               o.min && o.max ? " and " : "", o.max ? fmt::format("<= {}", *o.max) : "", o.unit.empty() ? "" : " " + o.unit);
        break;
      }
      case OptionType::Bool:
        if (!v.is_boolean()) fail("pipeline", "{}: expected true or false, got {}", path, abbreviate(v.dump()));
        break;
      case OptionType::String:
        if (!v.is_string()) fail("pipeline", "{}: expected a string, got {}", path, abbreviate(v.dump()));
        break;
      case OptionType::Path: {
        if (!v.is_string() || v.get<std::string>().empty())
          fail("pipeline", "{}: expected a file name, got {}", path, abbreviate(v.dump()));
        const std::string p = v.get<std::string>();
        check_path_length("pipeline", path, p);
        const bool pending = std::find(pending_outputs.begin(), pending_outputs.end(), p) != pending_outputs.end();
        std::error_code ec;
        // flat:WxH@CELL is a generated base, style:NAME a bundled style's dictionary (amplify).
        if (p.rfind("flat:", 0) != 0 && p.rfind("style:", 0) != 0 && !pending && !is_virtual_path(p) &&
            !std::filesystem::exists(p, ec))
          throw MissingFileError("pipeline", fmt::format("{}: input file {} does not exist", path, p), p);
        break;
      }
      case OptionType::OutputPath:
        if (!v.is_string() || v.get<std::string>().empty())
          fail("pipeline", "{}: expected an output file name, got {}", path, abbreviate(v.dump()));
        check_path_length("pipeline", path, v.get<std::string>());
        break;
      case OptionType::Enum: {
        if (!v.is_string()) fail("pipeline", "{}: expected one of {}, got {}", path, fmt::join(o.choices, "|"), abbreviate(v.dump()));
        bool ok = false;
        for (const auto& c : o.choices) ok = ok || c == v.get<std::string>();
        if (!ok) fail("pipeline", "{}: '{}' is not one of {}", path, v.get<std::string>(), fmt::join(o.choices, "|"));
        break;
      }
      case OptionType::Json:
        break;
    }
    out[o.name] = v;
  }
  return out;
}

std::string stages_markdown(const std::vector<std::string>& commands) {
  std::ostringstream md;
  md << "# terracl stages\n\nGenerated from the stage table by `terracl stages --markdown`; do not edit.\n"
        "Each stage runs as `terracl <stage> [IN] -o OUT [--option value ...]` or as "
        "`{\"type\": \"<stage>\", ...}` in a pipeline. Options are `snake_case` in JSON and `--kebab-case` on "
        "the command line; values with a unit also accept another unit of the same kind (\"2 km\"). "
        "Pipelines (`terracl run`) are described in [pipelines.md](pipelines.md).\n";
  for (const auto& s : StageRegistry::instance().all()) {
    const bool passes = s.input != DataKind::None && (s.output == DataKind::None || s.output == DataKind::Any);
    md << "\n## " << s.name << "\n\n" << s.description << "\n\nInput: " << data_kind_name(s.input)
       << "; output: " << (passes ? "its input, unchanged" : data_kind_name(s.output))
       << (s.cli || std::find(commands.begin(), commands.end(), s.name) != commands.end()
               ? ""
               : "; pipeline only")
       << ".\n\n";
    if (s.options.empty()) {
      md << "No options.\n";
      continue;
    }
    md << "| option | type | default | unit | help |\n|---|---|---|---|---|\n";
    for (const auto& o : s.options) {
      std::string type = option_type_name(o.type);
      if (o.type == OptionType::Enum) type = fmt::format("{}", fmt::join(o.choices, " \\| "));
      std::string def = o.required ? "(required)" : o.default_value.is_null() ? "" : o.default_value.dump();
      std::string help = o.help;  // a '|' would end the table cell
      for (size_t i = help.find('|'); i != std::string::npos; i = help.find('|', i + 2)) help.insert(i, "\\");
      md << "| `" << o.name << "` | " << type << " | " << def << " | " << o.unit << " | " << help << " |\n";
    }
  }
  return md.str();
}

}  // namespace terracl
