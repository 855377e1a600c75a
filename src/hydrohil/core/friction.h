/* friction.h: LuGre friction with asymmetric static parameters (SPEC §5, eq 25). The static set of
 * each direction is in the model slots HH_FC_POS.. HH_KV_NEG (hh_params_derive). */
#ifndef HH_FRICTION_H
#define HH_FRICTION_H
#include "core.h"
#include "hc_lugre.h"

HH_INLINE double stribeck(double v, const double *p);
HH_INLINE double viscous(double v, const double *p);
HH_INLINE double slip_friction(double v, int direction, const double *p);
HH_INLINE double lugre(double v, double z, const double *p, double *dz);

#endif
