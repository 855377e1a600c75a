/* hh_compat.h: what makes every build of the sources give the same numbers and load where it should, included by
 * every unit (through hh.h, and the FMU layer's fmu_instance.h), so the sources need no flags of their own (a
 * source-code FMU rebuilt by an importer for its target, a standalone plant built with make):
 *
 * - no fused multiply-add: a*b + c rounded twice, as IEEE 754 arithmetic written out (the build's
 *   -ffp-contract=off too). The standard's pragma for clang and MSVC; GCC ignores it, so where GCC may fuse
 *   (__FP_FAST_FMA: an FMA unit, e.g. aarch64 or -mfma) its optimize pragma says the same;
 * - HH_GLIBC_COMPAT (the exports' own binaries, export/fmu.py): the glibc symbols the code uses bound at their
 *   oldest version (exp, log, memcpy: glibc 2.29 and 2.14 gave them new ones, the same results for every value
 *   the model takes), so an FMU's binary loads on any glibc of its architecture (x86-64: 2.2.5, aarch64: 2.17). */
#ifndef HH_COMPAT_H
#define HH_COMPAT_H
#include <stdint.h>             /* (glibc's: __GLIBC__) */

#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#if defined(__FP_FAST_FMA)
#pragma GCC optimize("fp-contract=off")
#endif
#elif defined(_MSC_VER)
#pragma fp_contract(off)
#endif

#if defined(HH_GLIBC_COMPAT) && defined(__GLIBC__)
#if defined(__x86_64__)
__asm__(".symver exp,exp@GLIBC_2.2.5");
__asm__(".symver log,log@GLIBC_2.2.5");
__asm__(".symver memcpy,memcpy@GLIBC_2.2.5");
#elif defined(__aarch64__)
__asm__(".symver exp,exp@GLIBC_2.17");
__asm__(".symver log,log@GLIBC_2.17");
#endif
#endif

#endif
