// SPDX-License-Identifier: Apache-2.0
// libFuzzer harness: JSON text -> limited parser -> every edit operation's parameter parsing and
// validation against a 65 x 49 grid (validate_edit_script: what `terracl edit --validate` runs,
// without a device). Relative file names resolve in tests/fuzz/assets (TERRACL_FUZZ_ASSETS), which
// holds a small exemplar and dictionary, so that amplify, copy_paste and fit operations get past
// "file not found" to their own parameter parsing and the .tdic reader.
#include <terracl/edit.hpp>
#include <terracl/error.hpp>
#include <terracl/json_limits.hpp>

#include <cstdint>
#include <string>

#ifndef TERRACL_FUZZ_ASSETS
#error "TERRACL_FUZZ_ASSETS (tests/fuzz/assets) must be defined by tests/fuzz/CMakeLists.txt"
#endif

using namespace terracl;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const nlohmann::json doc =
        parse_json_limited(std::string(reinterpret_cast<const char*>(data), size), "fuzz", "input");
    validate_edit_script(doc, 65, 49, 30.0, TERRACL_FUZZ_ASSETS);
  } catch (const Error&) {
  }
  return 0;
}
