// Pieces `vellum render` and `vellum illustrate` share (figures.hpp).
#include "vellum/app/figures.hpp"

#include <cmath>
#include <sstream>

#include "vellum/core/error.hpp"

namespace vellum::app {

LabelVolume loadLabelsLike(const std::filesystem::path& path, const io::LoadOptions& volumeLoad) {
  io::LoadOptions o;
  o.region = volumeLoad.region;
  o.allowOutsideData = volumeLoad.allowOutsideData;
  return io::loadLabels(path, o);
}

void requireSameGrid(const LabelVolume& labels, const Geometry& volume, const std::filesystem::path& path,
                     double tolerance) {
  if (!labels.geometry().approxEqual(volume, tolerance))
    throw FileError(path, "label map grid " + labels.geometry().dims.str() + " differs from the volume's");
}

bool anyAnnotation(const render::AnnotationOptions& o) { return o.scaleBar || o.orientation || o.labels; }

void checkDisplayNames(const render::AnnotationOptions& options, const LabelVolume& labels) {
  std::string known;
  for (const Label& l : labels.table()) known += (known.empty() ? "" : ", ") + l.name;
  for (const auto& entry : options.displayNames) {
    const std::string& key = entry.first;
    // The key as annotate() matches it (render::displayName): the name without case, or the id.
    render::AnnotationOptions one;
    one.displayNames = {{key, "\x01"}};
    bool found = false;
    for (const Label& l : labels.table()) found = found || render::displayName(one, l.id, l.name) == "\x01";
    if (!found) throw Error("--label-name " + key + ": no structure of that name or id (structures: " + known + ")");
  }
}

namespace {

/// A finite number filling the whole text, or nothing.
bool parseDegrees(const std::string& text, double& out) {
  if (text.empty()) return false;
  try {
    size_t used = 0;
    out = std::stod(text, &used);
    return used == text.size() && std::isfinite(out);
  } catch (const std::exception&) {
    return false;
  }
}

/// "30" for 30, "12.5" for 12.5: the shortest text that reads back (file names).
std::string degreesText(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

FigureView parseView(const std::string& text, double elevationDeg) {
  // Elevation 89, not 90: straight down the superior axis "up" on screen is undefined.
  struct Named { const char* name; double az, el; };
  static constexpr Named kNamed[] = {{"anterior", 0, 0},   {"posterior", 180, 0}, {"left", 90, 0},
                                     {"right", -90, 0},    {"lateral", 90, 0},    {"superior", 0, 89},
                                     {"inferior", 0, -89}};
  for (const Named& n : kNamed)
    if (text == n.name) return {n.name, n.az, n.el};
  const auto colon = text.find(':');
  double az = 0, el = elevationDeg;
  const bool ok = colon == std::string::npos
                      ? parseDegrees(text, az)
                      : parseDegrees(text.substr(0, colon), az) && parseDegrees(text.substr(colon + 1), el);
  if (!ok)
    throw Error("--view '" + text +
                "': expected anterior, posterior, left, right, lateral, superior, inferior, AZ or AZ:EL (degrees)");
  return {colon == std::string::npos ? "az" + degreesText(az) : "az" + degreesText(az) + "el" + degreesText(el), az,
          el};
}

std::vector<std::string> splitList(const std::string& text, const char* what) {
  std::vector<std::string> items;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (item.empty()) throw Error(std::string(what) + " '" + text + "': an empty item");
    items.push_back(item);
  }
  if (items.empty() || text.back() == ',') throw Error(std::string(what) + " '" + text + "': an empty item");
  return items;
}

std::filesystem::path figurePath(const std::filesystem::path& out, const std::vector<std::string>& parts) {
  if (parts.empty()) return out;
  std::string stem = out.stem().string();
  for (const auto& p : parts) stem += "-" + p;
  return out.parent_path() / (stem + out.extension().string());
}

}  // namespace vellum::app
