#include "vellum/io/video_io.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include "vellum/core/error.hpp"
#include "vellum/io/replaced_files.hpp"

extern char** environ;

namespace vellum::io {

namespace fs = std::filesystem;

namespace {

std::atomic<uint64_t> gVideoCounter{0};

bool onPath(const std::string& exe) {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  std::stringstream ss(path);
  std::string dir;
  while (std::getline(ss, dir, ':'))
    if (!dir.empty() && ::access((fs::path(dir) / exe).c_str(), X_OK) == 0) return true;
  return false;
}

}  // namespace

bool videoEncoderAvailable() {
  static const bool ok = onPath("ffmpeg");
  return ok;
}

struct VideoWriter::Impl {
  fs::path target, tmp, log;
  int width = 0, height = 0;
  pid_t pid = -1;
  int fd = -1;
  int frames = 0;
  bool finished = false;

  void closePipe() {
    if (fd >= 0) ::close(fd);
    fd = -1;
  }
  int wait() {
    int status = 0;
    if (pid > 0) {
      while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
      pid = -1;
    }
    return status;
  }
  std::string logTail() const {
    std::ifstream in(log);
    std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (all.size() > 300) all = all.substr(all.size() - 300);
    for (char& c : all) if (c == '\n') c = ' ';
    return all;
  }
};

VideoWriter::VideoWriter(const fs::path& path, int width, int height, double fps)
    : impl_(std::make_unique<Impl>()) {
  auto& m = *impl_;
  if (width <= 0 || height <= 0) throw FileError(path, "video frame size must be positive");
  if (!(fps > 0) || fps > 1000) throw FileError(path, "frames per second must be in (0, 1000]");
  if (!videoEncoderAvailable()) throw FileError(path, "cannot write a movie: no ffmpeg executable on PATH");
  m.target = path;
  m.width = width;
  m.height = height;
  const fs::path folder = path.parent_path();
  const std::string tag = ".vellum-video-" + std::to_string(::getpid()) + "-" +
                          std::to_string(gVideoCounter.fetch_add(1)) + "-";
  m.tmp = (folder.empty() ? fs::path(".") : folder) / (tag + path.filename().string());
  m.log = (folder.empty() ? fs::path(".") : folder) / (tag + "ffmpeg.log");

  int pipefd[2];
  if (::pipe(pipefd) != 0) throw FileError(path, "cannot create a pipe to ffmpeg");
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, pipefd[0], 0);
  posix_spawn_file_actions_addclose(&fa, pipefd[1]);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&fa, 2, m.log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const std::string size = std::to_string(width) + "x" + std::to_string(height);
  const std::string rate = std::to_string(fps);
  std::vector<std::string> args = {"ffmpeg", "-nostdin", "-y", "-loglevel", "error",
                                   "-f", "rawvideo", "-pix_fmt", "rgba", "-s", size, "-r", rate,
                                   "-i", "pipe:0", "-an", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                                   "-c:v", "libx264", "-preset", "veryfast", "-crf", "20",
                                   "-pix_fmt", "yuv420p", "-movflags", "+faststart", m.tmp.string()};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const int rc = posix_spawnp(&m.pid, "ffmpeg", &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  ::close(pipefd[0]);
  if (rc != 0) {
    ::close(pipefd[1]);
    m.pid = -1;
    throw FileError(path, std::string("cannot start ffmpeg: ") + std::strerror(rc));
  }
  m.fd = pipefd[1];
  ::signal(SIGPIPE, SIG_IGN);  // a dying encoder must give a write error, not kill us
}

VideoWriter::~VideoWriter() {
  if (!impl_ || impl_->finished) return;
  auto& m = *impl_;
  m.closePipe();
  if (m.pid > 0) ::kill(m.pid, SIGTERM);
  m.wait();
  std::error_code ec;
  fs::remove(m.tmp, ec);
  fs::remove(m.log, ec);
}

int VideoWriter::framesWritten() const { return impl_->frames; }

void VideoWriter::addFrame(const RgbaImage& frame) {
  auto& m = *impl_;
  if (m.finished || m.fd < 0) throw FileError(m.target, "video already finished");
  if (frame.width != m.width || frame.height != m.height)
    throw FileError(m.target, "frame " + std::to_string(m.frames) + " is " + std::to_string(frame.width) +
                                  "x" + std::to_string(frame.height) + ", the movie is " +
                                  std::to_string(m.width) + "x" + std::to_string(m.height));
  const uint8_t* p = frame.pixels.data();
  size_t left = frame.pixels.size();
  while (left > 0) {
    const ssize_t n = ::write(m.fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw FileError(m.target, "ffmpeg stopped accepting frames: " + m.logTail());
    p += n;
    left -= static_cast<size_t>(n);
  }
  ++m.frames;
}

void VideoWriter::finish() {
  auto& m = *impl_;
  if (m.finished) return;
  m.closePipe();
  const int status = m.wait();
  std::error_code ec;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || m.frames == 0) {
    const std::string why = m.frames == 0 ? "no frames" : "ffmpeg failed: " + m.logTail();
    fs::remove(m.tmp, ec);
    fs::remove(m.log, ec);
    m.finished = true;
    throw FileError(m.target, why);
  }
  fs::remove(m.log, ec);
  ReplacedFiles::keepBeforeReplacing(m.target);  // a run that fails later puts it back
  fs::rename(m.tmp, m.target, ec);
  m.finished = true;
  if (ec) {
    fs::remove(m.tmp, ec);
    throw FileError(m.target, "cannot move the finished movie into place");
  }
}

void saveVideo(const std::vector<RgbaImage>& frames, const fs::path& path, double fps) {
  if (frames.empty()) throw FileError(path, "no frames");
  VideoWriter w(path, frames[0].width, frames[0].height, fps);
  for (const auto& f : frames) w.addFrame(f);
  w.finish();
}

}  // namespace vellum::io
