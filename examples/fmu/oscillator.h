/* The physics of the example FMU, shared by its FMI 2.0 and FMI 3.0 interfaces.
 *
 * A damped single-mass oscillator released from rest at x0 under a constant force:
 *     m x'' + c x' + k x = F,   x(0) = x0,   x'(0) = 0,
 * with the underdamped closed-form solution (sigma = c / (2 m), omega_d = sqrt(k/m - sigma^2),
 * x_s = F / k, A = x0 - x_s):
 *     x(t) = x_s + exp(-sigma t) A (cos(omega_d t) + sigma / omega_d sin(omega_d t))
 *     v(t) = -exp(-sigma t) A (sigma^2 / omega_d + omega_d) sin(omega_d t).
 * Model exchange integrates the state equations (the importer's solver); co-simulation steps
 * with the closed form, so a co-simulation run equals the closed form to rounding.
 */
#ifndef OSCILLATOR_H
#define OSCILLATOR_H

#include <math.h>
#include <stdio.h>

typedef struct {
    double m, c, k, x0, F;   /* parameters [kg], [N s/m], [N/m], [m], [N] */
    int order;               /* an integer parameter (never fuzzy: it tests the type check) */
    double time, start_time; /* [s] */
    double x, v;             /* states [m], [m/s] */
} Oscillator;

static void oscillator_defaults(Oscillator *o) {
    o->m = 1.0; o->c = 0.4; o->k = 100.0; o->x0 = 0.01; o->F = 0.0;
    o->order = 2;
    o->time = 0.0; o->start_time = 0.0;
    o->x = o->x0; o->v = 0.0;
}

/* Why the parameters cannot be simulated (message written to `why`), or 0 if they can. */
static int oscillator_invalid(const Oscillator *o, char *why, size_t size) {
    if (!(o->m > 0.0)) { snprintf(why, size, "mass m = %g must be positive", o->m); return 1; }
    if (!(o->k > 0.0)) { snprintf(why, size, "stiffness k = %g must be positive", o->k); return 1; }
    if (!(o->c >= 0.0)) { snprintf(why, size, "damping c = %g must not be negative", o->c); return 1; }
    if (o->c * o->c >= 4.0 * o->m * o->k) {
        snprintf(why, size, "c = %g is not below critical damping 2 sqrt(k m) = %g", o->c,
                 2.0 * sqrt(o->k * o->m));
        return 1;
    }
    return 0;
}

static double oscillator_omega0(const Oscillator *o) { return sqrt(o->k / o->m); }

/* The closed-form state at o->time (co-simulation and the initial state). */
static void oscillator_closed_form(Oscillator *o) {
    double t = o->time - o->start_time;
    double sigma = o->c / (2.0 * o->m);
    double wd = sqrt(o->k / o->m - sigma * sigma);
    double xs = o->F / o->k, a = o->x0 - xs, decay = exp(-sigma * t);
    o->x = xs + decay * a * (cos(wd * t) + sigma / wd * sin(wd * t));
    o->v = -decay * a * (sigma * sigma / wd + wd) * sin(wd * t);
}

static void oscillator_derivatives(const Oscillator *o, double *dx, double *dv) {
    *dx = o->v;
    *dv = (o->F - o->c * o->v - o->k * o->x) / o->m;
}

/* Value references of the Float64 / Real variables (shared by both interfaces). */
enum { VR_M = 0, VR_C, VR_K, VR_X0, VR_F, VR_OMEGA0, VR_X, VR_V, VR_DER_X, VR_DER_V, VR_ORDER, VR_TIME };

static int oscillator_get(const Oscillator *o, unsigned vr, double *value) {
    double dx, dv;
    oscillator_derivatives(o, &dx, &dv);
    switch (vr) {
        case VR_M: *value = o->m; return 1;
        case VR_C: *value = o->c; return 1;
        case VR_K: *value = o->k; return 1;
        case VR_X0: *value = o->x0; return 1;
        case VR_F: *value = o->F; return 1;
        case VR_OMEGA0: *value = oscillator_omega0(o); return 1;
        case VR_X: *value = o->x; return 1;
        case VR_V: *value = o->v; return 1;
        case VR_DER_X: *value = dx; return 1;
        case VR_DER_V: *value = dv; return 1;
        case VR_TIME: *value = o->time; return 1;
        default: return 0;
    }
}

static int oscillator_set(Oscillator *o, unsigned vr, double value) {
    switch (vr) {
        case VR_M: o->m = value; return 1;
        case VR_C: o->c = value; return 1;
        case VR_K: o->k = value; return 1;
        case VR_X0: o->x0 = value; return 1;
        case VR_F: o->F = value; return 1;
        default: return 0;
    }
}

#endif
