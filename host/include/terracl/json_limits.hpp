// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Reading JSON documents written by users (pipelines, edit scripts, constraints, sidecars) with
/// limits, so that a hostile file gives a clear error instead of exhausting the stack or memory:
/// at most `max_json_depth` nested arrays/objects and `max_json_bytes` bytes. Numbers that do not
/// fit a double (1e400) and malformed text are reported with the file name.
#include <nlohmann/json.hpp>

#include <cstddef>
#include <string>

namespace terracl {

/// Deepest nesting of arrays/objects accepted (a real pipeline or script needs < 10).
constexpr int max_json_depth = 64;
/// Largest JSON document accepted (64 MiB: far above any real script, pipeline or sketch).
constexpr std::size_t max_json_bytes = std::size_t(64) << 20;

/// Parses `text`; throws Error(stage, "<what>: ...") when it is malformed, too deep or too large.
nlohmann::json parse_json_limited(const std::string& text, const std::string& stage, const std::string& what);
/// Reads and parses the file at `path` (named in errors); throws Error(stage, ...) when it cannot
/// be read. `usage` makes the error a UsageError (exit 2), as for a pipeline file.
nlohmann::json read_json_file(const std::string& path, const std::string& stage, bool usage = false);

/// `text` cut to at most `max_chars` characters with "... (N characters)" appended, so that an
/// error message never echoes a 100 KB value.
std::string abbreviate(const std::string& text, std::size_t max_chars = 80);

}  // namespace terracl
