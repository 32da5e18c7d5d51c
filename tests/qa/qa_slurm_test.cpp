// `vellum qa --snakemake --profile scripts/qa/slurm` against a real single-node Slurm that the
// test starts (munged, slurmctld, slurmd in the foreground on a private configuration, socket and
// ports) and stops. Skipped with a message without root or Debian's slurm-wlm and munge, or
// when the daemons do not come up.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <random>
#include <thread>

#include "child_process.hpp"
#include "test_data.hpp"
#include "vellum/core/json_input.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {

/// A daemon in the foreground, stopped (SIGTERM, then SIGKILL) when the test ends.
struct Daemon {
  pid_t pid = -1;
  Daemon(const std::vector<std::string>& argv, const fs::path& log) {
    pid = ::fork();
    if (pid == 0) {
      ::setpgid(0, 0);
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd >= 0) {
        ::dup2(fd, 1);
        ::dup2(fd, 2);
      }
      std::vector<char*> args;
      for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      ::execv(args[0], args.data());
      ::_exit(127);
    }
  }
  ~Daemon() {
    if (pid <= 0) return;
    ::kill(pid, SIGTERM);
    for (int i = 0; i < 100; ++i) {
      if (::waitpid(pid, nullptr, WNOHANG) == pid) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ::kill(pid, SIGKILL);
    ::waitpid(pid, nullptr, 0);
  }
  bool running() const { return pid > 0 && ::waitpid(pid, nullptr, WNOHANG) == 0; }
};

std::string output(const std::string& cmd) {
  std::string out;
  if (FILE* p = ::popen(cmd.c_str(), "r")) {
    char buf[256];
    while (fgets(buf, sizeof buf, p)) out += buf;
    ::pclose(p);
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return out;
}

}  // namespace

TEST(QaSlurm, ProfileRunsEachCaseAsASlurmJob) {
  for (const char* tool : {"/usr/sbin/munged", "/usr/sbin/slurmctld", "/usr/sbin/slurmd", "/usr/bin/sbatch"})
    if (!fs::exists(tool)) GTEST_SKIP() << tool << " not found (Debian packages slurm-wlm, munge): the Slurm profile is not tested";
  if (::geteuid() != 0) GTEST_SKIP() << "the single-node Slurm needs root: the Slurm profile is not tested";
  if (std::system("snakemake --version > /dev/null 2>&1") != 0) GTEST_SKIP() << "snakemake not found";
  const fs::path dir = test::tempDir("qa-slurm");
  for (const char* d : {"state", "spool", "munge"}) fs::create_directories(dir / d);
  ::chmod((dir / "munge").c_str(), 0700);
  {  // a private munge key
    std::ofstream key(dir / "munge" / "munge.key", std::ios::binary);
    std::mt19937_64 rng(std::random_device{}());
    for (int i = 0; i < 128; ++i) key.put(static_cast<char>(rng()));
  }
  ::chmod((dir / "munge" / "munge.key").c_str(), 0600);
  const fs::path socket = dir / "munge" / "munge.socket";
  const std::string host = output("hostname -s");
  const int port = 20000 + static_cast<int>(::getpid() % 20000);
  const fs::path conf = dir / "slurm.conf";
  std::ofstream(conf) << "ClusterName=vellumqatest\nSlurmctldHost=" << host << "\nSlurmUser=root\nSlurmdUser=root\n"
                      << "AuthType=auth/munge\nAuthInfo=socket=" << socket.string() << "\n"
                      << "StateSaveLocation=" << (dir / "state").string() << "\nSlurmdSpoolDir=" << (dir / "spool").string() << "\n"
                      << "SlurmctldPidFile=" << (dir / "slurmctld.pid").string() << "\nSlurmdPidFile=" << (dir / "slurmd.pid").string() << "\n"
                      << "ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\nJobAcctGatherType=jobacct_gather/none\n"
                      << "AccountingStorageType=accounting_storage/none\nSelectType=select/cons_tres\n"
                      << "SelectTypeParameters=CR_Core_Memory\nMpiDefault=none\nReturnToService=2\n"
                      << "SlurmctldPort=" << port << "\nSlurmdPort=" << port + 1 << "\n"
                      << "NodeName=" << host << " CPUs=" << std::max(1u, std::thread::hardware_concurrency()) << " RealMemory=16000 State=UNKNOWN\n"
                      << "PartitionName=qa Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n";
  ::setenv("SLURM_CONF", conf.c_str(), 1);  // sbatch, sinfo and the daemons read this configuration
  ::setenv("XDG_CACHE_HOME", (dir / "cache").c_str(), 1);  // Snakemake's cache stays in the test's folder
  Daemon munge({"/usr/sbin/munged", "-F", "--force", "--socket=" + socket.string(),
                "--key-file=" + (dir / "munge" / "munge.key").string(), "--pid-file=" + (dir / "munge" / "munged.pid").string(),
                "--log-file=" + (dir / "munge" / "munged.log").string(), "--seed-file=" + (dir / "munge" / "munged.seed").string()},
               dir / "munged.out");
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  Daemon ctld({"/usr/sbin/slurmctld", "-D", "-i", "-f", conf.string(), "-L", (dir / "slurmctld.log").string()}, dir / "slurmctld.out");
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  Daemon slurmd({"/usr/sbin/slurmd", "-D", "-f", conf.string(), "-N", host, "-L", (dir / "slurmd.log").string()}, dir / "slurmd.out");
  std::string state;
  for (int i = 0; i < 100 && state != "idle"; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    state = output("sinfo -h -o %t 2>/dev/null");
  }
  if (state != "idle") {
    const std::string why = test::readAll(dir / "slurmctld.log") + test::readAll(dir / "slurmd.log");
    ::unsetenv("SLURM_CONF");
    ::unsetenv("XDG_CACHE_HOME");
    GTEST_SKIP() << "the single-node Slurm did not start (node state '" << state << "'): the Slurm profile is not tested\n"
                 << why.substr(why.size() > 1500 ? why.size() - 1500 : 0);
  }
  // Three small phantom cases, each one Slurm job.
  nlohmann::json cases = nlohmann::json::array();
  for (int i = 0; i < 3; ++i)
    cases.push_back({{"name", "phantom-" + std::to_string(i)},
                     {"command", {"phantom", "--size", "16", "--seed", std::to_string(i + 1), "--out", "ct.nrrd"}},
                     {"checks", {{{"max_seconds", 600}}}}});
  std::ofstream(dir / "qa.json") << nlohmann::json{{"name", "slurm"}, {"cases", cases}}.dump(2);
  const fs::path profile = fs::path(VELLUM_TEST_SOURCE_DIR) / ".." / "scripts" / "qa" / "slurm";
  const int rc = test::Child({"qa", (dir / "qa.json").string(), "--out", (dir / "run").string(), "--snakemake", "--jobs", "2",
                              "--profile", profile.string()},
                             dir / "qa.log")
                     .wait();
  ::unsetenv("SLURM_CONF");
  ::unsetenv("XDG_CACHE_HOME");
  EXPECT_EQ(rc, 0) << test::readAll(dir / "qa.log");
  const nlohmann::json sum = readJsonFile(dir / "run" / "summary.json", 1 << 20, "summary");
  EXPECT_EQ(sum["cases"].get<int>(), 3);
  EXPECT_EQ(sum["failures"].get<int>(), 0);
  // The profile's sbatch --output: one Slurm log per case job (the report runs locally).
  int slurmLogs = 0;
  for (const auto& e : fs::directory_iterator(dir / "run" / "workflow"))
    slurmLogs += e.path().filename().string().rfind("slurm-", 0) == 0;
  EXPECT_EQ(slurmLogs, 3) << test::readAll(dir / "qa.log");
  EXPECT_TRUE(munge.running() && ctld.running() && slurmd.running());
}
