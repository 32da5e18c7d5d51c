// VTK XML image data (.vti) through vtkXMLImageDataReader/Writer. VTK 9.1 writes and reads
// the Direction attribute (tested); the modality travels as a field-data string array
// "vellum_modality".
#include <vtkCallbackCommand.h>
#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkMatrix3x3.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkShortArray.h>
#include <vtkSmartPointer.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkStringArray.h>
#include <vtkUnsignedCharArray.h>
#include <vtkUnsignedShortArray.h>
#include <vtkXMLImageDataReader.h>
#include <vtkXMLImageDataWriter.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>

#include "io_detail.hpp"
#include "vellum/io/atomic_file.hpp"

namespace vellum::io::detail {

namespace {

/// Collects VTK error/warning text from one algorithm instead of printing it.
struct ErrorCatcher {
  std::string message;
  vtkNew<vtkCallbackCommand> cmd;
  explicit ErrorCatcher(vtkObject* obj) {
    cmd->SetClientData(this);
    cmd->SetCallback([](vtkObject*, unsigned long, void* client, void* call) {
      auto* self = static_cast<ErrorCatcher*>(client);
      if (self->message.empty() && call) self->message = trim(static_cast<const char*>(call));
    });
    obj->AddObserver(vtkCommand::ErrorEvent, cmd);
    obj->AddObserver(vtkCommand::WarningEvent, cmd);
  }
};

/// VTK messages are multi-line with source locations; keep the last line, which says what.
std::string shortVtkMessage(const std::string& m) {
  std::string s = m;
  while (!s.empty() && s.back() == '\n') s.pop_back();
  const size_t nl = s.find_last_of('\n');
  s = nl == std::string::npos ? s : s.substr(nl + 1);
  // Drop the "vtkXMLImageDataReader (0x55c5...): " prefix.
  if (const size_t p = s.find("): "); p != std::string::npos && s.find(" (0x") < p) s = s.substr(p + 3);
  return oneLine(s);
}

SampleType sampleTypeOfVtk(const fs::path& path, int vtkType) {
  switch (vtkType) {
    case VTK_CHAR:
    case VTK_SIGNED_CHAR: return SampleType::Int8;
    case VTK_UNSIGNED_CHAR: return SampleType::UInt8;
    case VTK_SHORT: return SampleType::Int16;
    case VTK_UNSIGNED_SHORT: return SampleType::UInt16;
    case VTK_INT: return SampleType::Int32;
    case VTK_UNSIGNED_INT: return SampleType::UInt32;
    case VTK_FLOAT: return SampleType::Float32;
    case VTK_DOUBLE: return SampleType::Float64;
    default: throw FileError(path, std::string("unsupported VTK scalar type ") + std::to_string(vtkType));
  }
}

// Structure checks before VTK sees the file (each guards a VTI fuzzer finding): arrays need a
// type, and VTK trusts the counts in each compressed array's header and allocates or divides
// by them, so every count is checked against the file's size.
void checkBeforeVtk(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::string head(size_t{1} << 20, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(in.gcount()));
  // VTK dereferences a missing type attribute of an array (a VTI fuzzer crash, also in release).
  const size_t xmlEnd = std::min(head.find("<AppendedData"), head.size());
  for (const char* tag : {"<Array", "<DataArray"})
    for (size_t at = head.find(tag); at < xmlEnd; at = head.find(tag, at + 1)) {
      const size_t end = head.find('>', at);
      const std::string element = head.substr(at, end == std::string::npos ? std::string::npos : end - at);
      const size_t type = element.find(" type=\"");
      if (type == std::string::npos)
        throw FileError(path, std::string(tag + 1) + " element without a type attribute");
      const size_t close = element.find('"', type + 7);
      const std::string name = element.substr(type + 7, close == std::string::npos ? 0 : close - type - 7);
      static const std::set<std::string> kTypes{"Int8",   "Int16",  "Int32",   "Int64",   "UInt8",  "UInt16",
                                                "UInt32", "UInt64", "Float32", "Float64", "String", "Bit"};
      if (!kTypes.count(name))  // VTK logs an unknown type and then dereferences null
        throw FileError(path, std::string(tag + 1) + " of unknown type '" + name + "'");
    }
  const size_t appended = head.find("<AppendedData");
  if (appended == std::string::npos) return;
  // The file's attributes live in its <VTKFile ...> start tag only (the binary data after
  // <AppendedData may contain any bytes, even a copy of that tag).
  const size_t fileTag = head.find("<VTKFile");
  const std::string vtkFile =
      fileTag < appended ? head.substr(fileTag, head.find('>', fileTag) - fileTag) : std::string();
  const bool compressed = vtkFile.find(" compressor=") != std::string::npos;
  const size_t underscore = head.find('_', appended);
  if (underscore == std::string::npos) return;
  const uint64_t headerBytes = vtkFile.find(" header_type=\"UInt64\"") != std::string::npos ? 8 : 4;
  const uint64_t base = underscore + 1, size = fileSize(path);
  for (size_t at = head.find(" offset=\""); at != std::string::npos && at < appended;
       at = head.find(" offset=\"", at + 1)) {
    const uint64_t offset = std::strtoull(head.c_str() + at + 9, nullptr, 10);
    if (offset > size || base + offset + headerBytes > size)
      throw FileError(path, "appended data offset " + std::to_string(offset) + " lies beyond the end of the file");
    // Header: block count, block size, last block's size, then each block's compressed size
    // (UInt32 or UInt64, little endian); VTK divides by the block size and allocates for the
    // counts, so all of them must be plausible.
    in.clear();
    in.seekg(static_cast<std::streamoff>(base + offset));
    const auto next = [&] {
      uint64_t v = 0;
      in.read(reinterpret_cast<char*>(&v), static_cast<std::streamsize>(headerBytes));
      if (in.gcount() != static_cast<std::streamsize>(headerBytes))
        throw FileError(path, "compressed array header runs past the end of the file");
      return v;
    };
    const uint64_t room = size - base - offset;
    if (!compressed) {  // raw appended data: a byte count, then the bytes
      const uint64_t bytes = next();
      if (bytes > room - headerBytes)
        throw FileError(path, "appended array of " + std::to_string(bytes) + " bytes in a file of " +
                                  std::to_string(size) + " bytes");
      continue;
    }
    const uint64_t blocks = next();
    if (blocks > room / headerBytes)
      throw FileError(path, "corrupt compressed array header: " + std::to_string(blocks) + " blocks in a file of " +
                                std::to_string(size) + " bytes");
    const uint64_t blockSize = next(), lastSize = next();
    if (blocks == 0) {  // VTK still allocates a block of blockSize: it must fit the file
      if (blockSize > 1032 * room + 64 || lastSize > 1032 * room + 64)
        throw FileError(path, "corrupt compressed array header (no blocks, block size " + std::to_string(blockSize) + ")");
      continue;
    }
    uint64_t compressed = 0;
    for (uint64_t b = 0; b < blocks; ++b) compressed += next();
    // Deflate expands at most 1032:1, so the blocks cannot hold more than that.
    const long double uncompressed = (long double)(blocks - 1) * blockSize + lastSize;
    if (blockSize == 0 || lastSize > blockSize || compressed > room ||
        uncompressed > 1032.0L * compressed + 64.0L * blocks)
      throw FileError(path, "corrupt compressed array header (block size " + std::to_string(blockSize) + ", last " +
                                std::to_string(lastSize) + ", " + std::to_string(compressed) + " compressed bytes)");
  }
}

}  // namespace

LoadedVolume loadVti(const fs::path& path, const LoadOptions& options) {
  fileSize(path);
  vtkNew<vtkXMLImageDataReader> reader;
  ErrorCatcher errors(reader);
  reader->SetFileName(path.c_str());
  if (!reader->CanReadFile(path.c_str())) throw FileError(path, "not a VTK XML image data file");
  checkBeforeVtk(path);
  // Information first: dims are checked against the budget before VTK allocates anything.
  try {
    reader->UpdateInformation();
  } catch (const std::exception& e) {
    throw FileError(path, std::string("VTK could not read the header (") + e.what() + ")");
  }
  if (!errors.message.empty()) throw FileError(path, shortVtkMessage(errors.message));
  int ext[6];
  reader->GetOutputInformation(0)->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), ext);
  const Dims dims{int64_t(ext[1]) - ext[0] + 1, int64_t(ext[3]) - ext[2] + 1, int64_t(ext[5]) - ext[4] + 1};
  checkAllocation(path, dims, 8);
  if (options.progress) options.progress->begin("reading " + path.filename().string(), 1);
  try {
    reader->Update();
  } catch (const std::exception& e) {  // e.g. std::bad_alloc for sizes VTK took from the file
    throw FileError(path, std::string("VTK could not read the data (") + e.what() + ")");
  }
  if (options.progress) options.progress->end();
  if (!errors.message.empty()) throw FileError(path, shortVtkMessage(errors.message));
  vtkImageData* img = reader->GetOutput();
  if (!img) throw FileError(path, "no image data");
  int got[6];
  img->GetExtent(got);
  for (int i = 0; i < 6; ++i)
    if (got[i] != ext[i]) throw FileError(path, "extent changed while reading (corrupt file?)");
  vtkDataArray* arr = img->GetPointData()->GetScalars();
  if (!arr && img->GetPointData()->GetNumberOfArrays() > 0) arr = img->GetPointData()->GetArray(0);
  if (!arr) throw FileError(path, "no point data array");
  if (arr->GetNumberOfComponents() != 1)
    throw FileError(path, "array '" + std::string(arr->GetName() ? arr->GetName() : "") + "' has " +
                              std::to_string(arr->GetNumberOfComponents()) + " components (1 expected)");
  if (arr->GetNumberOfTuples() != dims.voxelCount())
    throw FileError(path, "array has " + std::to_string(arr->GetNumberOfTuples()) + " values, expected " +
                              std::to_string(dims.voxelCount()) + " (truncated?)");

  Geometry g;
  g.dims = dims;
  double sp[3], org[3];
  img->GetSpacing(sp);
  img->GetOrigin(org);
  g.spacing = {sp[0], sp[1], sp[2]};
  const double* d = img->GetDirectionMatrix()->GetData();  // row-major, like Mat3
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) g.direction(r, c) = d[3 * r + c];
  // VTK's origin belongs to structured index (0,0,0); ours to the first voxel of the extent.
  g.origin = Vec3{org[0], org[1], org[2]} + g.direction * mul(Vec3{double(ext[0]), double(ext[2]), double(ext[4])}, g.spacing);
  const std::string warning = normalizeDirection(g);
  checkGeometry(path, g);

  const SampleType type = sampleTypeOfVtk(path, arr->GetDataType());
  const uint64_t bytes = static_cast<uint64_t>(dims.voxelCount()) * sampleSize(type);
  if (static_cast<uint64_t>(arr->GetDataTypeSize()) != sampleSize(type))
    throw FileError(path, "unexpected VTK scalar size");
  std::vector<uint8_t> data(static_cast<size_t>(bytes));
  std::memcpy(data.data(), arr->GetVoidPointer(0), data.size());

  std::string modality;
  if (auto* fd = img->GetFieldData()) {
    if (auto* s = vtkStringArray::SafeDownCast(fd->GetAbstractArray("vellum_modality"));
        s && s->GetNumberOfValues() > 0)
      modality = s->GetValue(0);
  }
  LoadedVolume out = makeLoaded(decodeVoxels(path, std::move(data), type, hostEndian(), g), "vti", modality);
  if (!warning.empty()) out.warnings.push_back(warning);
  return out;
}

void saveVti(const AnyVolume& v, const fs::path& path, const std::string& modality, Progress* progress) {
  const Geometry& g = geometryOf(v);
  vtkNew<vtkImageData> img;
  img->SetDimensions(int(g.dims.x), int(g.dims.y), int(g.dims.z));
  img->SetSpacing(g.spacing.x, g.spacing.y, g.spacing.z);
  img->SetOrigin(g.origin.x, g.origin.y, g.origin.z);
  double d[9];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) d[3 * r + c] = g.direction(r, c);
  img->SetDirectionMatrix(d);

  // Wrap the voxels without copying (save = 1: VTK never frees them).
  vtkSmartPointer<vtkDataArray> arr = std::visit(
      [](const auto& vol) -> vtkSmartPointer<vtkDataArray> {
        using T = typename std::decay_t<decltype(vol)>::value_type;
        vtkSmartPointer<vtkDataArray> a;
        if constexpr (std::is_same_v<T, int16_t>) a = vtkSmartPointer<vtkShortArray>::New();
        else if constexpr (std::is_same_v<T, uint8_t>) a = vtkSmartPointer<vtkUnsignedCharArray>::New();
        else if constexpr (std::is_same_v<T, uint16_t>) a = vtkSmartPointer<vtkUnsignedShortArray>::New();
        else a = vtkSmartPointer<vtkFloatArray>::New();
        a->SetNumberOfComponents(1);
        a->SetVoidArray(const_cast<T*>(vol.data()), static_cast<vtkIdType>(vol.size()), 1);
        return a;
      },
      v);
  arr->SetName("scalars");
  img->GetPointData()->SetScalars(arr);
  if (!modality.empty()) {
    vtkNew<vtkStringArray> s;
    s->SetName("vellum_modality");
    s->InsertNextValue(modality);
    img->GetFieldData()->AddArray(s);
  }

  if (progress) progress->begin("writing " + path.filename().string(), 1);
  writeAtomically(path, [&](const fs::path& tmp) {
    if (progress) progress->checkCancelled();
    vtkNew<vtkXMLImageDataWriter> writer;
    ErrorCatcher errors(writer);
    writer->SetInputData(img);
    writer->SetFileName(tmp.c_str());
    writer->SetDataModeToAppended();
    writer->EncodeAppendedDataOff();
    writer->SetCompressorTypeToZLib();
    writer->SetHeaderTypeToUInt64();
    if (writer->Write() != 1 || !errors.message.empty())
      throw FileError(path, "VTK writer failed: " + shortVtkMessage(errors.message));
  });
  if (progress) progress->end();
}

}  // namespace vellum::io::detail
