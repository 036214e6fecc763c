// A libFuzzer program for one entry of fuzz/entries.h (VIGIL_FUZZ_TARGET names it); built only
// with clang and VIGIL_FUZZ=ON (tools/fuzz.sh).
#include <cstdio>
#include <cstdlib>

#include "fuzz/entries.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const vigil::fuzz::Target* target = [] {
    const auto* t = vigil::fuzz::find_target(VIGIL_FUZZ_TARGET);
    if (!t) {
      std::fprintf(stderr, "no fuzz target named %s\n", VIGIL_FUZZ_TARGET);
      std::abort();
    }
    return t;
  }();
  target->entry(data, size);
  return 0;
}
