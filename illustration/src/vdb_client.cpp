// The shape pipeline's OpenVDB calls, forwarded to the module (illustration/vdb) opened on
// first use.
#include <string>

#include "vdb_functions.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/plugin_module.hpp"

#ifndef VELLUM_VDB_MODULE_PATH
#error "VELLUM_VDB_MODULE_PATH (the OpenVDB module's file) must be defined by the build"
#endif

namespace vellum::illustration::detail {

namespace {
const VdbFunctions& openFunctions() {
  static const PluginModule module("the OpenVDB module", "VELLUM_VDB_MODULE", VELLUM_VDB_MODULE_PATH);
  using Entry = const VdbFunctions* (*)();
  const VdbFunctions* f = reinterpret_cast<Entry>(module.symbol("vellum_vdb_functions"))();
  if (!f || f->version != kVdbFunctionsVersion)
    throw Error("the OpenVDB module does not match this build (version " + std::to_string(f ? f->version : 0) +
                ", expected " + std::to_string(kVdbFunctionsVersion) + "): rebuild it");
  return *f;
}
}  // namespace

const VdbFunctions& vdbFunctions() {
  static const VdbFunctions& f = openFunctions();  // once; a failure is retried and reported again
  return f;
}

void LevelSetDeleter::operator()(LevelSet* p) const {
  if (p) vdbFunctions().release(p);
}

LevelSetPtr denoiseLevelSet(const MaskBox& mask, int iterations, double margin) {
  return LevelSetPtr(vdbFunctions().denoise(mask, iterations, margin));
}

VolumeF32 levelSetToDense(const LevelSet& ls, const Geometry& g) {
  const VdbFunctions& f = vdbFunctions();
  VolumeF32 out(g, f.levelSetHalfWidth, f.levelSetHalfWidth);
  f.toDense(ls, {g.dims.x, g.dims.y, g.dims.z}, out.data());
  return out;
}

TriMesh extractIndexMesh(const LevelSet& ls, double adaptivity) { return vdbFunctions().indexMesh(ls, adaptivity); }

}  // namespace vellum::illustration::detail
