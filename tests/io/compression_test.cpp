// io::gzipCompress writes one gzip member (blocks compressed in parallel, one stream); files
// from before hold several concatenated members. Every reader must see one stream: zlib's gzread
// (what teem/NrrdIO in 3D Slicer and ITK use), the gzip tool, and our own inflateExactInto,
// which must also keep naming truncation, corruption and excess.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "io_test_util.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/compression.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;
using namespace vellum::test;
namespace fs = std::filesystem;

namespace {

// CT-like int16 samples: smooth structure plus noise, so compression is neither trivial nor none.
std::vector<uint8_t> ctLikeBytes(size_t samples) {
  std::vector<int16_t> v(samples);
  uint32_t state = 12345;
  for (size_t i = 0; i < samples; ++i) {
    state = state * 1664525u + 1013904223u;
    v[i] = static_cast<int16_t>(-1000 + static_cast<int>((i / 700) % 1500) + static_cast<int>(state >> 27));
  }
  std::vector<uint8_t> bytes(samples * 2);
  std::memcpy(bytes.data(), v.data(), bytes.size());
  return bytes;
}

std::vector<uint8_t> compressed(const std::vector<uint8_t>& raw) {
  const io::GzipBytes gz = io::gzipCompress(raw.data(), raw.size());
  return {gz.data.get(), gz.data.get() + gz.size};
}

// What Vellum wrote before: one gzip member per MiB of input, concatenated.
std::vector<uint8_t> oldMembers(const std::vector<uint8_t>& raw) {
  std::vector<uint8_t> out;
  constexpr size_t kMember = size_t{1} << 20;
  for (size_t at = 0; at < raw.size(); at += kMember) {
    const auto part = compressed({raw.begin() + static_cast<std::ptrdiff_t>(at),
                                  raw.begin() + static_cast<std::ptrdiff_t>(std::min(raw.size(), at + kMember))});
    out.insert(out.end(), part.begin(), part.end());
  }
  return out;
}

// Member start offsets, found by decoding member after member with zlib.
std::vector<size_t> memberOffsets(const std::vector<uint8_t>& gz) {
  std::vector<size_t> starts;
  std::vector<uint8_t> sink(1 << 16);
  size_t pos = 0;
  while (pos + 1 < gz.size() && gz[pos] == 0x1f && gz[pos + 1] == 0x8b) {
    starts.push_back(pos);
    z_stream zs{};
    inflateInit2(&zs, 15 + 16);
    zs.next_in = const_cast<Bytef*>(gz.data() + pos);
    zs.avail_in = static_cast<uInt>(gz.size() - pos);
    int rc = Z_OK;
    while (rc == Z_OK) {
      zs.next_out = sink.data();
      zs.avail_out = static_cast<uInt>(sink.size());
      rc = inflate(&zs, Z_NO_FLUSH);
    }
    EXPECT_EQ(rc, Z_STREAM_END) << "member at " << pos;
    pos += zs.total_in;
    inflateEnd(&zs);
    if (rc != Z_STREAM_END) break;
  }
  EXPECT_EQ(pos, gz.size()) << "bytes after the last member";
  return starts;
}

std::string inflateError(const std::vector<uint8_t>& gz, uint64_t expected) {
  std::vector<uint8_t> out(expected);
  try {
    io::inflateExactInto("x.gz", gz.data(), gz.size(), out.data(), expected);
  } catch (const FileError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Gzip, BlocksCompressedApartMakeOneMemberThatDecodesToTheExactBytes) {
  const auto raw = ctLikeBytes(2'300'000);  // 4.6 MB: 5 blocks, the last one partial
  const auto gz = compressed(raw);
  EXPECT_LT(gz.size(), raw.size() * 3 / 4) << "level 1 should still compress CT-like data";
  EXPECT_EQ(memberOffsets(gz).size(), 1u) << "one gzip stream";
  std::vector<uint8_t> back(raw.size());
  io::inflateExactInto("x.gz", gz.data(), gz.size(), back.data(), back.size());
  EXPECT_EQ(back, raw);
  // zlib's one-shot inflate of a single member checks the CRC-32 and size of the whole stream.
  std::vector<uint8_t> z(raw.size());
  z_stream zs{};
  inflateInit2(&zs, 15 + 16);
  zs.next_in = const_cast<Bytef*>(gz.data());
  zs.avail_in = static_cast<uInt>(gz.size());
  zs.next_out = z.data();
  zs.avail_out = static_cast<uInt>(z.size());
  EXPECT_EQ(inflate(&zs, Z_FINISH), Z_STREAM_END);
  EXPECT_EQ(zs.total_in, gz.size());
  inflateEnd(&zs);
  EXPECT_EQ(z, raw);
}

TEST(Gzip, OldFilesOfSeveralMembersStillRead) {
  const auto raw = ctLikeBytes(1'300'000);  // 2.6 MB: 3 members
  const auto gz = oldMembers(raw);
  EXPECT_EQ(memberOffsets(gz).size(), 3u);
  std::vector<uint8_t> back(raw.size());
  io::inflateExactInto("x.gz", gz.data(), gz.size(), back.data(), back.size());
  EXPECT_EQ(back, raw);
}

TEST(Gzip, ZlibGzreadReadsTheStreamAndOldMembers) {
  const fs::path dir = tempDir("gzip-gzread");
  const auto raw = ctLikeBytes(1'500'000);
  for (const auto& gz : {compressed(raw), oldMembers(raw)}) {
    writeFile(dir / "a.gz", std::string(gz.begin(), gz.end()));
    gzFile f = gzopen((dir / "a.gz").c_str(), "rb");
    ASSERT_NE(f, nullptr);
    std::vector<uint8_t> back(raw.size() + 16);
    const int got = gzread(f, back.data(), static_cast<unsigned>(back.size()));
    gzclose(f);
    ASSERT_EQ(got, static_cast<int>(raw.size()));
    back.resize(raw.size());
    EXPECT_EQ(back, raw);
  }
}

TEST(Gzip, TheGzipToolDecodesTheStream) {
  if (std::system("gzip --version > /dev/null 2>&1") != 0) GTEST_SKIP() << "no gzip tool";
  const fs::path dir = tempDir("gzip-tool");
  const auto raw = ctLikeBytes(1'200'000);
  const auto gz = compressed(raw);
  writeFile(dir / "a.gz", std::string(gz.begin(), gz.end()));
  const std::string cmd = "gzip -dc '" + (dir / "a.gz").string() + "' > '" + (dir / "a.raw").string() + "'";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const std::string back = readFile(dir / "a.raw");
  EXPECT_TRUE(back == std::string(raw.begin(), raw.end())) << "gzip -dc gave " << back.size() << " bytes";
}

TEST(Gzip, EmptyInputIsOneEmptyMember) {
  const io::GzipBytes gz = io::gzipCompress(nullptr, 0);
  ASSERT_GT(gz.size, 0u);
  const std::vector<uint8_t> bytes(gz.data.get(), gz.data.get() + gz.size);
  EXPECT_EQ(memberOffsets(bytes).size(), 1u);
  EXPECT_EQ(inflateError(bytes, 0), "");
}

TEST(Gzip, IncompressibleBytesFitTheirBlocksAndRoundTrip) {
  // Random bytes do not compress: each block must still fit its worst-case slot (stored
  // blocks), and the stream must decode exactly.
  std::vector<uint8_t> raw(2 * io::kGzipBlockBytes + 12345);
  uint64_t state = 0x9E3779B97F4A7C15ull;
  for (auto& b : raw) {
    state ^= state << 13, state ^= state >> 7, state ^= state << 17;
    b = static_cast<uint8_t>(state >> 56);
  }
  const auto gz = compressed(raw);
  EXPECT_GE(gz.size(), raw.size());
  EXPECT_LT(gz.size(), raw.size() + raw.size() / 1000 + 256) << "stored blocks cost 5 bytes per 64 KiB";
  EXPECT_EQ(memberOffsets(gz).size(), 1u);
  std::vector<uint8_t> back(raw.size());
  io::inflateExactInto("x.gz", gz.data(), gz.size(), back.data(), back.size());
  EXPECT_EQ(back, raw);
}

TEST(Gzip, DamageInALaterMemberIsNamed) {
  const auto raw = ctLikeBytes(1'600'000);
  const auto gz = oldMembers(raw);
  const auto starts = memberOffsets(gz);
  ASSERT_GE(starts.size(), 3u);
  // Cut inside the second member, and exactly at the start of the third: both are truncation.
  const std::vector<uint8_t> cutInside(gz.begin(), gz.begin() + static_cast<std::ptrdiff_t>(starts[1] + 5000));
  EXPECT_NE(inflateError(cutInside, raw.size()).find("truncated"), std::string::npos) << inflateError(cutInside, raw.size());
  const std::vector<uint8_t> cutAtMember(gz.begin(), gz.begin() + static_cast<std::ptrdiff_t>(starts[2]));
  EXPECT_NE(inflateError(cutAtMember, raw.size()).find("truncated"), std::string::npos)
      << inflateError(cutAtMember, raw.size());
  // Flipped bytes in the middle of the second member's deflate data.
  auto corrupt = gz;
  for (size_t i = (starts[1] + starts[2]) / 2; i < (starts[1] + starts[2]) / 2 + 64; ++i) corrupt[i] ^= 0x5a;
  EXPECT_NE(inflateError(corrupt, raw.size()).find("corrupt"), std::string::npos) << inflateError(corrupt, raw.size());
  // A header that promises less than the members hold (a decompression bomb is refused).
  EXPECT_NE(inflateError(gz, raw.size() - 1000).find("more than the expected"), std::string::npos)
      << inflateError(gz, raw.size() - 1000);
  // Bytes after the last member that are not a member are ignored, as before.
  auto trailing = gz;
  trailing.insert(trailing.end(), {'x', 'y', 'z'});
  EXPECT_EQ(inflateError(trailing, raw.size()), "");
}

TEST(Gzip, LargeNrrdVolumesRoundTripAndReadWithGzread) {
  const fs::path dir = tempDir("gzip-nrrd");
  const VolumeI16 ct = makeCt({160, 128, 40});  // 1.6 MB of voxels: two members
  for (const char* name : {"a.nrrd", "b.nhdr"}) {
    io::saveVolume(ct, dir / name);
    const io::LoadedVolume lv = io::loadVolume(dir / name);
    ASSERT_TRUE(std::holds_alternative<VolumeI16>(lv.volume)) << name;
    EXPECT_EQ(std::get<VolumeI16>(lv.volume).voxels(), ct.voxels()) << name;
  }
  // The detached data file is plain gzip: what NrrdIO's gzread sees must be the voxels exactly.
  gzFile f = gzopen((dir / "b.raw.gz").c_str(), "rb");
  ASSERT_NE(f, nullptr);
  std::vector<int16_t> back(ct.size() + 8);
  const int got = gzread(f, back.data(), static_cast<unsigned>(back.size() * 2));
  gzclose(f);
  ASSERT_EQ(got, static_cast<int>(ct.size() * 2));
  back.resize(ct.size());
  EXPECT_EQ(back, ct.voxels());
}

TEST(Gzip, TruncatedMultiMemberNrrdIsRefusedAsTruncated) {
  const fs::path dir = tempDir("gzip-nrrd-cut");
  io::saveVolume(makeCt({160, 128, 40}), dir / "a.nrrd");
  const std::string s = readFile(dir / "a.nrrd");
  writeFile(dir / "cut.nrrd", s.substr(0, s.size() * 2 / 3));
  try {
    io::loadVolume(dir / "cut.nrrd");
    FAIL() << "loaded a truncated file";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cut.nrrd"), std::string::npos) << e.what();
  }
}
