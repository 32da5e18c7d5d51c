// The shared report envelope (run_report.hpp).
#include "vellum/app/run_report.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <cstdio>
#include <fstream>

#include "vellum/core/error.hpp"
#include "vellum/io/output_policy.hpp"
#include "vellum_version.hpp"  // generated at configure time

namespace vellum::app {
namespace {

/// A 64-bit streaming hash: 8-byte words mixed by multiply-rotate (a simple design of our
/// own in the spirit of the common fast hashes; not cryptographic).
class Fingerprint {
 public:
  void bytes(const unsigned char* p, size_t n) {
    size_t i = 0;
    for (; i < n; ++i) {
      // Whole words at once where they line up (the same words the byte loop assembles).
      if (fill_ == 0 && std::endian::native == std::endian::little)
        for (; i + 8 <= n; i += 8) {
          std::memcpy(&word_, p + i, 8);
          flush();
        }
      if (i == n) break;
      word_ |= uint64_t(p[i]) << (8 * fill_);
      if (++fill_ == 8) flush();
    }
    length_ += n;
  }
  void text(const std::string& s) { bytes(reinterpret_cast<const unsigned char*>(s.data()), s.size()); }
  std::string hex() {
    flush();
    uint64_t h = state_ ^ length_;
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    char out[17];
    std::snprintf(out, sizeof out, "%016llx", static_cast<unsigned long long>(h));
    return out;
  }

 private:
  void flush() {
    const uint64_t x = state_ ^ (word_ * 0x9e3779b97f4a7c15ull);
    state_ = (x << 29 | x >> 35) * 0xbf58476d1ce4e5b9ull;
    word_ = 0;
    fill_ = 0;
  }
  uint64_t state_ = 0x243f6a8885a308d3ull, word_ = 0, length_ = 0;
  int fill_ = 0;
};

void hashFile(const std::filesystem::path& path, Fingerprint& f) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, "cannot be read for its fingerprint");
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), std::streamsize(buffer.size()));
    f.bytes(reinterpret_cast<const unsigned char*>(buffer.data()), size_t(in.gcount()));
  }
}

uint64_t sizeOf(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    uint64_t total = 0;
    for (const auto& e : std::filesystem::recursive_directory_iterator(path, ec))
      if (e.is_regular_file(ec)) total += e.file_size(ec);
    return total;
  }
  const auto n = std::filesystem::file_size(path, ec);
  return ec ? 0 : n;
}

nlohmann::json fileEntry(const std::filesystem::path& path) {
  return {{"path", path.string()}, {"bytes", sizeOf(path)}, {"fingerprint", contentFingerprint(path)}};
}

}  // namespace

std::string vellumVersion() { return VELLUM_VERSION_STRING; }
std::string vellumGitCommit() { return VELLUM_GIT_COMMIT; }

std::string contentFingerprint(const std::filesystem::path& path) {
  Fingerprint f;
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    std::vector<std::filesystem::path> files;
    for (const auto& e : std::filesystem::recursive_directory_iterator(path, ec))
      if (e.is_regular_file(ec)) files.push_back(e.path());
    if (ec) throw FileError(path, "cannot be listed for its fingerprint: " + ec.message());
    std::sort(files.begin(), files.end());
    for (const auto& file : files) {
      f.text(std::filesystem::relative(file, path).generic_string());
      f.text(std::string(1, '\0'));
      hashFile(file, f);
    }
    return f.hex();
  }
  hashFile(path, f);
  return f.hex();
}

double peakResidentMb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_maxrss) / 1024.0;  // KB on Linux
}

RunReport::RunReport(std::string commandLine) : command_(std::move(commandLine)) {}

RunReport::RunReport(std::string commandLine, Clock::time_point start)
    : command_(std::move(commandLine)), start_(start), last_(start) {}

void RunReport::outputVolume(const std::filesystem::path& path) {
  if (path.empty()) return;
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    output(path);
    return;
  }
  for (const auto& f : io::filesWrittenTo(path))
    if (std::filesystem::exists(f, ec)) output(f);
}

void RunReport::input(const std::filesystem::path& path, const std::string& role) {
  if (path.empty()) return;
  for (const auto& file : io::filesReadFrom(path)) {
    std::error_code ec;
    if (!std::filesystem::exists(file, ec)) continue;
    nlohmann::json e = fileEntry(file);
    e["role"] = file == path ? role : role + " (data file)";
    inputs_.push_back(std::move(e));
  }
}

void RunReport::loaded(const std::filesystem::path& path, const io::LoadedVolume& v) {
  for (auto& e : inputs_) {
    if (e["path"] != path.string()) continue;
    e["format"] = v.format;
    if (!v.modality.empty()) e["modality"] = v.modality;
    if (!v.seriesUid.empty()) {
      e["series_uid"] = v.seriesUid;
      for (const auto& s : v.series)
        if (s.uid == v.seriesUid) e["slices"] = s.frames;
    }
    const Geometry& g = geometryOf(v.volume);
    e["dims"] = {g.dims.x, g.dims.y, g.dims.z};
    e["spacing_mm"] = {g.spacing.x, g.spacing.y, g.spacing.z};
  }
  for (const auto& w : v.warnings) warnings_.push_back(path.string() + ": " + w);
}

void RunReport::mark(const std::string& stage) {
  const auto now = Clock::now();
  stages_[stage] = std::chrono::duration<double, std::milli>(now - last_).count();
  last_ = now;
}

void RunReport::output(const std::filesystem::path& path) { outputs_.push_back(fileEntry(path)); }

void RunReport::stamp(nlohmann::json& report) const {
  report["vellum"] = {{"version", vellumVersion()}, {"git_commit", vellumGitCommit()}, {"report_schema", 1}};
  report["command"] = command_;
  report["inputs"] = inputs_;
  report["warnings"] = warnings_;
  if (!stages_.empty()) report["stage_ms"] = stages_;
  report["total_ms"] = std::chrono::duration<double, std::milli>(Clock::now() - start_).count();
  report["peak_memory_mb"] = peakResidentMb();
  report["outputs"] = outputs_;
}

}  // namespace vellum::app
