#include "pixel.h"
#include <math.h>

void wdr_pixel_nominal(const wdr_board *b, wdr_pixel_dev *d)
{
    d->vdd = b->vdd_v;
    d->reset_gate = b->reset_gate_v;
    d->vt0_m1 = d->vt0_m2 = d->vt0_m3 = b->vt0_v;
    d->gamma = b->gamma_sqrt_v;
    d->phi2f = b->phi2f_v;
    d->c_pd = b->c_pd_f;
    d->c_pd_ref_v = b->c_pd_ref_v;
    d->pb = b->pb_v;
    d->mj = b->mj;
    d->beta3 = b->kp_a_per_v2 * b->m3.w_um / b->m3.l_um;
    d->sf_bias = b->sf_bias_a;
}

double wdr_vt(double vt0, double gamma, double phi2f, double vsb)
{
    double s = phi2f + vsb;
    return vt0 + gamma * (sqrt(s > 0 ? s : 0) - sqrt(phi2f));
}

/* Solve f(v) = 0 for an increasing f on [lo, hi] by bisection: the device curves here
 * are monotone, and 60 halvings reach double precision on any sane interval. */
static double solve_increasing(double (*f)(const wdr_pixel_dev *, double, double), const wdr_pixel_dev *d,
                               double target, double lo, double hi)
{
    for (int i = 0; i < 60; i++) {
        double mid = 0.5 * (lo + hi);
        if (f(d, mid, target) < 0)
            lo = mid;
        else
            hi = mid;
    }
    return 0.5 * (lo + hi);
}

static double reset_residual(const wdr_pixel_dev *d, double v, double unused)
{
    (void)unused;
    return v + wdr_vt(d->vt0_m1, d->gamma, d->phi2f, v) - d->reset_gate;
}

double wdr_pixel_reset_level(const wdr_pixel_dev *d)
{
    double v = solve_increasing(reset_residual, d, 0, -d->phi2f, d->reset_gate);
    return v < d->vdd ? v : d->vdd;
}

/* C(V) = c_pd * ((1 + Vref/pb) / (1 + V/pb))^mj, so Q has a closed form and an inverse. */
double wdr_pixel_charge(const wdr_pixel_dev *d, double v)
{
    double k = d->c_pd * pow(1.0 + d->c_pd_ref_v / d->pb, d->mj);
    double e = 1.0 - d->mj;
    return k * d->pb / e * (pow(1.0 + v / d->pb, e) - 1.0);
}

double wdr_pixel_voltage(const wdr_pixel_dev *d, double q)
{
    double k = d->c_pd * pow(1.0 + d->c_pd_ref_v / d->pb, d->mj);
    double e = 1.0 - d->mj;
    double base = 1.0 + q * e / (k * d->pb);
    if (base <= 0)
        return -d->pb; /* fully forward-biased: the node cannot fall further */
    return d->pb * (pow(base, 1.0 / e) - 1.0);
}

double wdr_pixel_turnoff_node(const wdr_pixel_dev *d, double v_g)
{
    return v_g + wdr_vt(d->vt0_m2, d->gamma, d->phi2f, v_g);
}

static double dark_residual(const wdr_pixel_dev *d, double v, double v_n0)
{
    return wdr_pixel_turnoff_node(d, v) - v_n0;
}

double wdr_pixel_dark_level(const wdr_pixel_dev *d, double v_n0)
{
    return solve_increasing(dark_residual, d, v_n0, -d->phi2f, v_n0);
}

static double sf_residual(const wdr_pixel_dev *d, double vo, double v_g)
{
    return vo + wdr_vt(d->vt0_m3, d->gamma, d->phi2f, vo) + sqrt(2.0 * d->sf_bias / d->beta3) - v_g;
}

double wdr_pixel_sf_out(const wdr_pixel_dev *d, double v_g)
{
    return solve_increasing(sf_residual, d, v_g, -d->phi2f, v_g);
}
