#include "vellum/io/nrrd_writer.hpp"

#include <sstream>

#include "io_detail.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/atomic_file.hpp"
#include "vellum/io/compression.hpp"

namespace vellum::io {
namespace {

std::string vec(const Vec3& v) {
  std::string out = "(";  // appended piecewise: g++ 12 warns (-Wrestrict) on "(" + std::string
  out += detail::fmt(v.x) + ",";
  out += detail::fmt(v.y) + ",";
  out += detail::fmt(v.z) + ")";
  return out;
}

}  // namespace

void writeNrrd(const std::filesystem::path& path, const NrrdLayout& layout, const void* bytes,
               size_t byteCount, bool gzip, Progress* progress) {
  if (layout.leadingSizes.size() != layout.leadingKinds.size())
    throw FileError(path, "NRRD layout: leading sizes and kinds differ in count");
  const Geometry& g = layout.geometry;
  const bool detached = detail::lower(path.extension().string()) == ".nhdr";
  const std::string dataName = path.stem().string() + (gzip ? ".raw.gz" : ".raw");

  std::ostringstream h;
  h << "NRRD0004\n";
  for (const auto& c : layout.comments) h << "# " << c << "\n";
  h << "type: " << layout.type << "\n"
    << "dimension: " << layout.leadingSizes.size() + 3 << "\n"
    << "space: left-posterior-superior\nsizes:";
  for (int64_t s : layout.leadingSizes) h << " " << s;
  h << " " << g.dims.x << " " << g.dims.y << " " << g.dims.z << "\nspace directions:";
  for (size_t i = 0; i < layout.leadingSizes.size(); ++i) h << " none";
  for (int a = 0; a < 3; ++a) h << " " << vec(g.direction.column(a) * g.spacing[a]);
  h << "\nkinds:";
  for (const auto& k : layout.leadingKinds) h << " " << k;
  h << " domain domain domain\n"
    << "endian: " << (detail::hostEndian() == Endian::Little ? "little" : "big") << "\n"
    << "encoding: " << (gzip ? "gzip" : "raw") << "\n"
    << "space origin: " << vec(g.origin) << "\n";
  if (detached) h << "data file: " << dataName << "\n";
  h << layout.extraFields << "\n";
  const std::string header = h.str();

  GzipBytes packed;
  detail::ByteView body{static_cast<const uint8_t*>(bytes), byteCount};
  if (gzip) {
    if (progress) progress->begin("compressing " + path.filename().string(), 1);
    packed = gzipCompress(body.data, body.size);
    if (progress) progress->end();
    body = {packed.data.get(), packed.size};
  }
  const auto writeTo = [&](const std::filesystem::path& target, const std::string& prefix, detail::ByteView data) {
    writeAtomically(target, [&](const std::filesystem::path& tmp) { detail::writeBinaryFile(tmp, prefix, data, progress); });
  };
  if (detached) {
    writeTo(path.parent_path() / dataName, "", body);
    writeTo(path, header, {});
  } else {
    writeTo(path, header, body);
  }
}

void writeTextFile(const std::filesystem::path& path, const std::string& text) {
  writeAtomically(path, [&](const std::filesystem::path& tmp) { detail::writeBinaryFile(tmp, text, {}); });
}

}  // namespace vellum::io
