/* The photon tracer (trace.c) compiled a third time, as trace_v3.c with AVX-512 (F, DQ, VL, BW,
 * CD: x86-64-v4) enabled as well (CMakeLists.txt): pgi__photons_trace calls this
 * pgi__photons_trace_v4 where the CPU has them (pgi__trace_v4_ok). Mostly the 16 lanes' loops
 * and copies in 512-bit registers, and twice the vector registers; contraction off, so the same
 * bits as the other two builds. */
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) /* = PGI__AVX2_TARGET */
#define PGI__TRACE_V3 1
#define PGI__TRACE_V4 1
#include "trace.c"
#else
typedef int pgi__trace_v4_unused; /* not x86-64 with GCC or clang: nothing here */
#endif
