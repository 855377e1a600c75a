/* paper_circuit.c: the paper's circuit's generated C (circuit.c) as a unit of a program that links hh_core.c too
 * (the standalone C plant, the FMU): HH_CORE_LINKED (core/core.h) leaves out the shared parts' functions, which
 * hh_core.c defines. (A file of its own, so that every unit compiles with the same flags.) */
#define HH_CORE_LINKED
#include "circuit.c"
