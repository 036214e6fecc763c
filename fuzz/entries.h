// Fuzz entry points (docs/RELIABILITY.md): each takes arbitrary bytes and feeds them to one of
// Vigil's parsers or message checks the way a file or a DDS sample would arrive. They are
// compiled into libFuzzer programs (tools/fuzz.sh, clang) and into the ordinary test suite, which
// replays the seed corpus and every input a fuzzer once found (fuzz/regressions) through them.
//
// An entry returns normally whatever the bytes are; a crash, a hang, an uncaught exception or a
// sanitizer report is a finding. Errors are fine: they are what a bad file must give. An entry
// also checks what a user relies on: an error names its file (or its message's field).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace vigil::fuzz {

using Entry = void (*)(const uint8_t* data, size_t size);

struct Target {
  const char* name;   // fuzz_<name> is its program; fuzz/corpus/<name> its seeds
  Entry entry;
  const char* what;   // one line for tools/fuzz.sh --list
};

// Every target, in a fixed order.
const std::vector<Target>& targets();
// The target of that name, or nullptr.
const Target* find_target(const std::string& name);

}  // namespace vigil::fuzz
