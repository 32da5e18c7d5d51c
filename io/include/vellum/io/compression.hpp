#pragma once
// gzip for Vellum's files: the one compressor and the one exact-size decompressor that every
// compressed reader and writer uses (NRRD volumes, label maps, backward maps, MetaImage).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

namespace vellum::io {

/// Input bytes per deflate block written by gzipCompress (each block is one parallel task).
inline constexpr size_t kGzipBlockBytes = size_t{1} << 20;

/// A compressed stream. The buffer is not zero-filled first (its pages are touched by the
/// compressing threads); `size` bytes are valid.
struct GzipBytes {
  std::unique_ptr<uint8_t[]> data;
  size_t size = 0;
};

/// `n` bytes as ONE gzip member (one stream, as every reader expects: some read only the first
/// member of several, and many are slow on them): blocks of kGzipBlockBytes input bytes are
/// compressed in parallel at a fast level (ISA-L level 3), each but the last ending byte-aligned
/// (full flush), and joined into one deflate stream under one header, CRC-32 and size (the
/// pigz scheme). Files from before (several concatenated members) still read: see below.
GzipBytes gzipCompress(const void* data, size_t n);

/// Refuses, before anything is allocated, a compressed stream of `n` bytes that claims to hold
/// `expected` bytes when deflate cannot expand that much (1032:1): FileError "truncated: ...".
void checkInflatedSize(const std::filesystem::path& path, size_t n, uint64_t expected);

/// Decompresses a gzip stream (one or more members) or a zlib stream into `dst`, which must
/// receive exactly `expected` bytes. Bytes after the last gzip member that do not start another
/// member are ignored. FileError naming `path`: "truncated" (also when the members end early),
/// "corrupt compressed data", "holds more than the expected ... bytes".
void inflateExactInto(const std::filesystem::path& path, const uint8_t* src, size_t n, uint8_t* dst,
                      uint64_t expected);

}  // namespace vellum::io
