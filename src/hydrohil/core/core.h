/* core.h: what the parts of the core share inside it (not part of the public interface, hh.h).
 *
 * The core is compiled as one translation unit (hh_core.c includes every part in dependency order), so
 * the small per-equation functions below are `static` and the compiler inlines them into the step: no
 * link-time optimisation needed, the same code in the Python extension, the FMU and the standalone plant.
 *
 * HH_CORE_LINKED: a translation unit compiled to be linked beside hh_core.c (a circuit's generated C in the
 * paper's rig's standalone plant and FMU, which step the generated model behind the core's loop) includes the
 * shared parts (control.c, watchdog.c, rng.c, link.c, delay.c) for their static helpers and leaves out hh.h's
 * functions, which hh_core.c defines: one definition of each in the program.
 */
#ifndef HH_CORE_H
#define HH_CORE_H

#include <math.h>
#include "hh.h"

#if defined(__GNUC__)
#define HH_INLINE static inline __attribute__((always_inline))
#else
#define HH_INLINE static inline
#endif

/* a loop over a tableau's stages unrolled, so that its coefficients are constants and its zeros drop out
 * (the generated circuit's step; gcc and clang), and what the compiler may take as true there (a tableau's
 * stages: at most HH_MAX_STAGES, where it is not a constant) */
#if defined(__GNUC__)
#define HH_UNROLL _Pragma("GCC unroll 4")   /* (HH_MAX_STAGES) */
#define HH_ASSUME(cond) do { if (!(cond)) __builtin_unreachable(); } while (0)
#else
#define HH_UNROLL
#define HH_ASSUME(cond) ((void)0)
#endif

#if defined(_MSC_VER) && !defined(__clang__)
#define HH_RESTRICT __restrict
#else
#define HH_RESTRICT restrict
#endif

#define HC_PI 3.14159265358979323846      /* (M_PI is not C99) */

HH_INLINE double hh_min(double a, double b) { return a < b ? a : b; }
HH_INLINE double hh_max(double a, double b) { return a > b ? a : b; }
HH_INLINE double hh_clamp(double x, double lo, double hi) { return hh_min(hh_max(x, lo), hi); }

/* A state's value after a step with its subnormal magnitudes (0 < |x| < DBL_MIN, 2.2e-308) made zero (SPEC §6's
 * step, issue #29). A state that decays to rest (a spool under a zero command: a damped second-order lag) falls
 * into the subnormal numbers and stays there, its arithmetic ~100 cycles an operation on Intel CPUs (microcode
 * assists): the settled example circuits stepped 5-6x slower there. 0·x: a subnormal becomes the zero of its
 * sign, a zero stays as it was (-0 too); a comparison and a product in plain C, the same bits on every platform
 * whatever its flush-to-zero and denormals-are-zero modes. Applied to the components' states right after each
 * explicit (sub)step, before the projection: the core's hybrid_step_tab and a circuit's generated substep. */
#define HH_SMALLEST_NORMAL 2.2250738585072014e-308
HH_INLINE double hh_unsubnormal(double x) { return fabs(x) < HH_SMALLEST_NORMAL ? 0.0 * x : x; }

#endif
