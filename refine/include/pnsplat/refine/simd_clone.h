// Functions built twice on x86-64 with GCC, for the baseline and for a newer instruction set; the
// processor picks one when the program loads. For refine/ and engine/, not part of the API.
// - PNSPLAT_AVX2_CLONE: loops over eight lanes at once (the fuzzy filter's pair loops, the
//   selection's counts of splats).
// - PNSPLAT_V3_CLONE: the per-point refinement (x86-64-v3: AVX2, BMI1/2, three-operand VEX code;
//   1.03x on the faster variants of `pnsplat bench refine`, pinned A/B).
// Every version computes the same bits: IEEE division and square root, selects, and no fused
// multiply-adds (-ffp-contract=off in refine/CMakeLists.txt and engine/CMakeLists.txt, and no
// std::fma). Not under ThreadSanitizer: the loader runs the choosing function before the sanitizer's runtime
// is up, and the program crashes at start.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__SANITIZE_THREAD__)
#define PNSPLAT_AVX2_CLONE __attribute__((target_clones("avx2", "default")))
#define PNSPLAT_V3_CLONE __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define PNSPLAT_AVX2_CLONE
#define PNSPLAT_V3_CLONE
#endif
