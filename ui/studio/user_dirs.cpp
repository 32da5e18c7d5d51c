#include "user_dirs.hpp"

#include <cstdlib>

namespace vellum::studio {
namespace fs = std::filesystem;

fs::path userFolder(const char* xdgVariable, const fs::path& underHome) {
  if (const char* xdg = std::getenv(xdgVariable); xdg && fs::path(xdg).is_absolute()) return fs::path(xdg) / "vellum";
  if (const char* home = std::getenv("HOME"); home && *home) return fs::path(home) / underHome / "vellum";
  return {};
}

}  // namespace vellum::studio
