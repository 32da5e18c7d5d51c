// Placeholder translation unit so that the target is a real library while its sources land.
namespace vellum::illustration {
int moduleVersion() { return 1; }
}  // namespace vellum::illustration
