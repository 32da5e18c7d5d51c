#pragma once
// Run-time dispatch of hot loops: GCC compiles a function marked VELLUM_SIMD_CLONES twice, for
// x86-64-v3 (AVX2 + FMA) and for baseline x86-64, and picks one when the program loads. Other
// compilers and CPUs get the plain function.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define VELLUM_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#define VELLUM_HAVE_AVX2_PATH 1
#else
#define VELLUM_SIMD_CLONES
#endif
// Lambdas inside cloned functions must be inlined: called out of line (as at -O0) they are
// compiled for the baseline target, and passing 32-byte vectors between an AVX2 caller and a
// baseline callee mismatches the ABI (a stack overflow under AddressSanitizer).
#define VELLUM_INLINE_LAMBDA __attribute__((always_inline))
