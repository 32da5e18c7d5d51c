#pragma once
// The part of a command's report that is the same for every command (issue 25 §2): the tool
// (version, git commit), the command line, each input with its size and content fingerprint
// (DICOM: series UID and slice count), the load warnings, stage timings, peak memory and each
// output with its fingerprint. A command adds its own keys beside these; stamp() writes them.
//
// Fingerprints are 64-bit non-cryptographic content hashes (hex), for "is this the same file"
// in QA runs, not for security. A folder's fingerprint covers its regular files' names and
// contents in name order.
#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "vellum/io/volume_io.hpp"

namespace vellum::app {

/// "0.1.0".
std::string vellumVersion();
/// The git commit the binary was configured from ("" when not built from a git checkout).
std::string vellumGitCommit();
/// 16 hex digits over the bytes of a file, or over a folder's regular files (names and
/// contents, in name order). Throws vellum::FileError when it cannot be read.
std::string contentFingerprint(const std::filesystem::path& path);
/// Peak resident memory of this process so far, in MB (getrusage).
double peakResidentMb();

class RunReport {
 public:
  /// `commandLine`: the command as typed (the CLI passes its argv joined); may be empty.
  explicit RunReport(std::string commandLine);
  /// A report assembled after the work (the pipelines keep their own stage timings): total_ms
  /// counts from `start`.
  RunReport(std::string commandLine, std::chrono::steady_clock::time_point start);
  /// An output file (a volume's header data file and a raw sidecar with it); missing ones skipped.
  void outputVolume(const std::filesystem::path& path);
  /// An input as read (a volume's header data file and a raw sidecar are fingerprinted with it).
  void input(const std::filesystem::path& path, const std::string& role);
  /// A loaded volume: its DICOM series and slice count, and its load warnings.
  void loaded(const std::filesystem::path& path, const io::LoadedVolume& volume);
  void warning(const std::string& text) { warnings_.push_back(text); }
  /// Wall time of a stage since the previous mark (or the start), in ms.
  void mark(const std::string& stage);
  void output(const std::filesystem::path& path);
  /// Adds "vellum", "command", "inputs", "warnings", "stage_ms", "peak_memory_mb" and "outputs"
  /// to `report` (an object; other keys are kept).
  void stamp(nlohmann::json& report) const;

 private:
  using Clock = std::chrono::steady_clock;
  std::string command_;
  nlohmann::json inputs_ = nlohmann::json::array(), outputs_ = nlohmann::json::array();
  nlohmann::json stages_ = nlohmann::json::object();
  std::vector<std::string> warnings_;
  Clock::time_point start_ = Clock::now(), last_ = start_;
};

}  // namespace vellum::app
