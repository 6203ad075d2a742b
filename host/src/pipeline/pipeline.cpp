// SPDX-License-Identifier: Apache-2.0
// Pipeline parsing, overrides and validation. Everything that can be checked without running is
// checked here, so that `terracl run --validate` catches a typo before a long run starts; every
// error names the pipeline file and the JSON path of the value at fault.
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/json_limits.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/version.hpp>

namespace terracl {
namespace fs = std::filesystem;

namespace {

bool valid_tag(const std::string& t) {
  if (t.empty()) return false;
  for (unsigned char c : t)
    if (!std::isalnum(c) && c != '_' && c != '-') return false;
  return true;
}

std::string stage_names(const StageRegistry& reg) {
  std::string s;
  for (const auto& st : reg.all()) s += (s.empty() ? "" : ", ") + st.name;
  return s;
}

std::string option_names(const StageInfo& s) {
  std::string names;
  for (const auto& o : s.options) names += (names.empty() ? "" : ", ") + o.name;
  return names.empty() ? "none" : names;
}

// The message of an Error without its "<stage>: " prefix.
std::string bare_message(const Error& e) { return std::string(e.what()).substr(e.stage().size() + 2); }

// Two spellings of one file ("out/a.tif", "./out/../out/a.tif") are the same output.
std::string same_file_key(const std::string& p) {
  std::error_code ec;
  const fs::path c = fs::weakly_canonical(fs::absolute(p), ec);
  return ec ? fs::absolute(p).lexically_normal().string() : c.string();
}

}  // namespace

void Pipeline::error(const std::string& message) const {
  throw UsageError("pipeline", m_source.empty() ? message : m_source + ": " + message);
}

Pipeline Pipeline::parse(const json& doc, const std::string& name, const std::string& source,
                         const StageRegistry& registry) {
  Pipeline p;
  p.m_name = name;
  p.m_source = source;
  const json* stages = &doc;
  std::string prefix;
  if (doc.is_object()) {
    for (auto& [key, value] : doc.items())
      if (key != "pipeline" && key != "terracl" && key != "description")
        p.error(
            fmt::format("/{}: unknown key; a pipeline object has \"pipeline\" (the stages), \"description\" (text) and "
                        "\"terracl\" (run information)",
                        abbreviate(key)));
    if (!doc.contains("pipeline")) p.error("expected a JSON array of stages, or an object with a \"pipeline\" array");
    stages = &doc.at("pipeline");
    prefix = "/pipeline";
  }
  if (!stages->is_array())
    p.error(
        fmt::format("{}: expected a JSON array of stages, got {}", prefix.empty() ? "/" : prefix, stages->type_name()));
  if (stages->empty())
    p.error(fmt::format(
        "{}: the pipeline is empty; it needs at least a reader and a writer, e.g. [\"in.tif\", \"out.exr\"]",
        prefix.empty() ? "/" : prefix));

  for (size_t i = 0; i < stages->size(); ++i) {
    const json& e = stages->at(i);
    PipelineStage st;
    st.where = fmt::format("{}/{}", prefix, i);
    const char* file_stage = i == 0 ? "read" : "write";
    if (e.is_string()) {
      const std::string s = e.get<std::string>();
      if (registry.find(s) && fs::path(s).extension().empty()) {
        st.type = s;
        st.options = json::object();
      } else if (fs::path(s).extension().empty()) {
        p.error(fmt::format("{}: '{}' is neither a stage nor a file name with an extension (stages: {})", st.where, abbreviate(s),
                            stage_names(registry)));
      } else {
        st.type = file_stage;
        st.options = json{{"filename", s}};
      }
    } else if (e.is_object()) {
      if (e.contains("type")) {
        if (!e.at("type").is_string())
          p.error(fmt::format("{}/type: expected a stage name, got {}", st.where, abbreviate(e.at("type").dump())));
        st.type = e.at("type").get<std::string>();
        if (!registry.find(st.type))
          p.error(fmt::format("{}/type: unknown stage '{}' (stages: {})", st.where, abbreviate(st.type), stage_names(registry)));
      } else if (e.contains("filename")) {
        st.type = file_stage;
      } else {
        p.error(fmt::format("{}: a stage needs a \"type\" (or a \"filename\" for a reader or writer)", st.where));
      }
      if (e.contains("tag")) {
        if (!e.at("tag").is_string() || !valid_tag(e.at("tag").get<std::string>()))
          p.error(fmt::format("{}/tag: a tag is a non-empty string of letters, digits, '_' and '-', got {}", st.where,
                              abbreviate(e.at("tag").dump())));
        st.tag = e.at("tag").get<std::string>();
      }
      st.options = json::object();
      for (auto& [key, value] : e.items())
        if (key != "type" && key != "tag") st.options[key] = value;
    } else {
      p.error(fmt::format("{}: expected a stage object or a file name, got {}", st.where, abbreviate(e.dump())));
    }
    st.info = registry.find(st.type);
    p.m_stages.push_back(std::move(st));
  }

  // Tags: explicit ones first, then the type (or type + occurrence when the type repeats).
  std::map<std::string, std::string> owner;  // tag -> where
  for (const auto& st : p.m_stages) {
    if (st.tag.empty()) continue;
    if (owner.count(st.tag))
      p.error(fmt::format("{}/tag: tag '{}' is already used by {}", st.where, st.tag, owner[st.tag]));
    owner[st.tag] = st.where;
  }
  std::map<std::string, int> untagged, seen;
  for (const auto& st : p.m_stages)
    if (st.tag.empty()) ++untagged[st.type];
  for (auto& st : p.m_stages) {
    if (!st.tag.empty()) continue;
    st.tag = untagged[st.type] > 1 ? fmt::format("{}{}", st.type, ++seen[st.type]) : st.type;
    if (owner.count(st.tag))
      p.error(fmt::format("{}/tag: tag '{}' is also the automatic tag of the stage at {}; choose another tag",
                          owner[st.tag], st.tag, st.where));
    owner[st.tag] = st.where;
  }
  return p;
}

Pipeline Pipeline::load(const std::string& path, const StageRegistry& registry) {
  std::ifstream in(path);
  if (!in || fs::is_directory(path))
    throw UsageError("pipeline", fmt::format("{}: cannot read the pipeline file", path));
  const json doc = read_json_file(path, "pipeline", true);  // depth and size limits
  std::string name = fs::path(path).stem().string();
  const std::string suffix = ".resolved";
  if (name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0)
    name.resize(name.size() - suffix.size());
  return parse(doc, name, path, registry);
}

void Pipeline::set(const std::string& assignment) {
  const auto eq = assignment.find('=');
  const auto dot = assignment.find('.');
  if (eq == std::string::npos || dot == std::string::npos || dot > eq || dot == 0 || dot + 1 == eq)
    throw UsageError("run", fmt::format("--set expects TAG.OPTION=VALUE, got '{}'", abbreviate(assignment)));
  const std::string tag = assignment.substr(0, dot), option = assignment.substr(dot + 1, eq - dot - 1),
                    value = assignment.substr(eq + 1);
  for (auto& st : m_stages) {
    if (st.tag != tag) continue;
    for (const auto& o : st.info->options) {
      if (o.name != option) continue;
      const json v = option_from_text(o, value);
      // Check the value now, so that the error names the --set that brought it (files are
      // checked by validate(): an earlier stage may write them).
      StageInfo one{st.type, "", DataKind::None, DataKind::None, {o}, nullptr};
      if (o.type == OptionType::Path) one.options[0].type = OptionType::String;
      one.options[0].required = false;
      try {
        resolve_options(one, json{{option, v}}, st.where);
      } catch (const Error& e) {
        throw UsageError("run", fmt::format("--set {}: {}", assignment, bare_message(e)));
      }
      st.options[option] = v;
      m_validated = false;
      return;
    }
    throw UsageError("run", fmt::format("--set {}: stage '{}' ({}) has no option '{}' (options: {})", assignment, tag,
                                        st.type, option, option_names(*st.info)));
  }
  std::string tags;
  for (const auto& st : m_stages) tags += (tags.empty() ? "" : ", ") + st.tag;
  throw UsageError("run", fmt::format("--set {}: no stage is tagged '{}' (tags: {})", assignment, tag, tags));
}

void Pipeline::validate() {
  DataKind current = DataKind::None;
  std::string producer;                           // tag of the stage that produced `current`
  std::vector<std::string> pending;               // files written by earlier stages
  std::map<std::string, DataKind> pending_kind;   // what they hold
  std::map<std::string, std::string> written_by;  // same_file_key -> where
  std::map<std::string, std::string> inputs;      // same_file_key -> where (files read)

  for (auto& st : m_stages) {
    const StageInfo& info = *st.info;
    try {
      st.options = resolve_options(info, st.options, st.where, pending);
    } catch (const UsageError&) {
      throw;
    } catch (const MissingFileError& e) {  // invalid, and still a missing file (Python: FileNotFoundError)
      throw MissingInputError("pipeline", m_source.empty() ? bare_message(e) : m_source + ": " + bare_message(e),
                              e.path());
    } catch (const Error& e) {
      error(bare_message(e));
    }

    const DataKind need = info.input;
    if (need != DataKind::None) {
      const bool ok = need == DataKind::Any ? current != DataKind::None : current == need;
      if (!ok) {
        const std::string before = current == DataKind::None ? "nothing comes before it (start with a reader: a file "
                                                               "name or {\"type\": \"read\", \"filename\": ...})"
                                                             : fmt::format("the stage before it ('{}') produces a {}",
                                                                           producer, data_kind_name(current));
        error(fmt::format("{}: stage '{}' ({}) needs a {} as input, but {}", st.where, st.tag, st.type,
                          data_kind_name(need), before));
      }
    }
    st.input = current;

    DataKind out = info.output;
    if (info.check) {
      try {
        out = info.check(st.options, current, st.where);
      } catch (const UsageError&) {
        throw;
      } catch (const Error& e) {
        error(bare_message(e));
      }
    }
    // A reader of a file written earlier in this pipeline gets what was written there.
    if (st.options.contains("filename") && st.options["filename"].is_string()) {
      auto it = pending_kind.find(same_file_key(st.options["filename"].get<std::string>()));
      if (it != pending_kind.end() && info.input == DataKind::None) out = it->second;
    }
    if (out == DataKind::None || out == DataKind::Any) out = current;
    st.output = out;

    st.outputs.clear();
    for (const auto& o : info.options) {
      const json& v = st.options[o.name];
      if (!v.is_string()) continue;
      const std::string file = v.get<std::string>();
      const std::string key = same_file_key(file);
      const std::string path = st.where + "/" + o.name;
      if (o.type == OptionType::Path && !pending_kind.count(key)) inputs.emplace(key, path);
      if (o.type != OptionType::OutputPath) continue;
      if (written_by.count(key)) error(fmt::format("{}: {} is also written by {}", path, file, written_by[key]));
      if (inputs.count(key))
        error(fmt::format("{}: {} is an input of this pipeline ({}); write to another file", path, file, inputs[key]));
      try {
        check_output_paths("pipeline", {}, {{path, file}});  // the subcommands' check: no devices, folders
      } catch (const Error& e) {
        error(bare_message(e));
      }
      // The folder is created when missing; an existing one must be writable.
      std::error_code ec;
      fs::path dir = fs::absolute(file).parent_path();
      while (!dir.empty() && !fs::exists(dir, ec) && dir != dir.parent_path()) dir = dir.parent_path();
      if (!fs::is_directory(dir, ec) || ::access(dir.c_str(), W_OK) != 0)
        error(fmt::format("{}: cannot write {}: {} is not a writable folder", path, file, dir.string()));
      written_by[key] = path;
      pending_kind[key] = out;
      pending.push_back(file);
      st.outputs.push_back(file);
    }
    current = out;
    producer = st.tag;
  }
  if (pending.empty())
    error(
        "the pipeline writes nothing: add an output file name (e.g. \"out.tif\") or a {\"type\": \"write\", "
        "\"filename\": ...} stage");
  m_validated = true;
}

json Pipeline::resolved() const {
  if (!m_validated) throw Error("pipeline", "resolved() needs a validated pipeline");
  json a = json::array();
  for (const auto& st : m_stages) {
    json o = json::object();
    o["type"] = st.type;
    o["tag"] = st.tag;
    for (auto& [k, v] : st.options.items())
      if (!v.is_null()) o[k] = v;
    a.push_back(o);
  }
  return a;
}

std::string Pipeline::hash() const {
  const std::string s = resolved().dump();
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return fmt::format("{:016x}", h);
}

std::vector<std::string> Pipeline::outputs() const {
  std::vector<std::string> v;
  for (const auto& st : m_stages) v.insert(v.end(), st.outputs.begin(), st.outputs.end());
  return v;
}

std::string Pipeline::resolved_path() const {
  const auto out = outputs();
  if (out.empty()) return "";
  fs::path dir = fs::path(out.front()).parent_path();
  return (dir / (m_name + ".resolved.json")).string();
}

std::vector<std::string> RunReport::outputs() const {
  std::vector<std::string> v;
  for (const auto& s : stages) v.insert(v.end(), s.outputs.begin(), s.outputs.end());
  return v;
}

}  // namespace terracl
