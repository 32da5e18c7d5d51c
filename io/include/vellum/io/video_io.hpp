#pragma once
// Movies: MP4 (H.264, yuv420p) through the ffmpeg executable, frames piped as raw RGBA.
// Atomic: frames go to a hidden temporary sibling that is renamed onto the target only when
// the encoder finished successfully.
#include <filesystem>
#include <memory>
#include <vector>

#include "vellum/core/image.hpp"

namespace vellum::io {

/// True when an `ffmpeg` executable is on PATH (checked once).
bool videoEncoderAvailable();

class VideoWriter {
 public:
  /// Starts the encoder for `path` (.mp4; .mkv/.mov/.avi also work) at `fps` frames per
  /// second. Odd sizes are padded to even. Throws vellum::FileError naming the path when
  /// ffmpeg is missing or cannot start, or for fps <= 0 or an empty size.
  VideoWriter(const std::filesystem::path& path, int width, int height, double fps);
  /// Without finish(), abandons the movie: stops the encoder and removes the temporary.
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  /// Appends one frame; its size must be the one given at construction.
  void addFrame(const RgbaImage& frame);
  /// Closes the stream, waits for ffmpeg, checks its status, renames into place.
  void finish();
  int framesWritten() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Convenience: all frames at once.
void saveVideo(const std::vector<RgbaImage>& frames, const std::filesystem::path& path, double fps);

}  // namespace vellum::io
