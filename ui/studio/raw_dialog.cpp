#include "raw_dialog.hpp"

#include <imgui.h>

#include <fstream>
#include <sstream>

#include "app.hpp"
#include "user_dirs.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/atomic_file.hpp"
#include "vellum/io/output_policy.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

namespace {
const char* nrrdType(VoxelType t) {
  switch (t) {
    case VoxelType::Int16: return "short";
    case VoxelType::UInt8: return "uchar";
    case VoxelType::UInt16: return "ushort";
    case VoxelType::Float32: return "float";
  }
  return "short";
}
}  // namespace

fs::path writeRawHeader(const fs::path& raw, const io::RawLayout& l, const fs::path& folder) {
  std::error_code ec;
  if (!fs::is_regular_file(raw, ec)) throw FileError(raw, "not a file");
  if (l.dims.x < 1 || l.dims.y < 1 || l.dims.z < 1) throw FileError(raw, "dims must be at least 1 x 1 x 1");
  if (!(l.spacing.x > 0 && l.spacing.y > 0 && l.spacing.z > 0)) throw FileError(raw, "spacing must be > 0 mm");
  if (folder.empty()) throw FileError(raw, "no folder for its header: set XDG_STATE_HOME or HOME");
  const uint64_t size = fs::file_size(raw), need = l.headerBytes + uint64_t(l.dims.voxelCount()) * voxelTypeSize(l.type);
  if (size != need)
    throw FileError(raw, std::to_string(size) + " bytes, but " + l.dims.str() + " " + voxelTypeName(l.type) + " after " +
                             std::to_string(l.headerBytes) + " header bytes needs " + std::to_string(need));
  const fs::path header = fs::absolute(folder / (raw.stem().string() + ".nhdr"));
  if (fs::equivalent(header.parent_path(), fs::absolute(raw).parent_path(), ec))
    throw FileError(header, "would be written beside the data");
  io::OutputPlan plan;
  plan.input(raw, "the RAW file").output(header, "the RAW header").check();
  fs::create_directories(folder);
  std::ostringstream h;
  h.precision(17);
  h << "NRRD0004\n# vellum-studio, Open RAW: the layout of a bare RAW file as entered\n"
    << "type: " << nrrdType(l.type) << "\ndimension: 3\nspace: left-posterior-superior\n"
    << "sizes: " << l.dims.x << ' ' << l.dims.y << ' ' << l.dims.z << "\n"
    << "space directions: (" << l.spacing.x << ",0,0) (0," << l.spacing.y << ",0) (0,0," << l.spacing.z << ")\n"
    << "space origin: (" << l.origin.x << ',' << l.origin.y << ',' << l.origin.z << ")\n"
    << "endian: " << (l.endian == io::Endian::Big ? "big" : "little") << "\nencoding: raw\n"
    << "byte skip: " << l.headerBytes << "\ndata file: " << fs::absolute(raw).string() << "\n";
  io::writeAtomically(header, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out << h.str();
    if (!out.flush()) throw FileError(header, "cannot write");
  });
  return header;
}

fs::path rawHeaderFolder() {
  const fs::path state = userFolder("XDG_STATE_HOME", ".local/state");
  return state.empty() ? fs::path() : state / "raw-headers";
}

bool isOpenRawHeader(const fs::path& path) {
  const fs::path folder = rawHeaderFolder();
  std::error_code ec;
  return !folder.empty() && path.extension() == ".nhdr" &&
         fs::equivalent(fs::absolute(path).parent_path(), folder, ec);
}

io::RawLayout RawDialogState::layout() const {
  io::RawLayout l;
  l.dims = {dims[0], dims[1], dims[2]};
  l.type = static_cast<VoxelType>(type);
  l.endian = bigEndian ? io::Endian::Big : io::Endian::Little;
  l.spacing = {spacing[0], spacing[1], spacing[2]};
  l.headerBytes = uint64_t(std::max(0, headerBytes));
  return l;
}

RawDialogState& rawDialog() {
  static RawDialogState state;
  return state;
}

void openRawAs(StudioApp& app, const RawDialogState& answers) {
  guarded(app, [&] { app.requestOpen(writeRawHeader(answers.data, answers.layout(), rawHeaderFolder())); });
}

void rawOpenButton(StudioApp& app) {
  if (ImGui::Button("Open RAW..."))
    app.fileBrowser().open(FileBrowser::Mode::Open, "Open a bare RAW file", [](const fs::path& p) {
      rawDialog().data = p;
      rawDialog().open = true;
    });
}

void drawRawDialog(StudioApp& app) {
  RawDialogState& d = rawDialog();
  if (!d.open) return;
  ImGui::SetNextWindowSize({460, 0}, ImGuiCond_Appearing);
  if (!ImGui::Begin("Open RAW", &d.open, ImGuiWindowFlags_NoCollapse)) {
    ImGui::End();
    return;
  }
  ImGui::TextWrapped("%s", d.data.string().c_str());
  ImGui::InputInt3("Dims (voxels)", d.dims);
  const char* types[] = {"int16", "uint8", "uint16", "float32"};
  ImGui::Combo("Voxel type", &d.type, types, 4);
  ImGui::InputFloat3("Spacing (mm)", d.spacing, "%.4f");
  ImGui::Checkbox("Big endian", &d.bigEndian);
  ImGui::InputInt("Header bytes", &d.headerBytes);
  std::error_code ec;
  const auto size = fs::file_size(d.data, ec);
  if (!ec) {
    const io::RawLayout l = d.layout();
    const uint64_t need = l.headerBytes + uint64_t(std::max<int64_t>(0, l.dims.voxelCount())) * voxelTypeSize(l.type);
    ImGui::Text("file: %llu bytes; this layout: %llu", (unsigned long long)size, (unsigned long long)need);
  }
  ImGui::TextDisabled("the header goes to %s", rawHeaderFolder().string().c_str());
  if (ImGui::Button("Open")) {
    openRawAs(app, d);
    d.open = false;
  }
  ImGui::SameLine();
  if (ImGui::Button("Cancel##raw")) d.open = false;
  ImGui::End();
}

}  // namespace vellum::studio
