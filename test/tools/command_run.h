// Runs a command-line tool the way a user does and keeps what it printed: the tools' tests.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace ccir_mapping::test {

struct CommandRun {
  int exit_code = -1;  // -1 when the command could not start or was killed
  std::string output;  // stdout and stderr
};

/// Runs `command` through the shell with stderr joined to stdout.
inline CommandRun runCommand(const std::string& command) {
  CommandRun run;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return run;
  std::array<char, 4096> buffer;
  while (const std::size_t n = std::fread(buffer.data(), 1, buffer.size(), pipe)) {
    run.output.append(buffer.data(), n);
  }
  const int status = ::pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

}  // namespace ccir_mapping::test
