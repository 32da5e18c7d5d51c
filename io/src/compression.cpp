// gzip compression (ISA-L, one stream of blocks compressed in parallel) and exact-size decompression (libdeflate fast
// path; zlib streaming path to name the problem when the fast path fails).
#include "vellum/io/compression.hpp"

#include <isa-l/igzip_lib.h>
#include <libdeflate.h>
#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <string>

#include "io_detail.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::io {
namespace {

// ISA-L's level 3 with its default buffer: on 32 MiB of noisy CT it is 2x faster than
// libdeflate's level 1 (75 vs 160 ms of CPU) for the same size (0.560 vs 0.557 of the input);
// ISA-L's levels 0-2 are slower here and compress less (docs/benchmarks-deformation.md).
constexpr int kIsalLevel = 3;
constexpr size_t kIsalLevelBuffer = ISAL_DEF_LVL3_DEFAULT;

// Stateless deflate expands by at most a stored block's header per 64 KiB; plus gzip's
// header and trailer and slack.
size_t memberBound(size_t len) { return len + 5 * (len / 65535 + 2) + 64; }

// One block of the deflate stream into [out, out + capacity): its size. A block that is not the
// last ends byte-aligned (FULL_FLUSH: an empty stored block, no back-references into it), so the
// blocks compressed apart concatenate into one valid deflate stream.
size_t compressBlock(const uint8_t* src, size_t len, bool last, uint8_t* out, size_t capacity,
                     std::vector<uint8_t>& levelBuffer) {
  isal_zstream stream;
  isal_deflate_stateless_init(&stream);
  stream.level = kIsalLevel;
  stream.level_buf = levelBuffer.data();
  stream.level_buf_size = static_cast<uint32_t>(levelBuffer.size());
  stream.gzip_flag = IGZIP_DEFLATE;
  stream.end_of_stream = last ? 1 : 0;
  stream.flush = last ? NO_FLUSH : FULL_FLUSH;
  stream.next_in = const_cast<uint8_t*>(src);  // ISA-L's API is not const-correct; it only reads
  stream.avail_in = static_cast<uint32_t>(len);
  stream.next_out = out;
  stream.avail_out = static_cast<uint32_t>(capacity);
  const int status = isal_deflate_stateless(&stream);
  if (status != COMP_OK) throw Error("ISA-L: gzip compression failed (status " + std::to_string(status) + ")");
  return stream.total_out;
}
struct DecompressorFree {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

bool startsGzipMember(const uint8_t* p, size_t n) { return n >= 2 && p[0] == 0x1f && p[1] == 0x8b; }

// libdeflate over the whole stream (member after member). False on any problem: the zlib path
// then decodes again and says precisely what is wrong.
bool inflateFast(const uint8_t* src, size_t n, uint8_t* dst, uint64_t expected) {
  std::unique_ptr<libdeflate_decompressor, DecompressorFree> d(libdeflate_alloc_decompressor());
  if (!d) return false;
  const size_t outSize = static_cast<size_t>(expected);
  if (!startsGzipMember(src, n)) {
    size_t got = 0;
    return libdeflate_zlib_decompress(d.get(), src, n, dst, outSize, &got) == LIBDEFLATE_SUCCESS &&
           got == outSize;
  }
  size_t pos = 0, produced = 0;
  do {
    size_t used = 0, got = 0;
    if (libdeflate_gzip_decompress_ex(d.get(), src + pos, n - pos, dst + produced, outSize - produced, &used,
                                      &got) != LIBDEFLATE_SUCCESS)
      return false;
    pos += used;
    produced += got;
  } while (startsGzipMember(src + pos, n - pos));
  return produced == outSize;
}

// zlib streaming inflate, member by member: slower, but tells truncation from corruption and
// notices data beyond `expected` (a decompression bomb) without writing past `dst`.
void inflateChecked(const std::filesystem::path& path, const uint8_t* src, size_t n, uint8_t* dst,
                    uint64_t expected) {
  z_stream zs{};
  if (inflateInit2(&zs, 15 + 32) != Z_OK) throw FileError(path, "zlib initialisation failed");
  constexpr size_t kChunk = size_t{1} << 30;  // zlib counts in 32-bit units
  size_t consumed = 0;
  uint64_t produced = 0;
  std::string problem;
  for (;;) {
    if (zs.avail_in == 0 && consumed < n) {
      const size_t c = std::min(kChunk, n - consumed);
      zs.next_in = const_cast<Bytef*>(src + consumed);
      zs.avail_in = static_cast<uInt>(c);
      consumed += c;
    }
    uint8_t scratch = 0;
    const bool full = produced == expected;
    zs.next_out = full ? &scratch : dst + produced;
    zs.avail_out = full ? 1u : static_cast<uInt>(std::min<uint64_t>(kChunk, expected - produced));
    const uInt outBefore = zs.avail_out, inBefore = zs.avail_in;
    const int ret = inflate(&zs, Z_NO_FLUSH);
    const uInt got = outBefore - zs.avail_out;
    if (full && got > 0) {
      problem = "compressed data holds more than the expected " + std::to_string(expected) + " bytes";
      break;
    }
    produced += full ? 0 : got;
    if (ret == Z_STREAM_END) {
      const size_t next = consumed - zs.avail_in;  // first byte after this member
      if (startsGzipMember(src + next, n - next) && inflateReset(&zs) == Z_OK) continue;
      break;
    }
    if (ret == Z_DATA_ERROR || ret == Z_NEED_DICT || ret == Z_MEM_ERROR || ret == Z_STREAM_ERROR) {
      problem = std::string("corrupt compressed data (") + (zs.msg ? zs.msg : "zlib error") + ")";
      break;
    }
    if (got == 0 && inBefore == zs.avail_in) {  // no progress: input exhausted
      problem = "compressed data is truncated (" + std::to_string(produced) + " of " +
                std::to_string(expected) + " bytes decoded)";
      break;
    }
  }
  inflateEnd(&zs);
  if (problem.empty() && produced != expected)  // the last member ended early: data are missing
    problem = "compressed data is truncated (decodes to " + std::to_string(produced) + " bytes, expected " +
              std::to_string(expected) + ")";
  if (!problem.empty()) throw FileError(path, problem);
}

}  // namespace

GzipBytes gzipCompress(const void* data, size_t n) {
  const auto* src = static_cast<const uint8_t*>(data);
  const size_t blocks = std::max<size_t>(1, (n + kGzipBlockBytes - 1) / kGzipBlockBytes);
  // gzip header (10 bytes: deflate, no name, no time, OS unix), the blocks, then CRC-32 and size.
  constexpr uint8_t kHeader[10] = {0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3};
  // Each block compresses into its own slot of the worst-case size, then slots are packed.
  std::vector<size_t> slot(blocks + 1, sizeof kHeader), packed(blocks, 0);
  std::vector<uLong> crc(blocks, 0);
  for (size_t m = 0; m < blocks; ++m)
    slot[m + 1] = slot[m] + memberBound(std::min(kGzipBlockBytes, n - std::min(n, m * kGzipBlockBytes)));
  const size_t capacity = slot[blocks] + 8;
  checkMemoryBudget(capacity, "compressed data");
  GzipBytes out{std::unique_ptr<uint8_t[]>(new uint8_t[capacity]), 0};
  adviseHugePages(out.data.get(), capacity);
  parallelFor(static_cast<int64_t>(blocks), [&](int64_t b, int64_t e) {
    std::vector<uint8_t> levelBuffer(kIsalLevelBuffer);
    for (auto m = static_cast<size_t>(b); m < static_cast<size_t>(e); ++m) {
      const size_t offset = m * kGzipBlockBytes, len = std::min(kGzipBlockBytes, n - std::min(n, offset));
      packed[m] = compressBlock(src + offset, len, m + 1 == blocks, out.data.get() + slot[m], slot[m + 1] - slot[m],
                                levelBuffer);
      crc[m] = crc32(0L, len ? src + offset : nullptr, static_cast<uInt>(len));
    }
  });
  std::memcpy(out.data.get(), kHeader, sizeof kHeader);
  out.size = sizeof kHeader;
  uLong total = crc32(0L, nullptr, 0);
  for (size_t m = 0; m < blocks; ++m) {
    std::memmove(out.data.get() + out.size, out.data.get() + slot[m], packed[m]);
    out.size += packed[m];
    const size_t len = std::min(kGzipBlockBytes, n - std::min(n, m * kGzipBlockBytes));
    total = crc32_combine(total, crc[m], static_cast<z_off_t>(len));
  }
  const uint32_t trailer[2] = {static_cast<uint32_t>(total), static_cast<uint32_t>(n & 0xffffffffu)};
  for (int w = 0; w < 2; ++w)
    for (int byte = 0; byte < 4; ++byte) out.data[out.size++] = static_cast<uint8_t>(trailer[w] >> (8 * byte));  // little endian
  return out;
}

void checkInflatedSize(const std::filesystem::path& path, size_t n, uint64_t expected) {
  // Deflate expands at most 1032:1: a header that claims more cannot be honest, and we refuse
  // it before allocating (a tiny file must not cost gigabytes of zeroed memory).
  if (expected / 1032 > n + 64)
    throw FileError(path, "truncated: " + std::to_string(n) + " compressed bytes cannot hold the " +
                              std::to_string(expected) + " bytes the header promises");
}

void inflateExactInto(const std::filesystem::path& path, const uint8_t* src, size_t n, uint8_t* dst,
                      uint64_t expected) {
  checkInflatedSize(path, n, expected);
  if (inflateFast(src, n, dst, expected)) return;
  inflateChecked(path, src, n, dst, expected);
}

namespace detail {

std::vector<uint8_t> inflateExact(const fs::path& path, const uint8_t* src, size_t n, uint64_t expected) {
  checkInflatedSize(path, n, expected);
  try {
    checkMemoryBudget(expected, "decompressed data");
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
  std::vector<uint8_t> out(static_cast<size_t>(expected));
  inflateExactInto(path, src, n, out.data(), expected);
  return out;
}

}  // namespace detail
}  // namespace vellum::io
