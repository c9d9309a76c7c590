// A child that does what the child check (tests/process.hpp) must catch:
// `leak` loses memory at exit (LeakSanitizer reports it in a sanitizer
// build), `ub` overflows a signed int (UBSan), `hang` ignores SIGTERM.
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <unistd.h>

int main(int argc, char** argv) {
  const char* what = argc > 1 ? argv[1] : "";
  if (std::strcmp(what, "leak") == 0) {
    // Kept only in a volatile local: nothing points at it at exit.
    char* volatile lost = static_cast<char*>(std::malloc(4096));
    lost[0] = 1;
    lost = nullptr;
    std::puts("leaked 4096 bytes");
    return 0;
  }
  if (std::strcmp(what, "ub") == 0) {
    volatile int big = 2147483647;
    const int over = big + argc;  // signed overflow: UBSan's "runtime error"
    std::printf("%d\n", over);
    return 0;
  }
  if (std::strcmp(what, "hang") == 0) {
    std::signal(SIGTERM, SIG_IGN);
    std::puts("ignoring SIGTERM");
    std::fflush(stdout);
    for (;;) ::pause();
  }
  return 2;
}
