// Functions that count bits in their hot loop: baseline x86-64 has no popcount instruction, so
// GCC builds a second version for CPUs that have one and picks it at load time.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define VADOP_POPCNT_CLONES __attribute__((target_clones("popcnt", "default")))
#else
#define VADOP_POPCNT_CLONES
#endif
