// Writing VTK XML image data (.vti) through vtkXMLImageDataWriter (appended raw, zlib, UInt64
// headers). VTK 9.1 writes the Direction attribute; the modality travels as a field-data string
// array "vellum_modality". Reading is our own parser (vti_reader.cpp).
#include <vtkCallbackCommand.h>
#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkShortArray.h>
#include <vtkSmartPointer.h>
#include <vtkStringArray.h>
#include <vtkUnsignedCharArray.h>
#include <vtkUnsignedShortArray.h>
#include <vtkXMLImageDataWriter.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>

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

}  // namespace

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
