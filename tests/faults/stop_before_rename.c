/* LD_PRELOAD shim for the fault tests: a process that is about to rename one of Vellum's
 * temporary outputs into place stops itself (SIGSTOP) first, so that the test can SIGKILL it
 * at exactly the worst moment — the output fully written beside the target, not yet moved. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>

int rename(const char* from, const char* to) {
  static int (*real_rename)(const char*, const char*);
  if (!real_rename) real_rename = (int (*)(const char*, const char*))dlsym(RTLD_NEXT, "rename");
  if (strstr(from, ".vellum-tmp-")) raise(SIGSTOP);
  return real_rename(from, to);
}
