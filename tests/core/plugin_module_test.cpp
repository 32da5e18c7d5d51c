// PluginModule: a module that cannot be opened, or lacks an entry point, is a one-line error
// naming the module and the file; the environment variable overrides the built-in file.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "vellum/core/error.hpp"
#include "vellum/core/plugin_module.hpp"

using namespace vellum;

namespace {
std::string errorOf(const PluginModule& m, const char* symbol) {
  try {
    m.symbol(symbol);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(PluginModule, AMissingFileIsNamedOnFirstUse) {
  const PluginModule m("the test module", nullptr, "/nonexistent/vellum-test-module.so");
  const std::string error = errorOf(m, "entry");
  EXPECT_EQ(error.rfind("cannot load the test module /nonexistent/vellum-test-module.so (", 0), 0u) << error;
  EXPECT_EQ(error.find('\n'), std::string::npos);
}

TEST(PluginModule, TheEnvironmentOverridesTheBuiltInFile) {
  ::setenv("VELLUM_TEST_MODULE", "/nonexistent/override.so", 1);
  const PluginModule m("the test module", "VELLUM_TEST_MODULE", "libc.so.6");
  ::unsetenv("VELLUM_TEST_MODULE");
  EXPECT_NE(errorOf(m, "malloc").find("/nonexistent/override.so"), std::string::npos);
}

TEST(PluginModule, EntryPointsAreFoundAndMissingOnesNamed) {
  const PluginModule m("the C library", nullptr, "libc.so.6");  // always loadable
  EXPECT_NE(m.symbol("strlen"), nullptr);
  EXPECT_EQ(errorOf(m, "vellum_no_such_entry"), "the C library libc.so.6 lacks the entry point vellum_no_such_entry");
}
