#include "stage_flags.hpp"

#include <fmt/format.h>

namespace terracl::cli {

std::string kebab(std::string s) {
  for (char& c : s)
    if (c == '_') c = '-';
  return s;
}

void StageFlags::add(CLI::App* sub, const StageInfo& stage, const std::string& output_option, bool enforce_required) {
  for (const auto& o : stage.options) {
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
    const std::string flag = "--" + kebab(o.name);
    if (o.type == OptionType::Bool) {
      if (sub->count(flag) || sub->count("--no-" + kebab(o.name))) opts[o.name] = m_flags.at(o.name);
    } else if (sub->count(flag)) {
      opts[o.name] = option_from_text(o, m_values.at(o.name));
    }
  }
  return opts;
}

}  // namespace terracl::cli
