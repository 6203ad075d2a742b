// SPDX-License-Identifier: Apache-2.0
// The CLI's 2 MB pages (apps/allocator.cpp): a command that works on data starts itself again with
// glibc.malloc.hugetlb=1 and then takes a fraction of the page faults, with the user's other
// tunables kept; GLIBC_TUNABLES=glibc.malloc.hugetlb=0 turns it off.
#include "test_helpers.hpp"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <string>
#include <vector>

extern char** environ;

using namespace terracl;

namespace {

struct CliRun {
  int exit_code = -1;
  long faults = -1;  // minor page faults of the command (and of what it executed in its place)
};

// Runs the CLI with GLIBC_TUNABLES set to `tunables` (unset when empty), output to /dev/null.
CliRun run_with_tunables(const std::string& tunables, const std::vector<std::string>& args) {
  std::vector<std::string> all = {TERRACL_CLI};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<std::string> env_store;
  for (char** e = environ; *e; ++e)
    if (std::string(*e).rfind("GLIBC_TUNABLES=", 0) != 0) env_store.push_back(*e);
  if (!tunables.empty()) env_store.push_back("GLIBC_TUNABLES=" + tunables);
  std::vector<char*> envp;
  for (auto& e : env_store) envp.push_back(e.data());
  envp.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    if (FILE* n = std::freopen("/dev/null", "w", stdout)) (void)n;
    execve(argv[0], argv.data(), envp.data());
    _exit(127);
  }
  CliRun r;
  int status = 0;
  rusage u{};
  if (pid > 0 && wait4(pid, &status, 0, &u) == pid) {
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.faults = u.ru_minflt;
  }
  return r;
}

bool huge_pages_on_request() {
  std::ifstream f("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  return std::getline(f, line) && line.find("[madvise]") != std::string::npos;
}

}  // namespace

TEST(CliAllocator, DataCommandsUseHugePagesUnlessTurnedOff) {
  test::TempDir tmp;
  const std::string script = tmp.path("empty.json");
  std::ofstream(script) << R"({"operations": []})";
  const std::vector<std::string> args = {"-q", "edit", "flat:1537x1537@10", "--script", script, "-o", tmp.path("out.tif")};
  const CliRun off = run_with_tunables("glibc.malloc.hugetlb=0", args);
  const CliRun on = run_with_tunables("", args);
  // Another tunable of the user's stays; hugetlb is added to it.
  const CliRun kept = run_with_tunables("glibc.malloc.tcache_count=0", args);
  ASSERT_EQ(off.exit_code, 0);
  ASSERT_EQ(on.exit_code, 0);
  ASSERT_EQ(kept.exit_code, 0);
  if (huge_pages_on_request()) {
    // 1537^2 float32 fields are 9.4 MB each: ~40,000 faults with 4 KB pages, ~5,000 with 2 MB ones.
    EXPECT_LT(on.faults * 3, off.faults) << "on " << on.faults << ", off " << off.faults;
    EXPECT_LT(kept.faults * 3, off.faults) << "kept " << kept.faults << ", off " << off.faults;
  } else {
    // The kernel gives no pages on request (THP "always" or "never"): nothing is started again.
    EXPECT_LT(on.faults, off.faults * 2) << "on " << on.faults << ", off " << off.faults;
  }
  // A command that only starts up is not started twice: --version stays at its own faults.
  const CliRun version = run_with_tunables("", {"--version"});
  const CliRun version_off = run_with_tunables("glibc.malloc.hugetlb=0", {"--version"});
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_LT(version.faults, version_off.faults * 3 / 2 + 200) << version.faults << " against " << version_off.faults;
}
