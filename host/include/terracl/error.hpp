// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Errors thrown by the library. Every message starts with "<stage>: " so that the CLI can print
/// `terracl ERROR: <stage>: <message>` without knowing where it came from.
#include <fmt/format.h>

#include <stdexcept>
#include <string>

namespace terracl {

/// Base of every error the library throws; what() is "<stage>: <message>".
class Error : public std::runtime_error {
 public:
  Error(const std::string& stage, const std::string& message)
      : std::runtime_error(stage + ": " + message), m_stage(stage) {}
  const std::string& stage() const { return m_stage; }

 private:
  std::string m_stage;
};

/// Thrown for bad command-line or pipeline usage (the CLI exits with 2 for these).
class UsageError : public Error {
 public:
  using Error::Error;
};

/// Thrown when an input file does not exist (Python: terracl.MissingFileError, a FileNotFoundError
/// with .filename); the CLI exits with 1, as for other errors.
class MissingFileError : public Error {
 public:
  MissingFileError(const std::string& stage, const std::string& message, const std::string& path)
      : Error(stage, message), m_path(path) {}
  const std::string& path() const { return m_path; }

 private:
  std::string m_path;
};

/// A pipeline naming an input file that does not exist: invalid like any bad pipeline (the CLI
/// exits with 2), and a missing file all the same (Python: terracl.MissingFileError).
class MissingInputError : public UsageError {
 public:
  MissingInputError(const std::string& stage, const std::string& message, const std::string& path)
      : UsageError(stage, message), m_path(path) {}
  const std::string& path() const { return m_path; }

 private:
  std::string m_path;
};

/// Thrown when a progress callback asked to stop (the CLI exits with 130, the Ctrl-C convention).
class Cancelled : public Error {
 public:
  explicit Cancelled(const std::string& stage, const std::string& message = "cancelled") : Error(stage, message) {}
};

/// Throws Error(stage, fmt::format(f, args...)).
template <typename... Args>
[[noreturn]] void fail(const std::string& stage, fmt::format_string<Args...> f, Args&&... args) {
  throw Error(stage, fmt::format(f, std::forward<Args>(args)...));
}

}  // namespace terracl
