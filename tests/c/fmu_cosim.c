/* fmu_cosim.c: a closed-loop co-simulation of a hydrohil FMU (FMI 2 Co-Simulation) from its binary alone, as an
 * importer runs it: the paper's P controller (u = clamp(kp * (x_ref - x_meas), -1, 1), x_meas the encoder's
 * counts times their size) on a reference given per step, one communication step of h each, the piston's
 * position printed per step as the 16 hex digits of its IEEE 754 bits (exact, whatever the platform's printf).
 * Built for each platform an FMU carries a binary for (tests/test_fmu_platforms.py: natively, for aarch64 run
 * under qemu-user, for Windows under wine).
 *
 * usage: fmu_cosim BINARY GUID REFERENCE_FILE H KP COUNT VR_U VR_XP VR_ENCODER VR_XP0 XP0
 *   REFERENCE_FILE: x_ref of each step (n + 1 numbers, as Python's repr writes them); COUNT: the encoder's count
 *   [m]; XP0: the piston's start, set in initialisation mode
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef _WIN32
#include <windows.h>
#define LOAD(path) ((void *)LoadLibraryA(path))
#define SYMBOL(lib, name) ((void *)GetProcAddress((HMODULE)(lib), name))
#else
#include <dlfcn.h>
#define LOAD(path) dlopen(path, RTLD_NOW | RTLD_LOCAL)
#define SYMBOL(lib, name) dlsym(lib, name)
#endif
#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                   fmi2String message, ...)
{
    va_list ap;
    (void)env;
    fprintf(stderr, "[%s %d %s] ", instance ? instance : "?", (int)status, category ? category : "");
    va_start(ap, message);
    vfprintf(stderr, message, ap);
    va_end(ap);
    fputc('\n', stderr);
}

static void *symbol(void *lib, const char *name)
{
    void *f = SYMBOL(lib, name);
    if (!f) {
        fprintf(stderr, "fmu_cosim: the binary does not export %s\n", name);
        exit(2);
    }
    return f;
}

static void print_bits(double x)
{
    unsigned char b[8];
    unsigned int hi = 0, lo = 0;
    int i;
    memcpy(b, &x, 8);                 /* (little-endian on every platform this runs on) */
    for (i = 7; i >= 4; i--)
        hi = (hi << 8) | b[i];
    for (i = 3; i >= 0; i--)
        lo = (lo << 8) | b[i];
    printf("%08x%08x\n", hi, lo);
}

int main(int argc, char **argv)
{
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2InstantiateTYPE *instantiate;
    fmi2SetupExperimentTYPE *setup;
    fmi2EnterInitializationModeTYPE *enter_init;
    fmi2ExitInitializationModeTYPE *exit_init;
    fmi2SetRealTYPE *set_real;
    fmi2GetRealTYPE *get_real;
    fmi2GetIntegerTYPE *get_integer;
    fmi2DoStepTYPE *do_step;
    fmi2TerminateTYPE *terminate;
    fmi2FreeInstanceTYPE *free_instance;
    fmi2Component c;
    fmi2ValueReference vr_u, vr_xp, vr_enc, vr_xp0;
    double h, kp, count, xp0, *ref = NULL, x_ref;
    size_t n = 0, cap = 0, k;
    void *lib;
    FILE *f;
    if (argc != 12) {
        fprintf(stderr, "usage: fmu_cosim BINARY GUID REFERENCE_FILE H KP COUNT VR_U VR_XP VR_ENCODER VR_XP0 XP0\n");
        return 2;
    }
    h = atof(argv[4]);
    kp = atof(argv[5]);
    count = atof(argv[6]);
    vr_u = (fmi2ValueReference)atol(argv[7]);
    vr_xp = (fmi2ValueReference)atol(argv[8]);
    vr_enc = (fmi2ValueReference)atol(argv[9]);
    vr_xp0 = (fmi2ValueReference)atol(argv[10]);
    xp0 = atof(argv[11]);
    f = fopen(argv[3], "r");
    if (!f) {
        fprintf(stderr, "fmu_cosim: cannot read %s\n", argv[3]);
        return 2;
    }
    while (fscanf(f, "%lf", &x_ref) == 1) {
        if (n == cap) {
            cap = cap ? 2 * cap : 1024;
            ref = realloc(ref, cap * sizeof *ref);
            if (!ref)
                return 2;
        }
        ref[n++] = x_ref;
    }
    fclose(f);
    lib = LOAD(argv[1]);
    if (!lib) {
        fprintf(stderr, "fmu_cosim: cannot load %s\n", argv[1]);
        return 2;
    }
    instantiate = (fmi2InstantiateTYPE *)symbol(lib, "fmi2Instantiate");
    setup = (fmi2SetupExperimentTYPE *)symbol(lib, "fmi2SetupExperiment");
    enter_init = (fmi2EnterInitializationModeTYPE *)symbol(lib, "fmi2EnterInitializationMode");
    exit_init = (fmi2ExitInitializationModeTYPE *)symbol(lib, "fmi2ExitInitializationMode");
    set_real = (fmi2SetRealTYPE *)symbol(lib, "fmi2SetReal");
    get_real = (fmi2GetRealTYPE *)symbol(lib, "fmi2GetReal");
    get_integer = (fmi2GetIntegerTYPE *)symbol(lib, "fmi2GetInteger");
    do_step = (fmi2DoStepTYPE *)symbol(lib, "fmi2DoStep");
    terminate = (fmi2TerminateTYPE *)symbol(lib, "fmi2Terminate");
    free_instance = (fmi2FreeInstanceTYPE *)symbol(lib, "fmi2FreeInstance");
    c = instantiate("cosim", fmi2CoSimulation, argv[2], "", &cb, fmi2False, fmi2False);
    if (!c || setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK || enter_init(c) != fmi2OK ||
        set_real(c, &vr_xp0, 1, &xp0) != fmi2OK || exit_init(c) != fmi2OK) {
        fprintf(stderr, "fmu_cosim: the FMU did not initialise\n");
        return 1;
    }
    for (k = 0; k < n; k++) {
        double xp, u;
        fmi2Integer enc;
        if (get_real(c, &vr_xp, 1, &xp) != fmi2OK || get_integer(c, &vr_enc, 1, &enc) != fmi2OK)
            return 1;
        print_bits(xp);
        if (k + 1 == n)
            break;
        u = kp * (ref[k] - (double)enc * count);
        u = u > 1.0 ? 1.0 : u < -1.0 ? -1.0 : u;
        if (set_real(c, &vr_u, 1, &u) != fmi2OK || do_step(c, (double)k * h, h, fmi2True) != fmi2OK)
            return 1;
    }
    terminate(c);
    free_instance(c);
    free(ref);
    return 0;
}
