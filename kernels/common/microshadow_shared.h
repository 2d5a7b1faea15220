/*
 * microshadow_shared.h - layout shared by the host (C++) and the OpenCL C 1.2 kernels.
 *
 * Only layout lives here: argument structs, enums and constants. No formula may be shared between
 * the kernels and the scalar oracle (host/oracle/), so that one mistake cannot pass both.
 *
 * Every struct uses only 32-bit scalars in a fixed order so that the C++ and OpenCL C layouts agree
 * without packing pragmas (checked by static_asserts on the host side).
 */
#ifndef MICROSHADOW_SHARED_H
#define MICROSHADOW_SHARED_H

#ifdef __OPENCL_C_VERSION__
typedef uint ms_u32;
typedef int ms_i32;
#else
#include <stdint.h>
typedef uint32_t ms_u32;
typedef int32_t ms_i32;
#endif

/* Mapping of the AO visibility to the cosine of the visibility cone angle (part 1). */
#define MS_AO_COSINE 0  /* cos_t = sqrt(1 - v): the AO bake used cosine-weighted rays (default) */
#define MS_AO_UNIFORM 1 /* cos_t = 1 - v: the AO bake used uniform-weighted rays */

/* Smith form of the sample weight G2(wi,wo,wm) / G1(wi,wm). */
#define MS_FORM_HEIGHT_CORRELATED 0
#define MS_FORM_UNCORRELATED 1

/* Sample sequences. */
#define MS_SEQUENCE_SOBOL 0  /* Owen-scrambled (0,m,2)-nets in base 2, one independent scramble per replicate */
#define MS_SEQUENCE_RANDOM 1 /* independent uniform points */

/* The kernels consume points in SIMD blocks of this many lanes (float16). */
#define MS_LANES 16

/*
 * One query of the generic term: a visibility cone and an anisotropic GGX microsurface seen from wi
 * and lit from wo. Directions are unit vectors in the tangent frame (normal = +z); the host normalises.
 * cos_theta and sin2_cone are the cosine and the squared sine of the cone half-angle, both mapped from
 * visibility by the host in double: sin2_cone carries tiny cones whose float cos_theta rounds to 1.
 */
typedef struct ms_query {
    float cos_theta;
    float alpha_x;
    float alpha_y;
    float wi_x, wi_y, wi_z;
    float wo_x, wo_y, wo_z;
    float sin2_cone;
    float pad1, pad2; /* keeps the struct 48 bytes, a multiple of 16 */
} ms_query;

/*
 * Integer tallies of one query over one replicate of the point set.
 * cone: samples with both cone conditions; hemisphere: samples with both hemisphere conditions.
 */
typedef struct ms_tally {
    ms_u32 cone;
    ms_u32 hemisphere;
} ms_tally;


/*
 * LUT bakes (kernels/bake_lut.cl): one (roughness, NdotV) slice, i.e. one alpha and one wi, tallied for
 * `directions` light directions wo (NdotL rows x azimuth nodes) and `texels` visibility texels at once.
 * Visibility texel j sits at v_j = vis_min + (j + bin_offset) / bin_scale (the host maps the texel
 * convention onto scale and offset).
 */
typedef struct ms_bake_slice {
    float alpha_x, alpha_y;
    float wi_x, wi_y, wi_z;
    float vis_min;
    float bin_scale;
    float bin_offset;
    ms_u32 points;     /* points per replicate (a multiple of MS_LANES) */
    ms_u32 replicates;
    ms_u32 directions; /* number of wo directions (float4 each: x, y, z, unused) */
    ms_u32 texels;     /* visibility texel count nv */
    ms_u32 ao_weighting;
    ms_u32 cell_points; /* azimuth-stratified bakes: points per cell and replicate (0: every point, one per direction) */
    ms_u32 pad1, pad2;  /* 64 bytes */
} ms_bake_slice;

/* The histogram kernel keeps this many interleaved copies of each histogram so that consecutive
 * increments of one bin (frequent: t is concentrated) do not form one long store-to-load chain. */
#define MS_BAKE_SUBHISTOGRAMS 4


/*
 * Area lights (kernels/area_light/area_light.cl): one query = a surface (visibility cone, alpha, wi), a
 * light (sphere: a cone of directions; rect: a rectangle of positions) and the BRDF lobe that weights
 * the light's directions. The host fills every derived quantity in double (core/area_light.hpp and
 * integrands/area_light/ say what each means).
 */
#define MS_LIGHT_SPHERE 0
#define MS_LIGHT_RECT 1
#define MS_LOBE_LAMBERT 0
#define MS_LOBE_GGX 1

typedef struct ms_area_query {
    float cos_theta, sin2_cone, cot2_cone; /* the visibility cone */
    float alpha_x, alpha_y;
    float wi_x, wi_y, wi_z;
    float wis_x, wis_y, wis_z; /* the stretched view normalize(ax wi.x, ay wi.y, wi.z) */
    float lambda_i;            /* Smith Lambda of wi (GGX lobe) */
    float a_x, a_y, a_z;       /* sphere: the centre direction c;  rect: corner p0 */
    float b_x, b_y, b_z;       /* sphere: frame vector t1 (unit, perpendicular to c);  rect: edge e1 = p1 - p0 */
    float c_x, c_y, c_z;       /* sphere: t2 = c x t1;  rect: edge e2 = p3 - p0 */
    float n_x, n_y, n_z;       /* rect: the plane's unit normal, oriented so that n.p0 > 0;  sphere: unused */
    float s0;                  /* sphere: 1 - cos gamma;  rect: n.p0, the plane's distance */
    float s1;                  /* sphere: sin^2 gamma;  rect: unused */
    float inv_measure;         /* sphere: 1 / solid angle;  rect: 1 / area */
    ms_u32 shape;              /* MS_LIGHT_* */
    ms_u32 lobe;               /* MS_LOBE_* */
    ms_u32 cosine_technique;   /* lambert: 1 when half the points sample the cosine lobe (lights of over 1 sr) */
    ms_u32 pad2, pad3;         /* 128 bytes */
} ms_area_query;

/*
 * The exact (deterministic) evaluator of the term (kernels/exact/exact_term.cl). Doubles travel as
 * float pairs: value = (double)hi + (double)lo, ~48 bits, so the double kernel keeps the host's digits
 * and the float kernel simply reads hi. Directions are unit vectors (the host normalises in double).
 */
typedef struct ms_exact_query {
    float cos_theta_hi, cos_theta_lo; /* the cone's cosine and squared sine, mapped from visibility */
    float sin2_cone_hi, sin2_cone_lo;
    float alpha_x_hi, alpha_x_lo;
    float alpha_y_hi, alpha_y_lo;
    float wi_x_hi, wi_x_lo, wi_y_hi, wi_y_lo, wi_z_hi, wi_z_lo;
    float wo_x_hi, wo_x_lo, wo_y_hi, wo_y_lo, wo_z_hi, wo_z_lo; /* 80 bytes */
} ms_exact_query;

/* One LUT texel of the azimuth mean: wi = (sqrt(1 - NdotV^2), 0, NdotV), wo at every relative azimuth. */
typedef struct ms_exact_texel {
    float cos_theta_hi, cos_theta_lo;
    float sin2_cone_hi, sin2_cone_lo;
    float alpha_hi, alpha_lo;
    float n_dot_v_hi, n_dot_v_lo;
    float n_dot_l_hi, n_dot_l_lo;
    float pad1, pad2; /* 48 bytes */
} ms_exact_texel;

/* The rules of one launch: node counts and their offsets in the rule buffer (n nodes at [at, at + n),
 * their weights at [at + n, at + 2n)), the Bernstein-ellipse parameter of the arc splitting and the
 * requested absolute tolerance of each value. The arcs' rules are two Gauss-Legendre rules; the azimuth
 * pieces' are one Gauss-Kronrod pair: the same 2n + 1 nodes twice, with the Kronrod weights (high)
 * and with the Gauss weights, zero at the Kronrod-only nodes (low). */
typedef struct ms_exact_rule {
    ms_i32 arc_high, arc_low, arc_high_at, arc_low_at;
    ms_i32 azimuth_high, azimuth_low, azimuth_high_at, azimuth_low_at;
    float arc_rho;
    float tolerance_hi, tolerance_lo;
    ms_u32 pad1; /* 48 bytes */
} ms_exact_rule;

/* A value with its estimated absolute error. */
typedef struct ms_exact_value {
    float term_hi, term_lo;
    float error_hi, error_lo;
    ms_u32 quadrature_pieces;
    ms_u32 flags; /* MS_EXACT_FLAG_* */
    ms_u32 pad1, pad2; /* 32 bytes */
} ms_exact_value;

/* A piece met the bound of the kernel's fixed-size subdivision stack and was finished with the rule
 * as it stood; its integral of |f| was added to the error estimate. */
#define MS_EXACT_FLAG_STACK_FULL 1u
/* The working precision could not resolve the value (the hemisphere's probability rounded to 0): the
 * value is 0 with error 1, and the host computes it again in double. */
#define MS_EXACT_FLAG_UNRESOLVED 2u

#endif /* MICROSHADOW_SHARED_H */
