// SPDX-License-Identifier: Apache-2.0
#pragma once
// Helpers shared by the edit operations' tests.
#include "test_helpers.hpp"

#include <terracl/edit.hpp>
#include <terracl/error.hpp>

#include <string>

namespace terracl::test {

/// The error validating `op` alone on `base` gives (it names the JSON path), or "" when it is valid.
inline std::string edit_op_error(const Heightfield& base, const nlohmann::json& op) {
  EditSession s(device(), base);
  try {
    s.validate({{"operations", {op}}});
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace terracl::test
