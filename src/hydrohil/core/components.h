/* components.h: the hydraulic component library's laws (SPEC §12.3), SI units, gauge pressures [Pa].
 *
 * Each component is a few inline functions over its parameters and its ports' values, returning flows
 * [m^3/s] (positive from its port a to its port b, or out of a source), capacitances [m^3/Pa] and the guards
 * of its modes. A generated circuit (hydrohil.circuits) calls them in a fixed order inside its right-hand
 * side, so the compiler sees the whole model. Their declarations (ports, parameters with unit, range and
 * description, states, modes) are in hydrohil/circuits/library.py; each law is its own file hc_<name>.h. */
#ifndef HH_COMPONENTS_H
#define HH_COMPONENTS_H
#include "core.h"

#include "hc_sqrt_law.h"
#include "hc_orifice.h"
#include "hc_pump.h"
#include "hc_relief_valve.h"
#include "hc_accumulator.h"
#include "hc_hose.h"
#include "hc_end_stops.h"
#include "hc_load.h"
#include "hc_motor.h"
#include "hc_valve_43.h"
#include "hc_counterbalance.h"
#include "hc_servo_valve.h"
#include "hc_lugre_cylinder.h"
#include "hc_node.h"

#endif
