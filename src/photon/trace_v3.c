/* The photon tracer (trace.c) compiled a second time, with AVX2, FMA, BMI1/2 and POPCNT
 * enabled for the whole file (CMakeLists.txt), its hot loops and the OpenMP regions around them
 * included: pgi__photons_trace calls this pgi__photons_trace_v3 where the CPU has them
 * (pgi__trace_v3_ok). The build flags keep contraction off, so that both give the same bits. */
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) /* = PGI__AVX2_TARGET */
#define PGI__TRACE_V3 1
#include "trace.c"
#else
typedef int pgi__trace_v3_unused; /* not x86-64 with GCC or clang: nothing here */
#endif
