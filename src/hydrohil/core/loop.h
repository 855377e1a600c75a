/* loop.h: the one sampled loop: controller (or open-loop command) -> input delay -> model step -> log.
 * It serves simulate (hybrid model, any tableau), maxstep (the continuous model at a fixed step), the
 * stiff reference (a SciPy step behind a callback) and the per-step API of the rig and the HIL plant. */
#ifndef HH_LOOP_H
#define HH_LOOP_H
#include "hybrid.h"
#include "reference.h"
#include "delay.h"
#include "sensors.h"
#include "control.h"

#endif
