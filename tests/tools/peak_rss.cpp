// SPDX-License-Identifier: Apache-2.0
// peak_rss COMMAND [ARGS...]: runs COMMAND and prints its peak resident memory in KiB on stderr's
// last line ("peak_rss_kib N"), exiting with its status. The tests measure the CLI through this
// small process: a child forked straight from the test binary starts with the test's own resident
// pages (copy-on-write, counted as its own), and Linux keeps that figure in the child's maximum
// across exec, so a CLI lighter than the test would read as heavy as the test.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: peak_rss COMMAND [ARGS...]\n");
    return 2;
  }
  const pid_t pid = fork();
  if (pid < 0) return 126;
  if (pid == 0) {
    execv(argv[1], argv + 1);
    _exit(127);
  }
  int status = 0;
  rusage ru{};
  if (wait4(pid, &status, 0, &ru) != pid) return 126;
  std::fprintf(stderr, "peak_rss_kib %ld\n", ru.ru_maxrss);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}
