/* sombra — phase functions of single scattering (Ament et al. 2014 Eq. 1–3), shared verbatim by
 * the kernels (lane types) and the C++ tests (float). cos_theta is the cosine of the scattering
 * angle between the direction the light travels and the direction towards the viewer. */
#ifndef SOMBRA_SHARED_PHASE_H
#define SOMBRA_SHARED_PHASE_H

#define SOMBRA_INV_4PI 0.0795774715f

/* Henyey–Greenstein: p(θ) = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}); g = 0 is isotropic 1/(4π),
 * g > 0 scatters forward. Integrates to 1 over the sphere for every g in (−1, 1). */
#define SOMBRA_HG_PHASE(g, cos_theta) \
    ((1.0f - (g) * (g)) * SOMBRA_INV_4PI / ((1.0f + (g) * (g) - 2.0f * (g) * (cos_theta)) * sqrt(1.0f + (g) * (g) - 2.0f * (g) * (cos_theta))))

#endif
