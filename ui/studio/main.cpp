// `vellum-studio [FILE|SCENE.json] [--labels L.nrrd] [--script S.json] [--size WxH] [--autosave S] [--log-frames]`
#include <csignal>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>
#ifdef __GLIBC__
#include <malloc.h>
#endif

#include "app.hpp"
#include "vellum/core/error.hpp"

namespace {

extern "C" void onSignal(int) { vellum::studio::StudioApp::interrupt(); }

void usage() {
  std::cout << "usage: vellum-studio [FILE|SCENE.json] [--labels LABELS] [--script S.json] [--size WxH] "
               "[--autosave SECONDS] [--log-frames]\n  see docs/studio.md\n";
}

}  // namespace

int main(int argc, char** argv) {
#ifdef __GLIBC__
  // A fixed mmap threshold (issue #22: memory <= 4x the volume). glibc raises it to the size of
  // each large block freed (up to 32 MB): after a label edit's box mask is freed, later blocks
  // of that size come from the heap arenas, where they fragment and stay resident (+13 MiB
  // after Remove islands at 512x512x350). Blocks over 1 MB are mapped and handed back on free.
  mallopt(M_MMAP_THRESHOLD, 1 << 20);
#endif
  vellum::studio::StudioOptions o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "vellum-studio: " << a << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      usage();
      return 0;
    } else if (a == "--script") {
      o.script = value();
    } else if (a == "--labels") {
      o.labels = value();
    } else if (a == "--size") {
      const std::string s = value();
      if (std::sscanf(s.c_str(), "%dx%d", &o.width, &o.height) != 2 || o.width < 320 || o.height < 240 ||
          o.width > 8192 || o.height > 8192) {
        std::cerr << "vellum-studio: --size must be WxH, at least 320x240 (got '" << s << "')\n";
        return 2;
      }
    } else if (a == "--autosave") {
      try {
        o.autosaveSeconds = std::stod(value());
      } catch (const std::exception&) {
        std::cerr << "vellum-studio: --autosave needs seconds (0 disables)\n";
        return 2;
      }
    } else if (a == "--log-frames") {
      o.logFrames = true;
    } else if (!a.empty() && a[0] == '-') {
      std::cerr << "vellum-studio: unknown option '" << a << "'\n";
      usage();
      return 2;
    } else if (o.input.empty()) {
      o.input = a;
    } else {
      std::cerr << "vellum-studio: more than one input ('" << o.input << "', '" << a << "')\n";
      return 2;
    }
  }
  std::signal(SIGINT, onSignal);  // Ctrl-C / kill: leave the loop, destroy GL cleanly
  std::signal(SIGTERM, onSignal);
  try {
    vellum::studio::StudioApp app(o);
    return app.run();
  } catch (const std::exception& e) {
    std::cerr << "vellum-studio: error: " << e.what() << "\n";
    return 2;
  }
}
