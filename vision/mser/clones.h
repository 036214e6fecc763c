// VIGIL_AVX2_CLONES: a function compiled twice, for AVX2 and for the baseline, the one the
// processor has chosen at load time by an ifunc resolver (the MSER segmenter's vectorised loops).
// Not under ThreadSanitizer: the resolver runs during relocation, before its runtime is up, and
// its instrumentation crashes every program that links it (found by tools/test.sh --sanitize).
#pragma once

#if defined(__SANITIZE_THREAD__)
#define VIGIL_AVX2_CLONES
#else
#define VIGIL_AVX2_CLONES __attribute__((target_clones("avx2", "default")))
#endif
