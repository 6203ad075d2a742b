// SPDX-License-Identifier: Apache-2.0
// Limited JSON reading. nlohmann's parser is iterative, but copying, comparing and dumping a
// document recurse once per level, so a file nested 80,000 deep crashed whichever of those ran
// first; the depth is therefore checked while parsing (the callback sees each level as it opens).
#include <terracl/error.hpp>
#include <terracl/json_limits.hpp>

#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace terracl {

std::string abbreviate(const std::string& text, std::size_t max_chars) {
  if (text.size() <= max_chars) return text;
  return fmt::format("{}... ({} characters)", text.substr(0, max_chars), text.size());
}

namespace {

struct TooDeep {};

}  // namespace

nlohmann::json parse_json_limited(const std::string& text, const std::string& stage, const std::string& what) {
  if (text.size() > max_json_bytes)
    fail(stage, "{}: {} bytes of JSON; the limit is {} MiB", what, text.size(), max_json_bytes >> 20);
  auto limit_depth = [](int depth, nlohmann::json::parse_event_t event, nlohmann::json&) {
    if ((event == nlohmann::json::parse_event_t::object_start || event == nlohmann::json::parse_event_t::array_start) &&
        depth >= max_json_depth)
      throw TooDeep{};
    return true;
  };
  try {
    return nlohmann::json::parse(text, limit_depth);
  } catch (const TooDeep&) {
    fail(stage, "{}: JSON nested deeper than {} levels (arrays/objects); the limit is {}", what, max_json_depth,
         max_json_depth);
  } catch (const nlohmann::json::out_of_range& e) {
    // 1e400 and the like: the number does not fit a double.
    fail(stage, "{}: a number in the JSON is out of range ({})", what, abbreviate(e.what(), 120));
  } catch (const nlohmann::json::exception& e) {
    fail(stage, "{}: malformed JSON (not valid JSON): {}", what, abbreviate(e.what(), 200));
  }
}

nlohmann::json read_json_file(const std::string& path, const std::string& stage, bool usage) {
  auto raise = [&](const std::string& message) {
    if (usage) throw UsageError(stage, message);
    throw Error(stage, message);
  };
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) raise(fmt::format("{}: is a folder, expected a JSON file", path));
  std::ifstream in(path, std::ios::binary);
  if (!in) raise(fmt::format("{}: cannot read the file", path));
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec && size > max_json_bytes)
    raise(fmt::format("{}: {} bytes of JSON; the limit is {} MiB", path, size, max_json_bytes >> 20));
  std::ostringstream s;
  s << in.rdbuf();
  try {
    return parse_json_limited(s.str(), stage, path);
  } catch (const UsageError&) {
    throw;
  } catch (const Error& e) {
    if (usage) throw UsageError(stage, std::string(e.what()).substr(stage.size() + 2));
    throw;
  }
}

}  // namespace terracl
