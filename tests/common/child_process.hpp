#pragma once
// The real `vellum` binary as a child process, for tests of signals, limits and faults.
// Needs VELLUM_CLI_PATH (the binary) defined by the test target.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace vellum::test {

inline std::string readAll(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

/// A running `vellum` child; stdout and stderr go to `errFile`. `beforeExec` runs in the
/// child (limits, mounts).
struct Child {
  pid_t pid = -1;
  std::filesystem::path stderrPath;

  Child(const std::vector<std::string>& args, const std::filesystem::path& errFile,
        const std::function<void()>& beforeExec = {})
      : stderrPath(errFile) {
    pid = ::fork();
    if (pid == 0) {
      const int fd = ::open(errFile.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd >= 0) {
        ::dup2(fd, 2);
        ::dup2(fd, 1);
      }
      if (beforeExec) beforeExec();
      std::vector<char*> argv{const_cast<char*>(VELLUM_CLI_PATH)};
      for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      ::execv(VELLUM_CLI_PATH, argv.data());
      ::_exit(127);
    }
  }
  /// Waits; returns the exit code, or 128 + signal.
  int wait() {
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  std::string errors() const { return readAll(stderrPath); }
  /// Waits until the child catches `sig` (its handler is installed: /proc/PID/status SigCgt),
  /// so that a slow start-up (a loaded machine, sanitizer builds) does not make a race.
  bool waitUntilCatching(int sig) const {
    for (int i = 0; i < 1000; ++i) {
      std::ifstream status("/proc/" + std::to_string(pid) + "/status");
      std::string line;
      while (std::getline(status, line))
        if (line.rfind("SigCgt:", 0) == 0 && (std::stoull(line.substr(7), nullptr, 16) >> (sig - 1)) & 1u)
          return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }
};

}  // namespace vellum::test
